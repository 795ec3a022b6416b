// emScon TPI byte streams: the frame splitter fed in pieces of every size the input
// chooses, then every frame through the packet and the command decoders, and what decodes
// encoded again (it must decode to the same packet). The codec never throws: a decoder
// refuses with a typed error, so any exception, crash or undefined behaviour is a finding.
#include <cstdint>
#include <cstdlib>
#include <string>
#include <string_view>

#include "fuzz/fuzz_support.h"
#include "instruments/emscon_codec.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  namespace es = armsig::instruments::emscon;
  const std::string_view bytes = armsig::fuzz::Text(data, size);
  // The first byte chooses the read size (1 … 256), so splits fall everywhere.
  const size_t step = size > 0 ? size_t{static_cast<uint8_t>(bytes[0])} + 1 : 1;
  es::FrameSplitter splitter;
  std::string frame;
  size_t frames = 0;
  for (size_t at = 0; at < size; at += step) {
    splitter.Append(bytes.substr(at, step));
    for (;;) {
      const auto status = splitter.Next(frame);
      if (status != es::FrameSplitter::Status::kFrame) break;
      ++frames;
      if (frame.size() < static_cast<size_t>(es::kMinPacketBytes) ||
          frame.size() > static_cast<size_t>(es::kMaxPacketBytes)) {
        std::abort();  // the splitter handed out a frame outside its bounds
      }
      const es::DecodedPacket packet = es::DecodePacket(frame);
      if (packet.packet && packet.error) std::abort();
      if (packet.packet) {
        (void)es::PacketTypeName(packet.type);
        const es::DecodedPacket again = es::DecodePacket(es::EncodePacket(*packet.packet));
        if (!again.packet) std::abort();  // what decodes must encode to something decodable
      }
      const es::DecodedRequest request = es::DecodeRequest(frame);
      if (request.request) {
        (void)es::CommandName(es::CommandOf(*request.request));
        const es::DecodedRequest again = es::DecodeRequest(es::EncodeRequest(*request.request));
        if (!again.request || es::CommandOf(*again.request) != es::CommandOf(*request.request)) {
          std::abort();
        }
      }
    }
  }
  // The whole input as one frame too (what a caller with its own framing would pass).
  (void)es::DecodePacket(bytes);
  (void)es::DecodeRequest(bytes);
  (void)frames;
  return 0;
}
