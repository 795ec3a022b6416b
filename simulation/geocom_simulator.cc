#include "simulation/geocom_simulator.h"

#include "instruments/geocom_codec.h"

namespace armsig::simulation {

namespace geocom = instruments::geocom;

GeoComSimulator::GeoComSimulator(VirtualLab& lab, int station, std::string link_path,
                                 SimulatorOptions options, std::string instrument_name, long serial)
    : LineSimulator(std::move(link_path), options),
      lab_(lab),
      station_(station),
      name_(std::move(instrument_name)),
      serial_(serial) {}

// One request line to its reply: one case per GeoCOM RPC the drivers use, each a few
// lines. Kept whole on purpose (about 150 lines): it is the protocol's table, read side by
// side with the GeoCOM reference and instruments/geocom_codec.h; split into helpers it
// would scatter one table over a dozen small functions.
namespace {

// What the instrument answers to a request it cannot take: the checksum or decode return code
// of a damaged or malformed request (GeoCOM reference, COM_*).
std::string RefusalReply(const geocom::ParsedRequest& parsed) {
  const int code = parsed.error == geocom::ParseError::kBadCrc
                       ? geocom::grc::kComSrvrRxChecksumError
                       : geocom::grc::kComCantDecodeReq;
  return geocom::EncodeReply({code, 0, 0, {}}, parsed.had_crc);
}

}  // namespace

std::optional<LineSimulator::Response> GeoComSimulator::Handle(const std::string& line,
                                                               const FaultSpec& fault) {
  const auto parsed = geocom::ParseRequest(line);
  if (parsed.error == geocom::ParseError::kNotAFrame) return std::nullopt;  // garbage: silence
  if (parsed.error) return Response{RefusalReply(parsed), std::chrono::milliseconds(5)};
  const bool crc = parsed.had_crc;
  const geocom::Request& q = *parsed.request;
  geocom::Reply r;
  r.trid = q.trid.value_or(0);
  auto latency = options_.angle_latency / 4;
  const auto face_value = [&] { return lab_.Face(station_) == 2 ? 1L : 0L; };  // TMC_FACE
  switch (q.rpc) {
    case geocom::rpc::kNullProc:
      break;
    case geocom::rpc::kGetDoublePrecision:
      r.values = {geocom::EncodeLong(15)};
      break;
    case geocom::rpc::kGetGeoComVersion:
      r.values = geocom::EncodeValues(geocom::Version{1, 50, 0});
      break;
    case geocom::rpc::kGetInstrumentName:
      r.values = {geocom::EncodeString(name_)};
      break;
    case geocom::rpc::kGetInstrumentNo:
      r.values = {geocom::EncodeLong(serial_)};
      break;
    case geocom::rpc::kGetFirmwareVersion:
      r.values = geocom::EncodeValues(geocom::Version{3, 20, 7});
      break;
    case geocom::rpc::kGetInclineSwitch:
      r.values = {geocom::EncodeLong(1)};
      break;
    case geocom::rpc::kSetInclineSwitch:
      break;
    case geocom::rpc::kGetFace:
      r.values = {geocom::EncodeLong(face_value())};
      break;
    case geocom::rpc::kChangeFace:
      lab_.SetFace(station_, 3 - lab_.Face(station_));
      latency = options_.motion_latency;
      break;
    case geocom::rpc::kMakePositioning:
    case geocom::rpc::kFineAdjust:
      latency = options_.motion_latency / 2;
      break;
    case geocom::rpc::kGetAngleComplete: {
      const AngleReading a = lab_.Read(station_);
      geocom::AngleComplete values;
      values.hz_rad = a.hz_rad;
      values.v_rad = a.v_rad;
      values.angle_accuracy_rad = 0.000001;
      values.angle_time_ms = 1000;
      values.cross_incline_rad = 0.00001;
      values.length_incline_rad = 0.00002;
      values.incline_accuracy_rad = 0.000003;
      values.incline_time_ms = 1000;
      values.face = face_value();
      r.values = geocom::EncodeValues(values);
      latency = options_.angle_latency;
      break;
    }
    case geocom::rpc::kGetAngleSimple: {
      const AngleReading a = lab_.Read(station_);
      r.values = geocom::EncodeValues(geocom::AngleSimple{a.hz_rad, a.v_rad});
      latency = options_.angle_latency;
      break;
    }
    case geocom::rpc::kDoMeasure: {
      const auto program =
          q.params.empty() ? std::optional<long>(1) : geocom::DecodeLong(q.params[0]);
      distance_ready_ = program != 0L;  // 0 = TMC_STOP
      latency = options_.angle_latency / 4;
      break;
    }
    case geocom::rpc::kGetSimpleMea: {
      double distance_mm = 0.0;
      const AngleReading a = lab_.Read(station_, distance_ready_ ? &distance_mm : nullptr);
      geocom::SimpleMeasurement m{a.hz_rad, a.v_rad, distance_mm / 1000.0};
      if (!distance_ready_) {
        r.rc = geocom::grc::kTmcAngleOk;  // angles valid, no distance measured
        m.slope_distance_m = 0.0;
      }
      r.values = geocom::EncodeValues(m);
      latency = options_.distance_latency;
      break;
    }
    case geocom::rpc::kMeasDistanceAngle: {
      const auto mode = q.params.empty() ? std::optional<long>(2) : geocom::DecodeLong(q.params[0]);
      if (!mode) {
        r.rc = geocom::grc::kIvParam;
        break;
      }
      double distance_mm = 0.0;
      const AngleReading a = lab_.Read(station_, &distance_mm);
      r.values = geocom::EncodeValues(
          geocom::DistanceAngle{a.hz_rad, a.v_rad, distance_mm / 1000.0, *mode});
      latency = options_.distance_latency;
      break;
    }
    default:
      r.rc_com = geocom::grc::kComProcUnavail;
      r.values.clear();
  }
  switch (fault.fault) {
    case Fault::kOtherReply:
      // The right transaction id with another RPC's values (CSV_GetFirmwareVersion).
      r.rc_com = geocom::grc::kOk;
      r.rc = geocom::grc::kOk;
      r.values = geocom::EncodeValues(geocom::Version{3, 20, 7});
      break;
    case Fault::kOutOfRange:
      // Angles in degrees where radians belong, and a zenith angle below 0.
      if (r.values.size() >= 2) {
        const auto hz = geocom::DecodeDouble(r.values[0]);
        const auto v = geocom::DecodeDouble(r.values[1]);
        if (hz && v) {
          r.values[0] = geocom::EncodeDouble(*hz * 180.0 / std::numbers::pi);
          r.values[1] = geocom::EncodeDouble(-*v);
        }
      }
      break;
    case Fault::kBusy:
      r.rc = geocom::grc::kSysBusy;
      r.values.clear();
      break;
    case Fault::kErrorCode:
      r.rc = fault.code;
      r.values.clear();
      break;
    case Fault::kWarningCode:
      r.rc = fault.code;
      break;
    case Fault::kWrongTrid:
      r.trid = (r.trid + 7) % 32768;
      break;
    default:
      break;
  }
  std::string bytes = geocom::EncodeReply(
      r, (crc || fault.fault == Fault::kBadCrc) && fault.fault != Fault::kNoCrc);
  if (fault.fault == Fault::kBadCrc) {
    // Corrupt one digit of the CRC field (the third comma-separated header field).
    const size_t colon = bytes.find(':');
    const size_t last_comma = bytes.rfind(',', colon);
    bytes[last_comma + 1] = bytes[last_comma + 1] == '1' ? '2' : '1';
  }
  return Response{bytes, latency};
}

std::string GeoComSimulator::FloodLine(const std::string& request, int64_t k) {
  // Well-formed replies (with a CRC when the request had one) whose transaction ids are
  // far from the request's: late replies to requests never sent.
  const auto parsed = geocom::ParseRequest(request);
  const int trid = parsed.request ? parsed.request->trid.value_or(0) : 0;
  geocom::Reply r;
  r.trid = (trid + 10000 + static_cast<int>(k % 1000)) % 32768;
  r.values = geocom::EncodeValues(geocom::AngleSimple{1.0, 1.5});
  return geocom::EncodeReply(r, parsed.had_crc);
}

}  // namespace armsig::simulation
