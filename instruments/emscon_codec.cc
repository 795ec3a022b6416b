#include "instruments/emscon_codec.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <type_traits>
#include <utility>
#include <vector>

namespace armsig::instruments::emscon {

namespace {

// --- Little-endian fields at fixed offsets (independent of the host's byte order) ------

void PutI32(std::string& out, size_t offset, int32_t value) {
  const auto u = static_cast<uint32_t>(value);
  for (int i = 0; i < 4; ++i) out[offset + i] = static_cast<char>((u >> (8 * i)) & 0xFFu);
}

void PutF64(std::string& out, size_t offset, double value) {
  const auto u = std::bit_cast<uint64_t>(value);
  for (int i = 0; i < 8; ++i) out[offset + i] = static_cast<char>((u >> (8 * i)) & 0xFFu);
}

void PutBool(std::string& out, size_t offset, bool value) { PutI32(out, offset, value ? 1 : 0); }

int32_t GetI32(std::string_view in, size_t offset) {
  uint32_t u = 0;
  for (int i = 0; i < 4; ++i) u |= uint32_t{static_cast<uint8_t>(in[offset + i])} << (8 * i);
  return static_cast<int32_t>(u);
}

double GetF64(std::string_view in, size_t offset) {
  uint64_t u = 0;
  for (int i = 0; i < 8; ++i) u |= uint64_t{static_cast<uint8_t>(in[offset + i])} << (8 * i);
  return std::bit_cast<double>(u);
}

// ES_BOOL: an int32, any non-zero value is true (the Leica receive side tests != 0).
bool GetBool(std::string_view in, size_t offset) { return GetI32(in, offset) != 0; }

// A packet of `size` bytes with its header filled in.
std::string Frame(int32_t size, int32_t type) {
  std::string out(static_cast<size_t>(size), '\0');
  PutI32(out, 0, size);
  PutI32(out, 4, type);
  return out;
}

// --- UTF-16LE names (unsigned short[32]) ----------------------------------------------

inline constexpr size_t kNameUnits = 32;

void AppendUtf8(std::string& out, uint32_t cp) {
  if (cp < 0x80) {
    out += static_cast<char>(cp);
  } else if (cp < 0x800) {
    out += static_cast<char>(0xC0 | (cp >> 6));
    out += static_cast<char>(0x80 | (cp & 0x3F));
  } else if (cp < 0x10000) {
    out += static_cast<char>(0xE0 | (cp >> 12));
    out += static_cast<char>(0x80 | ((cp >> 6) & 0x3F));
    out += static_cast<char>(0x80 | (cp & 0x3F));
  } else {
    out += static_cast<char>(0xF0 | (cp >> 18));
    out += static_cast<char>(0x80 | ((cp >> 12) & 0x3F));
    out += static_cast<char>(0x80 | ((cp >> 6) & 0x3F));
    out += static_cast<char>(0x80 | (cp & 0x3F));
  }
}

// Up to the first zero code unit; unpaired surrogates become U+FFFD.
std::string GetName(std::string_view in, size_t offset) {
  std::string out;
  for (size_t i = 0; i < kNameUnits; ++i) {
    const uint32_t u = static_cast<uint8_t>(in[offset + 2 * i]) |
                       uint32_t{static_cast<uint8_t>(in[offset + 2 * i + 1])} << 8;
    if (u == 0) break;
    if (u >= 0xD800 && u < 0xDC00 && i + 1 < kNameUnits) {
      const uint32_t low = static_cast<uint8_t>(in[offset + 2 * i + 2]) |
                           uint32_t{static_cast<uint8_t>(in[offset + 2 * i + 3])} << 8;
      if (low >= 0xDC00 && low < 0xE000) {
        AppendUtf8(out, 0x10000 + ((u - 0xD800) << 10) + (low - 0xDC00));
        ++i;
        continue;
      }
    }
    AppendUtf8(out, (u >= 0xD800 && u < 0xE000) ? 0xFFFD : u);
  }
  return out;
}

// UTF-8 → UTF-16LE, at most 31 code units and a terminator; invalid bytes become U+FFFD.
void PutName(std::string& out, size_t offset, std::string_view name) {
  std::vector<uint16_t> units;
  for (size_t i = 0; i < name.size();) {
    const auto b = static_cast<uint8_t>(name[i]);
    const int extra = b < 0x80           ? 0
                      : (b >> 5) == 0x6  ? 1
                      : (b >> 4) == 0xE  ? 2
                      : (b >> 3) == 0x1E ? 3
                                         : -1;
    uint32_t cp = 0xFFFD;
    if (extra >= 0 && i + extra < name.size()) {
      cp = extra == 0 ? b : b & (0x3F >> extra);
      for (int k = 1; k <= extra; ++k) cp = (cp << 6) | (static_cast<uint8_t>(name[i + k]) & 0x3F);
      i += extra + 1;
    } else {
      ++i;
    }
    if (cp >= 0x10000) {
      units.push_back(static_cast<uint16_t>(0xD800 + ((cp - 0x10000) >> 10)));
      units.push_back(static_cast<uint16_t>(0xDC00 + ((cp - 0x10000) & 0x3FF)));
    } else {
      units.push_back(static_cast<uint16_t>(cp));
    }
  }
  units.resize(std::min(units.size(), kNameUnits - 1));
  for (size_t i = 0; i < kNameUnits; ++i) {
    const uint16_t u = i < units.size() ? units[i] : 0;
    out[offset + 2 * i] = static_cast<char>(u & 0xFF);
    out[offset + 2 * i + 1] = static_cast<char>(u >> 8);
  }
}

// --- Reply layouts --------------------------------------------------------------------

inline constexpr int32_t kBasicCommandBytes = 12;  // BasicCommandCT
inline constexpr int32_t kBasicReplyBytes = 16;    // BasicCommandRT
inline constexpr int32_t kSingleMeasResultBytes = 156;
inline constexpr int32_t kSingleMeasResult2Bytes = 204;
inline constexpr int32_t kMultiHeadBytes = 48;   // MultiMeasResultT before its records
inline constexpr int32_t kMeasRecordBytes = 36;  // MeasValueT

// The size of a successful reply to `command` when it carries a payload this codec
// decodes (0 = a bare BasicCommandRT; nullopt = a command whose reply layout is not
// modelled: any size from 16 is accepted, the payload kept undecoded).
std::optional<int32_t> ReplyBytes(int32_t command) {
  switch (command) {
    case GetSystemStatus::kCommand:
      return 56;
    case GetReflectors::kCommand:
      return 100;
    case GetEnvironmentParams::kCommand:
      return 40;
    case GetSystemSettings::kCommand:
      return 52;
    case GetFace::kCommand:
    case GetReflector::kCommand:
      return 20;
    case GetLongSystemParameter::kCommand:
      return 24;
    case Initialize::kCommand:
    case SetUnits::kCommand:
    case SetEnvironmentParams::kCommand:
    case SetMeasurementMode::kCommand:
    case SetCoordinateSystemType::kCommand:
    case SetStationaryModeParams::kCommand:
    case SetReflector::kCommand:
    case SetSystemSettings::kCommand:
    case StartMeasurement::kCommand:
    case StopMeasurement::kCommand:
    case SetContinuousTimeModeParams::kCommand:
    case SetContinuousDistanceModeParams::kCommand:
    case ChangeFace::kCommand:
    case GoPosition::kCommand:
    case FindReflector::kCommand:
      return kBasicReplyBytes;
    default:
      return std::nullopt;
  }
}

// SystemSettingsDataT at `at` (36 bytes).
void PutSettings(std::string& out, size_t at, const SystemSettings& s) {
  PutI32(out, at, s.weather_monitor_status);
  PutBool(out, at + 4, s.apply_transformation);
  PutBool(out, at + 8, s.apply_station_orientation);
  PutBool(out, at + 12, s.keep_last_position);
  PutBool(out, at + 16, s.send_unsolicited_messages);
  PutBool(out, at + 20, s.send_reflector_position);
  PutBool(out, at + 24, s.try_measurement_mode);
  PutBool(out, at + 28, s.has_nivel);
  PutBool(out, at + 32, s.has_video_camera);
}

SystemSettings GetSettings(std::string_view in, size_t at) {
  SystemSettings s;
  s.weather_monitor_status = GetI32(in, at);
  s.apply_transformation = GetBool(in, at + 4);
  s.apply_station_orientation = GetBool(in, at + 8);
  s.keep_last_position = GetBool(in, at + 12);
  s.send_unsolicited_messages = GetBool(in, at + 16);
  s.send_reflector_position = GetBool(in, at + 20);
  s.try_measurement_mode = GetBool(in, at + 24);
  s.has_nivel = GetBool(in, at + 28);
  s.has_video_camera = GetBool(in, at + 32);
  return s;
}

// SystemUnitsDataT at `at` (20 bytes).
void PutUnits(std::string& out, size_t at, const Units& u) {
  PutI32(out, at, u.length);
  PutI32(out, at + 4, u.angle);
  PutI32(out, at + 8, u.temperature);
  PutI32(out, at + 12, u.pressure);
  PutI32(out, at + 16, u.humidity);
}

Units GetUnits(std::string_view in, size_t at) {
  return {GetI32(in, at), GetI32(in, at + 4), GetI32(in, at + 8), GetI32(in, at + 12),
          GetI32(in, at + 16)};
}

std::string EncodeAnswer(const CommandAnswer& a) {
  struct Visitor {
    const CommandAnswer& a;
    std::string Bare(int32_t size) const {
      std::string out = Frame(size, packet_type::kCommand);
      PutI32(out, 8, a.command);
      PutI32(out, 12, a.status);
      return out;
    }
    std::string operator()(std::monostate) const { return Bare(kBasicReplyBytes); }
    std::string operator()(const SystemStatus& s) const {  // GetSystemStatusRT, 56 bytes
      std::string out = Bare(56);
      PutI32(out, 16, s.last_result_status);
      PutI32(out, 20, s.tracker_processor_status);
      PutI32(out, 24, s.laser_status);
      PutI32(out, 28, s.adm_status);
      PutI32(out, 32, s.version_major);
      PutI32(out, 36, s.version_minor);
      PutI32(out, 40, s.version_build);
      PutI32(out, 44, s.weather_monitor_status);
      PutI32(out, 48, s.flags);
      PutI32(out, 52, s.serial);
      return out;
    }
    std::string operator()(const ReflectorInfo& r) const {  // GetReflectorsRT, 100 bytes
      std::string out = Bare(100);
      PutI32(out, 16, r.total);
      PutI32(out, 20, r.id);
      PutI32(out, 24, r.target_type);
      PutF64(out, 28, r.surface_offset);
      PutName(out, 36, r.name);
      return out;
    }
    std::string operator()(const EnvironmentParams& e) const {  // 40 bytes
      std::string out = Bare(40);
      PutF64(out, 16, e.temperature);
      PutF64(out, 24, e.pressure);
      PutF64(out, 32, e.humidity);
      return out;
    }
    std::string operator()(const SystemSettings& s) const {  // GetSystemSettingsRT, 52 bytes
      std::string out = Bare(52);
      PutSettings(out, 16, s);
      return out;
    }
    std::string operator()(const Int32Value& v) const {
      std::string out = Bare(20);
      PutI32(out, 16, v.value);
      return out;
    }
    std::string operator()(const LongParameter& p) const {
      std::string out = Bare(24);
      PutI32(out, 16, p.parameter);
      PutI32(out, 20, p.value);
      return out;
    }
  };
  return std::visit(Visitor{a}, a.data);
}

std::string EncodeMeasResult(const MeasResult& m) {
  // SingleMeasResultT (156 bytes) / SingleMeasResult2T (204 bytes), EMSCON.md §3.2.
  std::string out =
      Frame(m.extended ? kSingleMeasResult2Bytes : kSingleMeasResultBytes,
            m.extended ? packet_type::kSingleMeasResult2 : packet_type::kSingleMeasResult);
  PutI32(out, 8, m.status);
  PutI32(out, 12, m.meas_mode);
  PutBool(out, 16, m.try_mode);
  for (int i = 0; i < 3; ++i) {
    PutF64(out, 20 + 8 * i, m.value[i]);
    PutF64(out, 44 + 8 * i, m.std_dev[i]);
  }
  PutF64(out, 68, m.std_total);
  if (!m.extended) {
    for (int i = 0; i < 3; ++i) {
      PutF64(out, 76 + 8 * i, m.pointing_error[i]);
      PutF64(out, 100 + 8 * i, m.apriori_std[i]);
    }
    PutF64(out, 124, m.apriori_std_total);
    PutF64(out, 132, m.temperature);
    PutF64(out, 140, m.pressure);
    PutF64(out, 148, m.humidity);
  } else {
    for (int i = 0; i < 3; ++i) {
      PutF64(out, 76 + 8 * i, m.covariance[i]);
      PutF64(out, 100 + 8 * i, m.pointing_error[i]);
      PutF64(out, 124 + 8 * i, m.apriori_std[i]);
      PutF64(out, 156 + 8 * i, m.apriori_covariance[i]);
    }
    PutF64(out, 148, m.apriori_std_total);
    PutF64(out, 180, m.temperature);
    PutF64(out, 188, m.pressure);
    PutF64(out, 196, m.humidity);
  }
  return out;
}

MeasResult DecodeMeasResult(std::string_view in, bool extended) {
  MeasResult m;
  m.extended = extended;
  m.status = GetI32(in, 8);
  m.meas_mode = GetI32(in, 12);
  m.try_mode = GetBool(in, 16);
  for (int i = 0; i < 3; ++i) {
    m.value[i] = GetF64(in, 20 + 8 * i);
    m.std_dev[i] = GetF64(in, 44 + 8 * i);
  }
  m.std_total = GetF64(in, 68);
  if (!extended) {
    for (int i = 0; i < 3; ++i) {
      m.pointing_error[i] = GetF64(in, 76 + 8 * i);
      m.apriori_std[i] = GetF64(in, 100 + 8 * i);
    }
    m.apriori_std_total = GetF64(in, 124);
    m.temperature = GetF64(in, 132);
    m.pressure = GetF64(in, 140);
    m.humidity = GetF64(in, 148);
  } else {
    for (int i = 0; i < 3; ++i) {
      m.covariance[i] = GetF64(in, 76 + 8 * i);
      m.pointing_error[i] = GetF64(in, 100 + 8 * i);
      m.apriori_std[i] = GetF64(in, 124 + 8 * i);
      m.apriori_covariance[i] = GetF64(in, 156 + 8 * i);
    }
    m.apriori_std_total = GetF64(in, 148);
    m.temperature = GetF64(in, 180);
    m.pressure = GetF64(in, 188);
    m.humidity = GetF64(in, 196);
  }
  return m;
}

// The header of a whole frame: its size field must be in bounds and equal the frame's
// length. Returns the type, or sets the error.
template <typename Decoded>
std::optional<int32_t> CheckFrame(std::string_view frame, Decoded& out) {
  if (frame.size() < kHeaderBytes) {
    out.error = DecodeError::kTruncated;
    out.why = "a packet of " + std::to_string(frame.size()) + " bytes has no 8-byte header";
    return std::nullopt;
  }
  const int32_t size = GetI32(frame, 0);
  const int32_t type = GetI32(frame, 4);
  if constexpr (requires { out.type; }) out.type = type;
  if (size < kMinPacketBytes || size > kMaxPacketBytes) {
    out.error = DecodeError::kBadSize;
    out.why = "size field " + std::to_string(size) + " outside " + std::to_string(kMinPacketBytes) +
              " to " + std::to_string(kMaxPacketBytes);
    return std::nullopt;
  }
  if (static_cast<size_t>(size) > frame.size()) {
    out.error = DecodeError::kTruncated;
    out.why = "size field " + std::to_string(size) + " but only " + std::to_string(frame.size()) +
              " bytes";
    return std::nullopt;
  }
  if (static_cast<size_t>(size) < frame.size()) {
    out.error = DecodeError::kBadSize;
    out.why = "size field " + std::to_string(size) + " but a frame of " +
              std::to_string(frame.size()) + " bytes";
    return std::nullopt;
  }
  return type;
}

template <typename Decoded>
bool ExpectSize(std::string_view frame, int32_t expected, const std::string& what, Decoded& out) {
  if (static_cast<int32_t>(frame.size()) == expected) return true;
  out.error = DecodeError::kBadLength;
  out.why =
      what + ": " + std::to_string(frame.size()) + " bytes, expected " + std::to_string(expected);
  return false;
}

}  // namespace

double TimeOf(const MeasRecord& record) {
  return static_cast<double>(record.time1) + 1e-6 * static_cast<double>(record.time2);
}

void SetTime(MeasRecord& record, double tracker_time_s) {
  const double whole = std::floor(tracker_time_s);
  auto micro = static_cast<int64_t>(std::llround((tracker_time_s - whole) * 1e6));
  auto seconds = static_cast<int64_t>(whole);
  if (micro >= 1000000) {
    micro -= 1000000;
    ++seconds;
  }
  record.time1 = static_cast<int32_t>(seconds);
  record.time2 = static_cast<int32_t>(micro);
}

// --- Requests -------------------------------------------------------------------------

int32_t CommandOf(const Request& request) {
  return std::visit([](const auto& r) { return std::decay_t<decltype(r)>::kCommand; }, request);
}

std::string EncodeRequest(const Request& request) {
  struct Visitor {
    std::string Basic(int32_t command, int32_t size) const {
      std::string out = Frame(size, packet_type::kCommand);
      PutI32(out, 8, command);
      return out;
    }
    // Parameterless commands: a bare BasicCommandCT (12 bytes).
    std::string operator()(const Initialize&) const { return Basic(Initialize::kCommand, 12); }
    std::string operator()(const GetSystemStatus&) const {
      return Basic(GetSystemStatus::kCommand, 12);
    }
    std::string operator()(const GetEnvironmentParams&) const {
      return Basic(GetEnvironmentParams::kCommand, 12);
    }
    std::string operator()(const GetReflector&) const { return Basic(GetReflector::kCommand, 12); }
    std::string operator()(const GetReflectors&) const {
      return Basic(GetReflectors::kCommand, 12);
    }
    std::string operator()(const GetSystemSettings&) const {
      return Basic(GetSystemSettings::kCommand, 12);
    }
    std::string operator()(const StartMeasurement&) const {
      return Basic(StartMeasurement::kCommand, 12);
    }
    std::string operator()(const ChangeFace&) const { return Basic(ChangeFace::kCommand, 12); }
    std::string operator()(const StopMeasurement&) const {
      return Basic(StopMeasurement::kCommand, 12);
    }
    std::string operator()(const SetContinuousTimeModeParams& r) const {  // 28 bytes
      std::string out = Basic(SetContinuousTimeModeParams::kCommand, 28);
      PutI32(out, 12, r.time_separation_ms);
      PutI32(out, 16, r.number_of_points);
      PutBool(out, 20, r.use_region);
      PutI32(out, 24, r.region_type);
      return out;
    }
    std::string operator()(const SetContinuousDistanceModeParams& r) const {  // 32 bytes
      std::string out = Basic(SetContinuousDistanceModeParams::kCommand, 32);
      PutF64(out, 12, r.spatial_distance);
      PutI32(out, 20, r.number_of_points);
      PutBool(out, 24, r.use_region);
      PutI32(out, 28, r.region_type);
      return out;
    }
    std::string operator()(const GetFace&) const { return Basic(GetFace::kCommand, 12); }
    std::string operator()(const SetUnits& r) const {  // 32 bytes
      std::string out = Basic(SetUnits::kCommand, 32);
      PutUnits(out, 12, r.units);
      return out;
    }
    std::string operator()(const SetEnvironmentParams& r) const {  // 36 bytes
      std::string out = Basic(SetEnvironmentParams::kCommand, 36);
      PutF64(out, 12, r.temperature);
      PutF64(out, 20, r.pressure);
      PutF64(out, 28, r.humidity);
      return out;
    }
    std::string operator()(const SetMeasurementMode& r) const {  // 16 bytes
      std::string out = Basic(SetMeasurementMode::kCommand, 16);
      PutI32(out, 12, r.mode);
      return out;
    }
    std::string operator()(const SetCoordinateSystemType& r) const {  // 16 bytes
      std::string out = Basic(SetCoordinateSystemType::kCommand, 16);
      PutI32(out, 12, r.type);
      return out;
    }
    std::string operator()(const SetStationaryModeParams& r) const {  // 20 bytes
      std::string out = Basic(SetStationaryModeParams::kCommand, 20);
      PutI32(out, 12, r.meas_time_ms);
      PutBool(out, 16, r.use_adm);
      return out;
    }
    std::string operator()(const SetReflector& r) const {  // 16 bytes
      std::string out = Basic(SetReflector::kCommand, 16);
      PutI32(out, 12, r.reflector_id);
      return out;
    }
    std::string operator()(const SetSystemSettings& r) const {  // 48 bytes
      std::string out = Basic(SetSystemSettings::kCommand, 48);
      PutSettings(out, 12, r.settings);
      return out;
    }
    std::string operator()(const GoPosition& r) const {  // 40 bytes
      std::string out = Basic(GoPosition::kCommand, 40);
      PutF64(out, 12, r.val1);
      PutF64(out, 20, r.val2);
      PutF64(out, 28, r.val3);
      PutBool(out, 36, r.use_adm);
      return out;
    }
    std::string operator()(const FindReflector& r) const {  // 20 bytes
      std::string out = Basic(FindReflector::kCommand, 20);
      PutF64(out, 12, r.approx_distance);
      return out;
    }
    std::string operator()(const GetLongSystemParameter& r) const {  // 16 bytes
      std::string out = Basic(GetLongSystemParameter::kCommand, 16);
      PutI32(out, 12, r.parameter);
      return out;
    }
  };
  return std::visit(Visitor{}, request);
}

DecodedRequest DecodeRequest(std::string_view frame) {
  DecodedRequest out;
  const auto type = CheckFrame(frame, out);
  if (!type) return out;
  if (*type != packet_type::kCommand) {
    out.error = DecodeError::kUnknownType;
    out.why = "a client sends commands (type 0), not " + PacketTypeName(*type);
    return out;
  }
  if (frame.size() < kBasicCommandBytes) {
    out.error = DecodeError::kBadLength;
    out.why = "a command of " + std::to_string(frame.size()) + " bytes has no command id";
    return out;
  }
  out.command = GetI32(frame, 8);
  const std::string what = CommandName(out.command);
  // Each command's CT size (EMSCON.md §3.3), then its parameters at their offsets.
  const auto take = [&](int32_t size, auto make) {
    if (ExpectSize(frame, size, what, out)) out.request = make();
  };
  switch (out.command) {
    case Initialize::kCommand:
      take(12, [] { return Request{Initialize{}}; });
      break;
    case GetSystemStatus::kCommand:
      take(12, [] { return Request{GetSystemStatus{}}; });
      break;
    case GetEnvironmentParams::kCommand:
      take(12, [] { return Request{GetEnvironmentParams{}}; });
      break;
    case GetReflector::kCommand:
      take(12, [] { return Request{GetReflector{}}; });
      break;
    case GetReflectors::kCommand:
      take(12, [] { return Request{GetReflectors{}}; });
      break;
    case GetSystemSettings::kCommand:
      take(12, [] { return Request{GetSystemSettings{}}; });
      break;
    case StartMeasurement::kCommand:
      take(12, [] { return Request{StartMeasurement{}}; });
      break;
    case ChangeFace::kCommand:
      take(12, [] { return Request{ChangeFace{}}; });
      break;
    case StopMeasurement::kCommand:
      take(12, [] { return Request{StopMeasurement{}}; });
      break;
    case SetContinuousTimeModeParams::kCommand:
      take(28, [&] {
        return Request{SetContinuousTimeModeParams{GetI32(frame, 12), GetI32(frame, 16),
                                                   GetBool(frame, 20), GetI32(frame, 24)}};
      });
      break;
    case SetContinuousDistanceModeParams::kCommand:
      take(32, [&] {
        return Request{SetContinuousDistanceModeParams{GetF64(frame, 12), GetI32(frame, 20),
                                                       GetBool(frame, 24), GetI32(frame, 28)}};
      });
      break;
    case GetFace::kCommand:
      take(12, [] { return Request{GetFace{}}; });
      break;
    case SetUnits::kCommand:
      take(32, [&] { return Request{SetUnits{GetUnits(frame, 12)}}; });
      break;
    case SetEnvironmentParams::kCommand:
      take(36, [&] {
        return Request{
            SetEnvironmentParams{GetF64(frame, 12), GetF64(frame, 20), GetF64(frame, 28)}};
      });
      break;
    case SetMeasurementMode::kCommand:
      take(16, [&] { return Request{SetMeasurementMode{GetI32(frame, 12)}}; });
      break;
    case SetCoordinateSystemType::kCommand:
      take(16, [&] { return Request{SetCoordinateSystemType{GetI32(frame, 12)}}; });
      break;
    case SetStationaryModeParams::kCommand:
      take(20, [&] {
        return Request{SetStationaryModeParams{GetI32(frame, 12), GetBool(frame, 16)}};
      });
      break;
    case SetReflector::kCommand:
      take(16, [&] { return Request{SetReflector{GetI32(frame, 12)}}; });
      break;
    case SetSystemSettings::kCommand:
      take(48, [&] { return Request{SetSystemSettings{GetSettings(frame, 12)}}; });
      break;
    case GoPosition::kCommand:
      take(40, [&] {
        return Request{GoPosition{GetF64(frame, 12), GetF64(frame, 20), GetF64(frame, 28),
                                  GetBool(frame, 36)}};
      });
      break;
    case FindReflector::kCommand:
      take(20, [&] { return Request{FindReflector{GetF64(frame, 12)}}; });
      break;
    case GetLongSystemParameter::kCommand:
      take(16, [&] { return Request{GetLongSystemParameter{GetI32(frame, 12)}}; });
      break;
    default:
      out.error = DecodeError::kUnknownType;
      out.why = what + " is not a command this codec models";
  }
  return out;
}

// --- Server packets -------------------------------------------------------------------

std::string EncodePacket(const Packet& packet) {
  struct Visitor {
    std::string operator()(const CommandAnswer& a) const { return EncodeAnswer(a); }
    std::string operator()(const ErrorResponse& e) const {  // ErrorResponseT, 16 bytes
      std::string out = Frame(16, packet_type::kError);
      PutI32(out, 8, e.command);
      PutI32(out, 12, e.status);
      return out;
    }
    std::string operator()(const MeasResult& m) const { return EncodeMeasResult(m); }
    std::string operator()(const StatusChange& s) const {  // SystemStatusChangeT, 12 bytes
      std::string out = Frame(12, packet_type::kSystemStatusChange);
      PutI32(out, 8, s.change);
      return out;
    }
    std::string operator()(const MultiMeasResult& m) const {  // 48 + 36 n bytes
      const auto n = static_cast<int32_t>(m.records.size());
      std::string out = Frame(kMultiHeadBytes + kMeasRecordBytes * n, packet_type::kMultiMeasResult);
      PutI32(out, 8, m.status);
      PutI32(out, 12, n);
      PutI32(out, 16, m.meas_mode);
      PutBool(out, 20, m.try_mode);
      PutF64(out, 24, m.temperature);
      PutF64(out, 32, m.pressure);
      PutF64(out, 40, m.humidity);
      for (int32_t i = 0; i < n; ++i) {
        const size_t at = kMultiHeadBytes + static_cast<size_t>(kMeasRecordBytes) * i;
        const MeasRecord& r = m.records[i];
        PutI32(out, at, r.status);
        PutI32(out, at + 4, r.time1);
        PutI32(out, at + 8, r.time2);
        for (int k = 0; k < 3; ++k) PutF64(out, at + 12 + 8 * k, r.value[k]);
      }
      return out;
    }
    std::string operator()(const ReflectorPosition& r) const {  // ReflectorPosResultT, 36
      std::string out = Frame(36, packet_type::kReflectorPosResult);
      PutI32(out, 8, r.status);
      for (int i = 0; i < 3; ++i) PutF64(out, 12 + 8 * i, r.value[i]);
      return out;
    }
  };
  return std::visit(Visitor{}, packet);
}

DecodedPacket DecodePacket(std::string_view frame) {
  DecodedPacket out;
  const auto type = CheckFrame(frame, out);
  if (!type) return out;
  const int32_t size = static_cast<int32_t>(frame.size());
  switch (*type) {
    case packet_type::kCommand: {
      if (size < kBasicReplyBytes) {
        out.error = DecodeError::kBadLength;
        out.why = "a command reply of " + std::to_string(size) + " bytes (at least 16)";
        return out;
      }
      CommandAnswer a;
      a.command = GetI32(frame, 8);
      a.status = GetI32(frame, 12);
      const auto expected = ReplyBytes(a.command);
      // A failed reply's payload is not interpreted (the Leica dispatcher stops after the
      // status), whatever its length; an unmodelled reply is kept without its payload.
      if (a.status == status::kAllOk && expected) {
        if (!ExpectSize(frame, *expected, CommandName(a.command) + " reply", out)) return out;
        switch (a.command) {
          case GetSystemStatus::kCommand:
            a.data = SystemStatus{GetI32(frame, 16), GetI32(frame, 20), GetI32(frame, 24),
                                  GetI32(frame, 28), GetI32(frame, 32), GetI32(frame, 36),
                                  GetI32(frame, 40), GetI32(frame, 44), GetI32(frame, 48),
                                  GetI32(frame, 52)};
            break;
          case GetReflectors::kCommand:
            a.data = ReflectorInfo{GetI32(frame, 16), GetI32(frame, 20), GetI32(frame, 24),
                                   GetF64(frame, 28), GetName(frame, 36)};
            break;
          case GetEnvironmentParams::kCommand:
            a.data = EnvironmentParams{GetF64(frame, 16), GetF64(frame, 24), GetF64(frame, 32)};
            break;
          case GetSystemSettings::kCommand:
            a.data = GetSettings(frame, 16);
            break;
          case GetFace::kCommand:
          case GetReflector::kCommand:
            a.data = Int32Value{GetI32(frame, 16)};
            break;
          case GetLongSystemParameter::kCommand:
            a.data = LongParameter{GetI32(frame, 16), GetI32(frame, 20)};
            break;
          default:
            break;  // a bare reply
        }
      }
      out.packet = a;
      return out;
    }
    case packet_type::kError:
      if (!ExpectSize(frame, 16, "ErrorResponse", out)) return out;
      out.packet = ErrorResponse{GetI32(frame, 8), GetI32(frame, 12)};
      return out;
    case packet_type::kSingleMeasResult:
      if (!ExpectSize(frame, kSingleMeasResultBytes, "SingleMeasResult", out)) return out;
      out.packet = DecodeMeasResult(frame, false);
      return out;
    case packet_type::kSingleMeasResult2:
      if (!ExpectSize(frame, kSingleMeasResult2Bytes, "SingleMeasResult2", out)) return out;
      out.packet = DecodeMeasResult(frame, true);
      return out;
    case packet_type::kMultiMeasResult: {
      if (size < kMultiHeadBytes) {
        out.error = DecodeError::kBadLength;
        out.why = "MultiMeasResult: " + std::to_string(size) + " bytes, at least 48";
        return out;
      }
      const int32_t n = GetI32(frame, 12);
      if (n < 0 || n > kMaxRecordsPerPacket) {
        out.error = DecodeError::kBadLength;
        out.why = "MultiMeasResult: " + std::to_string(n) + " records (0 to " +
                  std::to_string(kMaxRecordsPerPacket) + ")";
        return out;
      }
      if (!ExpectSize(frame, kMultiHeadBytes + kMeasRecordBytes * n,
                      "MultiMeasResult of " + std::to_string(n) + " records", out)) {
        return out;
      }
      MultiMeasResult m;
      m.status = GetI32(frame, 8);
      m.meas_mode = GetI32(frame, 16);
      m.try_mode = GetBool(frame, 20);
      m.temperature = GetF64(frame, 24);
      m.pressure = GetF64(frame, 32);
      m.humidity = GetF64(frame, 40);
      m.records.resize(n);
      for (int32_t i = 0; i < n; ++i) {
        const size_t at = kMultiHeadBytes + static_cast<size_t>(kMeasRecordBytes) * i;
        MeasRecord& r = m.records[i];
        r.status = GetI32(frame, at);
        r.time1 = GetI32(frame, at + 4);
        r.time2 = GetI32(frame, at + 8);
        for (int k = 0; k < 3; ++k) r.value[k] = GetF64(frame, at + 12 + 8 * k);
      }
      out.packet = std::move(m);
      return out;
    }
    case packet_type::kSystemStatusChange:
      if (!ExpectSize(frame, 12, "SystemStatusChange", out)) return out;
      out.packet = StatusChange{GetI32(frame, 8)};
      return out;
    case packet_type::kReflectorPosResult: {
      if (!ExpectSize(frame, 36, "ReflectorPosResult", out)) return out;
      ReflectorPosition r;
      r.status = GetI32(frame, 8);
      for (int i = 0; i < 3; ++i) r.value[i] = GetF64(frame, 12 + 8 * i);
      out.packet = r;
      return out;
    }
    default:
      out.error = DecodeError::kUnknownType;
      out.why = PacketTypeName(*type) + " (" + std::to_string(size) + " bytes) is not decoded";
      return out;
  }
}

}  // namespace armsig::instruments::emscon
