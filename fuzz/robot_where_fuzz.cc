// Robot controllers: the VAL / AS monitor (WHERE readouts, commands) and the encoder
// counter box's replies.
#include "fuzz/fuzz_support.h"
#include "robots/robot_codec.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace armsig;
  const std::string_view line = fuzz::Text(data, size);
  fuzz::ExpectOnlyInputErrors("robot monitor", [&] {
    (void)robots::ParseMonitorLine(line);
    (void)robots::ParseMonitorCommand(line);
    (void)robots::ParseWhere(line);
    (void)robots::ParseCounterRequest(line);
    (void)robots::ParseCounterReply(line);
  });
  return 0;
}
