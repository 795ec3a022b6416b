// Robot controllers: the VAL / AS monitor (WHERE readouts, commands) and the encoder
// counter box's replies.
#include "fuzz/fuzz_support.h"
#include "instruments/robot_codec.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace armsig;
  const std::string_view line = fuzz::Text(data, size);
  fuzz::ExpectOnlyInputErrors("robot monitor", [&] {
    (void)instruments::ParseMonitorLine(line);
    (void)instruments::ParseMonitorCommand(line);
    (void)instruments::ParseWhere(line);
    (void)instruments::ParseCounterRequest(line);
    (void)instruments::ParseCounterReply(line);
  });
  return 0;
}
