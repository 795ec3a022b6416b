#include "instruments/geocom_device.h"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <cmath>
#include <numbers>

#include "instruments/line_retry.h"

namespace armsig::instruments {

using geocom::CodeClass;

GeoComDevice::GeoComDevice(std::unique_ptr<LineTransport> transport, RetryPolicy policy,
                           bool use_crc)
    : transport_(std::move(transport)), policy_(policy), use_crc_(use_crc) {
  transport_->SetMaxLineBytes(geocom::kMaxLineBytes);
}

int GeoComDevice::NextTransactionId() {
  trid_ = (trid_ + 1) % 32768;  // 0…32767, then back to 0
  if (trid_ == 0) trid_ = 1;
  return trid_;
}

geocom::Reply GeoComDevice::Call(int rpc, const std::vector<std::string>& params) {
  return Call(rpc, params, CallDeadline());
}

geocom::Reply GeoComDevice::Call(int rpc, const std::vector<std::string>& params,
                                 Deadline deadline) {
  ++stats_.requests;
  const auto start = Clock::now();
  std::string last_error = "no attempt before the deadline";
  int last_code = grc::kComTimedOut;
  // This call's transaction ids: a late reply to an earlier attempt of the same request
  // is still its reply (a slow instrument is not asked twice for nothing).
  std::vector<int> sent;
  int attempt = 0;
  for (; attempt < policy_.attempts && Clock::now() < deadline; ++attempt) {
    if (attempt > 0) ++stats_.retries;
    const Deadline until = AttemptDeadline(deadline, policy_.attempts - attempt);
    int stale = 0;
    try {
      if (!transport_->IsOpen()) {
        transport_->Open();
        ++stats_.reconnects;
        transport_->Drain(Millis(20), until);
      }
      const int trid = NextTransactionId();
      sent.push_back(trid);
      transport_->Write(geocom::EncodeRequest({rpc, trid, params}, use_crc_), until);
      bool retry = false;
      while (!retry) {
        const std::string line = transport_->ReadLine(until);
        const auto parsed = geocom::ParseReply(line, use_crc_);
        if (parsed.error == geocom::ParseError::kNotAFrame ||
            parsed.error == geocom::ParseError::kMalformed) {
          ++stats_.noise_lines;  // garbage on the line: skip it (the deadline still runs)
          spdlog::debug("{}: skipped a line that is no GeoCOM reply: {}", name(), parsed.why);
          continue;
        }
        if (parsed.error == geocom::ParseError::kBadCrc ||
            parsed.error == geocom::ParseError::kMissingCrc) {
          ++stats_.crc_errors;
          const bool missing = parsed.error == geocom::ParseError::kMissingCrc;
          last_error = (missing ? "reply without a CRC on a CRC link: "
                                : "reply failed its CRC check: ") +
                       parsed.why;
          last_code = missing ? grc::kComNoChecksum : grc::kComClntRxChecksumError;
          retry = true;
          break;
        }
        const geocom::Reply& reply = *parsed.reply;
        if (std::find(sent.begin(), sent.end(), reply.trid) == sent.end()) {
          ++stats_.stale_replies;  // a late reply to an earlier request
          ++stale;
          continue;
        }
        const int code = reply.rc_com != 0 ? reply.rc_com : reply.rc;
        if (geocom::Classify(code) == CodeClass::kBusy) {
          ++stats_.busy;
          last_error = geocom::CodeName(code) + ": " + geocom::CodeMeaning(code);
          last_code = code;
          transport_->Pause(policy_.busy_delay, deadline);
          retry = true;
          break;
        }
        if (reply.rc_com ==
            grc::kComSrvrRxChecksumError) {  // the instrument saw our CRC as bad: send again
          ++stats_.crc_errors;
          last_error = "instrument reports a checksum error";
          last_code = grc::kComSrvrRxChecksumError;
          retry = true;
          break;
        }
        if (reply.rc_com != 0) {
          throw InstrumentError(
              name(), reply.rc_com,
              geocom::CodeName(reply.rc_com) + ": " + geocom::CodeMeaning(reply.rc_com));
        }
        return reply;
      }
    } catch (const TransportError& e) {
      if (e.kind() == TransportError::Kind::kInterrupted) throw;
      last_error = e.message();
      last_code = CodeOf(e);
      if (e.kind() == TransportError::Kind::kTimeout && stale > 0) {
        last_error = std::to_string(stale) + " replies carried other transaction ids than " +
                     std::to_string(sent.back());
        last_code = grc::kComTrIdMismatch;
      }
      // A timeout: a late reply may still arrive and will be dropped by its transaction
      // id. An over-long line: what is left of it (a flood's bytes still in the port)
      // is drained, for a short while, so the next attempt starts on a clean line. A
      // lost port: reopen after a pause.
      if (e.kind() == TransportError::Kind::kLineTooLong) {
        ++stats_.long_lines;
        try {
          transport_->Drain(Millis(50), std::min(deadline, Clock::now() + kMaxDrain));
        } catch (const TransportError& d) {
          if (d.kind() == TransportError::Kind::kInterrupted) throw;
          transport_->Close();
        }
      } else if (e.kind() != TransportError::Kind::kTimeout) {
        transport_->Close();
        transport_->Pause(policy_.reconnect_delay, deadline);
      }
    }
  }
  throw InstrumentError(name(), last_code,
                        "RPC " + std::to_string(rpc) + ": " + geocom::CodeName(last_code) + ": " +
                            GaveUp(attempt, start, last_error));
}

DeviceInfo GeoComDevice::Identify() {
  const Deadline deadline = CallDeadline();  // the three RPCs share one deadline
  auto values = [&](int rpc) {
    const auto r = Call(rpc, {}, deadline);
    if (r.rc != 0) throw InstrumentError(name(), r.rc, geocom::CodeName(r.rc));
    return r.values;
  };
  std::string why;
  auto decoded = [&](auto value) {
    if (!value) throw InstrumentError(name(), grc::kComCantDecode, why);
    return *value;
  };
  DeviceInfo info;
  info.name = decoded(geocom::DecodeStringValue(values(geocom::rpc::kGetInstrumentName),
                                                "CSV_GetInstrumentName", &why));
  info.serial = std::to_string(decoded(geocom::DecodeLongValue(
      values(geocom::rpc::kGetInstrumentNo), "CSV_GetInstrumentNo", &why)));
  const auto firmware =
      decoded(geocom::DecodeVersion(values(geocom::rpc::kGetFirmwareVersion), &why));
  info.firmware = std::to_string(firmware.release) + "." + std::to_string(firmware.version) + "." +
                  std::to_string(firmware.subversion);
  return info;
}

void GeoComDevice::ThrowIfNoData(const geocom::Reply& reply) const {
  if (geocom::Classify(reply.rc) == CodeClass::kError) {
    throw InstrumentError(name(), reply.rc,
                          geocom::CodeName(reply.rc) + ": " + geocom::CodeMeaning(reply.rc));
  }
}

Reading GeoComDevice::StartReading(const geocom::Reply& reply) const {
  Reading r;
  r.time = std::chrono::system_clock::now();
  r.return_code = reply.rc;
  if (reply.rc != 0) r.note = geocom::CodeName(reply.rc) + ": " + geocom::CodeMeaning(reply.rc);
  return r;
}

Reading GeoComDevice::MeasureAngles() {
  const auto reply = Call(geocom::rpc::kGetAngleComplete, {"1"});
  ThrowIfNoData(reply);
  std::string why;
  const auto a = geocom::DecodeAngleComplete(reply.values, &why);
  if (!a) throw InstrumentError(name(), grc::kComCantDecode, why);
  CheckAngles(name(), a->hz_rad, a->v_rad);
  Reading r = StartReading(reply);
  r.angles = {a->hz_rad, a->v_rad, a->face == 1 ? 2 : 1};
  return r;
}

Reading GeoComDevice::MeasureAnglesSimple() {
  const auto reply = Call(geocom::rpc::kGetAngleSimple, {"1"});
  ThrowIfNoData(reply);
  std::string why;
  const auto a = geocom::DecodeAngleSimple(reply.values, &why);
  if (!a) throw InstrumentError(name(), grc::kComCantDecode, why);
  CheckAngles(name(), a->hz_rad, a->v_rad);
  Reading r = StartReading(reply);
  r.angles = {a->hz_rad, a->v_rad, a->v_rad > std::numbers::pi ? 2 : 1};
  return r;
}

Reading GeoComDevice::MeasureDistanceAndAngles() {
  const Deadline deadline = CallDeadline();  // both RPCs share one deadline
  const auto start = Call(geocom::rpc::kDoMeasure, {"1", "1"}, deadline);  // DEF_DIST, AUTO_INC
  ThrowIfNoData(start);
  const auto reply = Call(geocom::rpc::kGetSimpleMea, {"5000", "1"}, deadline);
  ThrowIfNoData(reply);
  std::string why;
  const auto m = geocom::DecodeSimpleMeasurement(reply.values, &why);
  if (!m) throw InstrumentError(name(), grc::kComCantDecode, why);
  CheckAngles(name(), m->hz_rad, m->v_rad);
  Reading r = StartReading(reply);
  r.angles = {m->hz_rad, m->v_rad, m->v_rad > std::numbers::pi ? 2 : 1};
  // Angles-only codes: the distance is not valid even if a number is present.
  if (geocom::Classify(reply.rc) != CodeClass::kAnglesOnly) {
    if (!m->slope_distance_m)
      throw InstrumentError(name(), grc::kComCantDecode,
                            "TMC_GetSimpleMea: reply has no slope distance");
    CheckDistance(name(), *m->slope_distance_m * 1000.0);
    if (*m->slope_distance_m > 0) r.distance_mm = *m->slope_distance_m * 1000.0;
  }
  if (!r.distance_mm && r.return_code == 0) {
    throw InstrumentError(name(), grc::kTmcDistError, "TMC_DIST_ERROR: no distance in the reply");
  }
  return r;
}

int GeoComDevice::Face() {
  const auto r = Call(geocom::rpc::kGetFace, {});
  if (r.rc != 0) throw InstrumentError(name(), r.rc, "TMC_GetFace failed: " + geocom::CodeName(r.rc));
  std::string why;
  const auto face = geocom::DecodeLongValue(r.values, "TMC_GetFace", &why);
  if (!face) throw InstrumentError(name(), grc::kComCantDecode, why);
  return *face == 1 ? 2 : 1;
}

void GeoComDevice::ChangeFace() {
  const auto r = Call(geocom::rpc::kChangeFace, {"0", "0", "0"});
  if (r.rc != 0)
    throw InstrumentError(name(), r.rc, geocom::CodeName(r.rc) + ": " + geocom::CodeMeaning(r.rc));
}

bool GeoComDevice::CompensatorOn() {
  const auto r = Call(geocom::rpc::kGetInclineSwitch, {});
  if (r.rc != 0)
    throw InstrumentError(name(), r.rc, "TMC_GetInclineSwitch failed: " + geocom::CodeName(r.rc));
  std::string why;
  const auto on = geocom::DecodeLongValue(r.values, "TMC_GetInclineSwitch", &why);
  if (!on) throw InstrumentError(name(), grc::kComCantDecode, why);
  return *on == 1;
}

void GeoComDevice::FineAdjust(double search_hz_rad, double search_v_rad) {
  const auto r = Call(geocom::rpc::kFineAdjust, {geocom::EncodeDouble(search_hz_rad),
                                                 geocom::EncodeDouble(search_v_rad), "0"});
  if (r.rc != 0)
    throw InstrumentError(name(), r.rc, geocom::CodeName(r.rc) + ": " + geocom::CodeMeaning(r.rc));
}

void GeoComDevice::PositionTo(double hz_rad, double v_rad, bool atr) {
  const auto r =
      Call(geocom::rpc::kMakePositioning,
           {geocom::EncodeDouble(hz_rad), geocom::EncodeDouble(v_rad), "0", atr ? "1" : "0", "0"});
  if (r.rc != 0)
    throw InstrumentError(name(), r.rc, geocom::CodeName(r.rc) + ": " + geocom::CodeMeaning(r.rc));
}

}  // namespace armsig::instruments
