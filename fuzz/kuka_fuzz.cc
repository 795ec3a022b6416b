// KUKA variable server byte streams (KukaVarProxy / C3 Bridge): the frame splitter fed in
// pieces of every size the input chooses, as a client (responses) and as a server
// (requests), every frame through its decoder and what decodes encoded again (it must
// decode to the same message), every value through the KRL value parsers (what parses as
// axes must format to text that parses to the same axes), and the input as a $CONFIG.DAT
// fragment. The codec never throws, except ParseDeclarations, which refuses a malformed
// DECL line with std::invalid_argument; any other exception, a crash or undefined behaviour
// is a finding.
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <stdexcept>
#include <string>
#include <string_view>

#include "fuzz/fuzz_support.h"
#include "robots/kuka_codec.h"

namespace {

namespace kuka = armsig::robots::kuka;

void Values(std::string_view text) {
  (void)kuka::ParseBool(text);
  (void)kuka::ParseInt(text);
  (void)kuka::ParseReal(text);
  (void)kuka::ParseEnum(text);
  (void)kuka::ParseString(text);
  (void)kuka::ParsePose(text);
  if (const auto s = kuka::ParseStructure(text)) {
    if (s->components.empty()) std::abort();
  }
  for (int axes : {1, 6}) {
    const auto q = kuka::ParseAxes(text, axes);
    if (!q) continue;
    const auto again = kuka::ParseAxes(kuka::FormatAxes(*q), axes);
    if (!again) std::abort();  // formatted axes must parse
    for (int i = 0; i < axes; ++i) {
      const double tolerance = 1e-8 * std::max(1.0, std::abs((*q)(i)));
      if (!(std::abs((*again)(i) - (*q)(i)) <= tolerance)) std::abort();
    }
  }
}

void Frames(std::string_view bytes, size_t step, const armsig::instruments::FrameSplitter::Format& format) {
  armsig::instruments::FrameSplitter splitter(format);
  std::string frame;
  for (size_t at = 0; at < bytes.size(); at += step) {
    splitter.Append(bytes.substr(at, step));
    while (splitter.Next(frame) == armsig::instruments::FrameSplitter::Status::kFrame) {
      if (static_cast<int64_t>(frame.size()) < format.min_bytes ||
          static_cast<int64_t>(frame.size()) > format.max_bytes)
        std::abort();  // the splitter handed out a frame outside its bounds
      const auto response = kuka::DecodeResponse(frame);
      if (response.response) {
        if (!response.why.empty()) std::abort();
        const auto again = kuka::DecodeResponse(kuka::EncodeResponse(*response.response));
        if (!again.response || again.response->value != response.response->value ||
            again.response->tag != response.response->tag)
          std::abort();
        Values(response.response->value);
      }
      const auto request = kuka::DecodeRequest(frame);
      if (request.request && request.request->name.size() <= kuka::kMaxNameBytes) {
        const auto again = kuka::DecodeRequest(kuka::EncodeRequest(*request.request));
        if (!again.request || again.request->name != request.request->name ||
            again.request->value != request.request->value)
          std::abort();
      }
    }
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string_view bytes = armsig::fuzz::Text(data, size);
  // The first byte chooses the read size (1 … 256), so splits fall everywhere.
  const size_t step = size > 0 ? size_t{static_cast<uint8_t>(bytes[0])} + 1 : 1;
  Frames(bytes, step, kuka::kResponseFrames);
  Frames(bytes, step, kuka::kRequestFrames);
  (void)kuka::DecodeResponse(bytes);
  (void)kuka::DecodeRequest(bytes);
  Values(bytes);
  try {
    (void)kuka::ParseDeclarations(bytes);
  } catch (const std::invalid_argument&) {
    // a malformed DECL line, refused with its line number
  }
  return 0;
}
