#include "instruments/gsi_device.h"

#include <spdlog/spdlog.h>

#include <numbers>

#include "instruments/line_retry.h"

namespace armsig::instruments {

GsiOnlineDevice::GsiOnlineDevice(std::unique_ptr<LineTransport> transport, RetryPolicy policy)
    : transport_(std::move(transport)), policy_(policy) {
  transport_->SetMaxLineBytes(gsi::kMaxOnlineLineBytes);
}

gsi::Word GsiOnlineDevice::Get(char mode, int wi) {
  return Get(mode, wi, Clock::now() + policy_.timeout);
}

gsi::Word GsiOnlineDevice::Get(char mode, int wi, Deadline deadline) {
  gsi::OnlineRequest request;
  request.mode = mode;
  request.wi = wi;
  const std::string command = gsi::FormatOnlineRequest(request);
  return WithRetries(*transport_, policy_, deadline, [&](Deadline until) -> gsi::Word {
    transport_->Write(command, until);
    int other_words = 0, noise = 0;  // skipped against the deadline
    for (;;) {
      std::string why;
      std::string line;
      try {
        line = transport_->ReadLine(until);
      } catch (const TransportError& e) {
        if (e.kind() != TransportError::Kind::kTimeout || other_words + noise == 0) throw;
        throw TransportError(e.kind(), name(),
                             "no WI" + std::to_string(wi) + " by the deadline: " +
                                 std::to_string(other_words) + " other words and " +
                                 std::to_string(noise) + " other lines skipped");
      }
      const auto reply = gsi::ParseOnlineReply(line, &why);
      if (!reply) {
        ++noise;
        spdlog::debug("{}: skipped a line that is no GSI Online reply: {}", name(), why);
        continue;
      }
      switch (reply->kind) {
        case gsi::OnlineReply::Kind::kError:
        case gsi::OnlineReply::Kind::kWarning:
          throw InstrumentError(name(), reply->code,
                                "GSI Online " + gsi::Describe(*reply) + " for GET/" +
                                    std::string(1, mode) + "/WI" + std::to_string(wi));
        case gsi::OnlineReply::Kind::kAck:
          continue;
        case gsi::OnlineReply::Kind::kWord:
          if (reply->word.wi == wi) return reply->word;
          ++other_words;
          spdlog::debug("{}: skipped word {} while waiting for word {}", name(), reply->word.wi, wi);
          continue;  // a reply to something else
      }
    }
  });
}

DeviceInfo GsiOnlineDevice::Identify() {
  const Deadline deadline = Clock::now() + policy_.timeout;  // one deadline for the call
  DeviceInfo info;
  info.name = gsi::Identifier(Get('I', 13, deadline));
  info.serial = gsi::Identifier(Get('I', 12, deadline));
  info.firmware = gsi::Identifier(Get('I', 590, deadline));
  return info;
}

Reading GsiOnlineDevice::MeasureAngles() {
  const Deadline deadline = Clock::now() + policy_.timeout;  // one deadline for the call
  const gsi::Word hz = Get('M', 21, deadline);
  const gsi::Word v = Get('I', 22, deadline);
  std::string why;
  auto hz_rad = gsi::AngleRad(hz, &why);
  if (!hz_rad) throw InstrumentError(name(), grc::kComCantDecode, "WI21: " + why);
  auto v_rad = gsi::AngleRad(v, &why);
  if (!v_rad) throw InstrumentError(name(), grc::kComCantDecode, "WI22: " + why);
  CheckAngles(name(), *hz_rad, *v_rad);
  Reading r;
  r.time = std::chrono::system_clock::now();
  r.angles = {*hz_rad, *v_rad, *v_rad > std::numbers::pi ? 2 : 1};
  return r;
}

Reading GsiOnlineDevice::MeasureDistanceAndAngles() {
  const Deadline deadline = Clock::now() + policy_.timeout;  // one deadline for the call
  const gsi::Word distance = Get('M', 31, deadline);
  std::string why;
  auto mm = gsi::LengthMm(distance, &why);
  if (!mm) throw InstrumentError(name(), grc::kComCantDecode, "WI31: " + why);
  CheckDistance(name(), *mm);
  if (!(*mm > 0)) throw InstrumentError(name(), 1292, "WI31: no distance measured");
  auto hz = gsi::AngleRad(Get('I', 21, deadline), &why);
  if (!hz) throw InstrumentError(name(), grc::kComCantDecode, "WI21: " + why);
  auto v = gsi::AngleRad(Get('I', 22, deadline), &why);
  if (!v) throw InstrumentError(name(), grc::kComCantDecode, "WI22: " + why);
  CheckAngles(name(), *hz, *v);
  Reading r;
  r.time = std::chrono::system_clock::now();
  r.angles = {*hz, *v, *v > std::numbers::pi ? 2 : 1};
  r.distance_mm = *mm;
  return r;
}

int GsiOnlineDevice::Face() { return MeasureAngles().angles.face; }

void GsiOnlineDevice::ChangeFace() {
  throw InstrumentError(name(), 5, "GSI Online has no face change: turn the telescope by hand");
}

bool GsiOnlineDevice::CompensatorOn() {
  throw InstrumentError(name(), 5, "GSI Online does not report the compensator state");
}

}  // namespace armsig::instruments
