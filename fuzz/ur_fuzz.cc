// Universal Robots byte streams: the same bytes as RTDE packages and as primary/secondary
// messages, each through its frame splitter fed in pieces of every size the input chooses,
// every frame through the decoders (a data package against armsig's output recipe), and
// what decodes encoded again (it must decode to the same values); the input's lines as
// dashboard answers and URScript lines. The codec never throws: any exception, crash or
// undefined behaviour is a finding.
#include <algorithm>
#include <cstdint>
#include <cstdlib>
#include <string>
#include <string_view>
#include <vector>

#include "fuzz/fuzz_support.h"
#include "robots/ur_codec.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  namespace ur = armsig::robots::ur;
  using armsig::instruments::FrameSplitter;
  const std::string_view bytes = armsig::fuzz::Text(data, size);
  const size_t step = size > 0 ? size_t{static_cast<uint8_t>(bytes[0])} + 1 : 1;
  const std::vector<ur::rtde::ValueType> recipe = {
      ur::rtde::ValueType::kDouble, ur::rtde::ValueType::kVector6d, ur::rtde::ValueType::kVector6d,
      ur::rtde::ValueType::kInt32,  ur::rtde::ValueType::kInt32,    ur::rtde::ValueType::kUint32};
  FrameSplitter rtde(ur::rtde::kFrames), primary(ur::primary::kFrames);
  std::string frame, why;
  for (size_t at = 0; at < size; at += step) {
    rtde.Append(bytes.substr(at, step));
    primary.Append(bytes.substr(at, step));
    while (rtde.Next(frame) == FrameSplitter::Status::kFrame) {
      const auto package = ur::rtde::Decode(frame, &why);
      if (!package) std::abort();  // the splitter's frame has its size field's length
      (void)ur::rtde::DecodeAccepted(package->payload);
      (void)ur::rtde::DecodeUrControlVersion(package->payload);
      (void)ur::rtde::DecodeSetupOutputsRequest(package->payload);
      (void)ur::rtde::DecodeProtocolVersionRequest(package->payload);
      if (const auto text = ur::rtde::DecodeText(package->payload)) {
        const auto again = ur::rtde::DecodeText(ur::rtde::Decode(ur::rtde::Text(*text), &why)->payload);
        if (!again || again->message != text->message) std::abort();
      }
      if (const auto setup = ur::rtde::DecodeSetupOutputsAnswer(package->payload)) {
        for (const auto& t : setup->types) (void)ur::rtde::ValueTypeOf(t);
      }
      if (const auto values = ur::rtde::DecodeData(package->payload, recipe, &why)) {
        const auto again = ur::rtde::DecodeData(
            ur::rtde::Decode(ur::rtde::EncodeData(values->recipe, recipe, values->values), &why)
                ->payload,
            recipe, &why);
        if (!again) std::abort();  // what decodes must encode to something decodable
      }
    }
    while (primary.Next(frame) == FrameSplitter::Status::kFrame) {
      if (const auto m = ur::primary::Decode(frame, &why)) {
        if (m->kinematics) (void)m->kinematics->ToKinematics();
      }
    }
  }
  (void)ur::primary::Decode(bytes, &why);
  // Lines: dashboard answers and script lines.
  size_t start = 0;
  while (start < bytes.size()) {
    const size_t end = std::min(bytes.find('\n', start), bytes.size());
    const std::string_view line = bytes.substr(start, end - start);
    (void)ur::dashboard::Field(line, "Robotmode");
    (void)ur::dashboard::Boolean(line);
    (void)ur::dashboard::PolyscopeVersion(line);
    (void)ur::dashboard::NotUnderstood(line);
    if (const auto move = ur::ParseMove(line, &why)) {
      const auto again = ur::ParseMove(
          move->circular ? ur::MoveC(*move->via_rad, move->joints_rad, move->a, move->v)
          : move->linear ? ur::MoveL(move->joints_rad, move->a, move->v)
                         : ur::MoveJ(move->joints_rad, move->a, move->v),
          &why);
      if (!again) std::abort();
    }
    start = end + 1;
  }
  return 0;
}
