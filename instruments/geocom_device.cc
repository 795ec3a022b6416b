#include "instruments/geocom_device.h"

#include <cmath>
#include <numbers>
#include <thread>

namespace armsig::instruments {

using geocom::CodeClass;

GeoComDevice::GeoComDevice(std::unique_ptr<LineTransport> transport, RetryPolicy policy,
                           bool use_crc)
    : transport_(std::move(transport)), policy_(policy), use_crc_(use_crc) {}

int GeoComDevice::NextTransactionId() {
  trid_ = (trid_ + 1) % 32768;  // 0…32767, then back to 0
  if (trid_ == 0) trid_ = 1;
  return trid_;
}

geocom::Reply GeoComDevice::Call(int rpc, const std::vector<std::string>& params) {
  ++stats_.requests;
  std::string last_error = "no attempt";
  int last_code = 3077;
  for (int attempt = 0; attempt < policy_.attempts; ++attempt) {
    if (attempt > 0) ++stats_.retries;
    try {
      if (!transport_->IsOpen()) {
        transport_->Open();
        ++stats_.reconnects;
        transport_->Drain(std::chrono::milliseconds(20));
      }
      const int trid = NextTransactionId();
      transport_->Write(geocom::EncodeRequest({rpc, trid, params}, use_crc_), policy_.timeout);
      const auto deadline = std::chrono::steady_clock::now() + policy_.timeout;
      bool retry = false;
      while (!retry) {
        const auto left =
            std::chrono::duration_cast<Millis>(deadline - std::chrono::steady_clock::now());
        if (left.count() <= 0) {
          throw TransportError(TransportError::Kind::kTimeout, name(), "no matching reply in time");
        }
        const std::string line = transport_->ReadLine(left);
        const auto parsed = geocom::ParseReply(line);
        if (parsed.error == geocom::ParseError::kNotAFrame ||
            parsed.error == geocom::ParseError::kMalformed) {
          ++stats_.noise_lines;  // garbage on the line: skip it
          continue;
        }
        if (parsed.error == geocom::ParseError::kBadCrc) {
          ++stats_.crc_errors;
          last_error = "reply failed its CRC check";
          last_code = 3102;
          retry = true;
          break;
        }
        const geocom::Reply& reply = *parsed.reply;
        if (reply.trid != trid) {
          ++stats_.stale_replies;  // a late reply to an earlier request
          continue;
        }
        const int code = reply.rc_com != 0 ? reply.rc_com : reply.rc;
        if (geocom::Classify(code) == CodeClass::kBusy) {
          ++stats_.busy;
          last_error = geocom::CodeName(code) + ": " + geocom::CodeMeaning(code);
          last_code = code;
          std::this_thread::sleep_for(policy_.busy_delay);
          retry = true;
          break;
        }
        if (reply.rc_com == 3101) {  // the instrument saw our CRC as bad: send again
          ++stats_.crc_errors;
          last_error = "instrument reports a checksum error";
          last_code = 3101;
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
      last_error = e.what();
      last_code = e.kind() == TransportError::Kind::kTimeout ? 3077 : 3085;
      if (e.kind() == TransportError::Kind::kTimeout) {
        // A late reply may still arrive: it will be dropped by its transaction id.
        continue;
      }
      transport_->Close();
      std::this_thread::sleep_for(policy_.reconnect_delay);
    }
  }
  throw InstrumentError(name(), last_code,
                        "RPC " + std::to_string(rpc) + " failed after " +
                            std::to_string(policy_.attempts) + " attempts: " + last_error);
}

DeviceInfo GeoComDevice::Identify() {
  DeviceInfo info;
  auto text = [&](int rpc) {
    const auto r = Call(rpc, {});
    if (r.rc != 0) throw InstrumentError(name(), r.rc, geocom::CodeName(r.rc));
    return r.values;
  };
  auto name_values = text(geocom::rpc::kGetInstrumentName);
  if (name_values.empty() || !geocom::DecodeString(name_values[0])) {
    throw InstrumentError(name(), 3074, "CSV_GetInstrumentName: expected a quoted name");
  }
  info.name = *geocom::DecodeString(name_values[0]);
  auto serial = text(geocom::rpc::kGetInstrumentNo);
  if (serial.empty() || !geocom::DecodeLong(serial[0])) {
    throw InstrumentError(name(), 3074, "CSV_GetInstrumentNo: expected a number");
  }
  info.serial = std::to_string(*geocom::DecodeLong(serial[0]));
  auto firmware = text(geocom::rpc::kGetFirmwareVersion);
  if (firmware.size() < 3)
    throw InstrumentError(name(), 3074, "CSV_GetSWVersion: expected 3 numbers");
  info.firmware = firmware[0] + "." + firmware[1] + "." + firmware[2];
  return info;
}

Reading GeoComDevice::ToReading(const geocom::Reply& reply, int hz_index, int v_index,
                                int distance_index, int face_index) {
  const CodeClass cls = geocom::Classify(reply.rc);
  if (cls == CodeClass::kError) {
    throw InstrumentError(name(), reply.rc,
                          geocom::CodeName(reply.rc) + ": " + geocom::CodeMeaning(reply.rc));
  }
  auto number = [&](int index, const char* what) {
    if (index >= static_cast<int>(reply.values.size())) {
      throw InstrumentError(name(), 3074, std::string("reply has no ") + what);
    }
    auto v = geocom::DecodeDouble(reply.values[index]);
    if (!v)
      throw InstrumentError(
          name(), 3074, std::string("cannot decode ") + what + " '" + reply.values[index] + "'");
    return *v;
  };
  Reading r;
  r.time = std::chrono::system_clock::now();
  r.return_code = reply.rc;
  if (reply.rc != 0) r.note = geocom::CodeName(reply.rc) + ": " + geocom::CodeMeaning(reply.rc);
  r.angles.hz_rad = number(hz_index, "Hz");
  r.angles.v_rad = number(v_index, "V");
  if (face_index >= 0) {
    r.angles.face = number(face_index, "face") == 1.0 ? 2 : 1;
  } else {
    r.angles.face = r.angles.v_rad > std::numbers::pi ? 2 : 1;
  }
  // Angles-only codes: the distance is not valid even if a number is present.
  if (distance_index >= 0 && cls != CodeClass::kAnglesOnly) {
    const double metres = number(distance_index, "slope distance");
    if (metres > 0) r.distance_mm = metres * 1000.0;
  }
  return r;
}

Reading GeoComDevice::MeasureAngles() {
  // TMC_GetAngle1: Hz, V, AngleAccuracy, AngleTime, CrossIncl, LengthIncl, InclAccuracy, InclTime,
  // Face.
  return ToReading(Call(geocom::rpc::kGetAngleComplete, {"1"}), 0, 1, -1, 8);
}

Reading GeoComDevice::MeasureAnglesSimple() {
  return ToReading(Call(geocom::rpc::kGetAngleSimple, {"1"}), 0, 1, -1, -1);
}

Reading GeoComDevice::MeasureDistanceAndAngles() {
  const auto start = Call(geocom::rpc::kDoMeasure, {"1", "1"});  // DEF_DIST, AUTO_INC
  if (geocom::Classify(start.rc) == CodeClass::kError) {
    throw InstrumentError(name(), start.rc,
                          geocom::CodeName(start.rc) + ": " + geocom::CodeMeaning(start.rc));
  }
  Reading r = ToReading(Call(geocom::rpc::kGetSimpleMea, {"5000", "1"}), 0, 1, 2, -1);
  if (!r.distance_mm && r.return_code == 0) {
    throw InstrumentError(name(), 1292, "TMC_DIST_ERROR: no distance in the reply");
  }
  return r;
}

int GeoComDevice::Face() {
  const auto r = Call(geocom::rpc::kGetFace, {});
  if (r.rc != 0 || r.values.empty()) throw InstrumentError(name(), r.rc, "TMC_GetFace failed");
  return r.values[0] == "1" ? 2 : 1;
}

void GeoComDevice::ChangeFace() {
  const auto r = Call(geocom::rpc::kChangeFace, {"0", "0", "0"});
  if (r.rc != 0)
    throw InstrumentError(name(), r.rc, geocom::CodeName(r.rc) + ": " + geocom::CodeMeaning(r.rc));
}

bool GeoComDevice::CompensatorOn() {
  const auto r = Call(geocom::rpc::kGetInclineSwitch, {});
  if (r.rc != 0 || r.values.empty())
    throw InstrumentError(name(), r.rc, "TMC_GetInclineSwitch failed");
  return r.values[0] == "1";
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
