// GeoCOM ASCII replies and requests, and the value decoders applied to a reply.
#include "fuzz/fuzz_support.h"
#include "instruments/geocom_codec.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace armsig;
  namespace g = instruments::geocom;
  const std::string_view line = fuzz::Text(data, size);
  fuzz::ExpectOnlyInputErrors("geocom", [&] {
    (void)g::ParseRequest(line);
    const auto reply = g::ParseReply(line);
    if (reply.reply) {
      const auto& values = reply.reply->values;
      (void)g::DecodeAngleComplete(values);
      (void)g::DecodeAngleSimple(values);
      (void)g::DecodeSimpleMeasurement(values);
      (void)g::DecodeDistanceAngle(values);
      (void)g::DecodeVersion(values);
      (void)g::DecodeStringValue(values, "fuzz");
      (void)g::DecodeLongValue(values, "fuzz");
      (void)g::Classify(reply.reply->rc);
      (void)g::CodeName(reply.reply->rc);
      (void)g::CodeMeaning(reply.reply->rc);
    }
    (void)g::DecodeDouble(line);
    (void)g::DecodeLong(line);
    (void)g::DecodeString(line);
    (void)g::DecodeByte(line);
  });
  return 0;
}
