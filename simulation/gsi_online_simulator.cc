#include "simulation/gsi_online_simulator.h"

#include <spdlog/spdlog.h>

#include <stdexcept>

#include "core/units.h"
#include "instruments/gsi_codec.h"

namespace armsig::simulation {

namespace gsi = instruments::gsi;

GsiOnlineSimulator::GsiOnlineSimulator(VirtualLab& lab, int station, std::string link_path,
                                       SimulatorOptions options)
    : LineSimulator(std::move(link_path), options), lab_(lab), station_(station) {}

std::optional<LineSimulator::Response> GsiOnlineSimulator::Handle(const std::string& line,
                                                                  const FaultSpec& fault) {
  using Reply = gsi::OnlineReply;
  const auto reply = [](Reply::Kind kind, int code = 0) {
    Reply r;
    r.kind = kind;
    r.code = code;
    return gsi::FormatOnlineReply(r);
  };
  if (fault.fault == Fault::kErrorCode)
    return Response{reply(Reply::Kind::kError, fault.code), options_.angle_latency};
  if (fault.fault == Fault::kBusy)
    return Response{reply(Reply::Kind::kWarning, 100), options_.angle_latency};
  const std::string invalid = reply(Reply::Kind::kWarning, 427);  // invalid command
  const auto q = gsi::ParseOnlineRequest(line);
  if (!q) return Response{invalid, std::chrono::milliseconds(5)};
  if (q->kind == gsi::OnlineRequest::Kind::kSet) {
    if (q->param != 137) return Response{invalid, std::chrono::milliseconds(5)};
    gsi16_ = q->value == 1;  // 137: GSI type, 0 GSI-8, 1 GSI-16
    return Response{reply(Reply::Kind::kAck), std::chrono::milliseconds(5)};
  }
  auto latency = std::chrono::milliseconds(5);
  if (q->mode == 'M' && (q->wi == 21 || q->wi == 22)) {
    last_ = lab_.Read(station_);
    latency = options_.angle_latency;
  } else if (q->mode == 'M' && q->wi == 31) {
    last_ = lab_.Read(station_, &last_distance_mm_);
    latency = options_.distance_latency;
  }
  Reply word;
  if (fault.fault == Fault::kOtherReply && q->kind == gsi::OnlineRequest::Kind::kGet) {
    // Another word than the one asked for (the reply to another GET).
    word.word = gsi::TextWord(q->wi == 12 ? 13 : 12, "4711", gsi16_);
    return Response{gsi::FormatOnlineReply(word), latency};
  }
  if (fault.fault == Fault::kWrongUnit && (q->wi == 21 || q->wi == 22)) {
    word.word = gsi::LengthWord(q->wi, 1234.5, gsi16_, '0');  // metres on an angle word
    return Response{gsi::FormatOnlineReply(word), latency};
  }
  if (fault.fault == Fault::kOutOfRange && q->wi == 22) {
    word.word = gsi::AngleWord(22, -WrapTwoPi(last_.v_rad), gsi16_);  // a negative zenith angle
    return Response{gsi::FormatOnlineReply(word), latency};
  }
  try {
    switch (q->wi) {
      case 21:  // a circle reading: [0, 400 gon)
        word.word = gsi::AngleWord(21, WrapTwoPi(last_.hz_rad), gsi16_);
        break;
      case 22:
        word.word = gsi::AngleWord(22, WrapTwoPi(last_.v_rad), gsi16_);
        break;
      case 31:
        word.word = gsi::LengthWord(31, last_distance_mm_, gsi16_, '8');
        break;
      case 12:
        word.word = gsi::TextWord(12, "4711", gsi16_);
        break;
      case 13:
        word.word = gsi::TextWord(13, "T2002", gsi16_);
        break;
      case 590:
        word.word = gsi::TextWord(590, "3.04", gsi16_);
        break;
      default:
        return Response{invalid, std::chrono::milliseconds(5)};
    }
  } catch (const std::out_of_range& e) {  // e.g. a distance beyond a GSI-8 word
    spdlog::warn("GSI Online simulator: {}", e.what());
    return Response{invalid, std::chrono::milliseconds(5)};
  }
  return Response{gsi::FormatOnlineReply(word), latency};
}

std::string GsiOnlineSimulator::FloodLine(const std::string& request, int64_t k) {
  // Words of the instrument, none the one asked for.
  const auto q = gsi::ParseOnlineRequest(request);
  gsi::OnlineReply word;
  word.word = gsi::TextWord(q && q->wi == 12 ? 13 : 12, std::to_string(4700 + k % 100), gsi16_);
  return gsi::FormatOnlineReply(word);
}

}  // namespace armsig::simulation
