#include "robots/ur_codec.h"

#include <fmt/format.h>

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstring>

namespace armsig::robots::ur {
using instruments::ControllerKinematics;

namespace {

// --- Big-endian fields (every UR interface is in network order) -------------------------

void PutU8(std::string& out, uint8_t v) { out.push_back(static_cast<char>(v)); }
void PutU16(std::string& out, uint16_t v) {
  PutU8(out, static_cast<uint8_t>(v >> 8));
  PutU8(out, static_cast<uint8_t>(v));
}
void PutU32(std::string& out, uint32_t v) {
  for (int shift = 24; shift >= 0; shift -= 8) PutU8(out, static_cast<uint8_t>(v >> shift));
}
void PutU64(std::string& out, uint64_t v) {
  for (int shift = 56; shift >= 0; shift -= 8) PutU8(out, static_cast<uint8_t>(v >> shift));
}
void PutI32(std::string& out, int32_t v) { PutU32(out, static_cast<uint32_t>(v)); }
void PutDouble(std::string& out, double v) {
  uint64_t bits = 0;
  std::memcpy(&bits, &v, sizeof bits);
  PutU64(out, bits);
}
void PutFloat(std::string& out, float v) {
  uint32_t bits = 0;
  std::memcpy(&bits, &v, sizeof bits);
  PutU32(out, bits);
}

// Reads fields in order; a read past the end leaves ok() false and returns zero.
class Reader {
 public:
  explicit Reader(std::string_view bytes) : bytes_(bytes) {}
  bool ok() const { return ok_; }
  size_t left() const { return bytes_.size() - at_; }
  bool Need(size_t n) {
    if (left() < n) ok_ = false;
    return ok_;
  }
  uint64_t Unsigned(size_t n) {
    if (!Need(n)) return 0;
    uint64_t v = 0;
    for (size_t k = 0; k < n; ++k) v = (v << 8) | static_cast<uint8_t>(bytes_[at_ + k]);
    at_ += n;
    return v;
  }
  uint8_t U8() { return static_cast<uint8_t>(Unsigned(1)); }
  uint16_t U16() { return static_cast<uint16_t>(Unsigned(2)); }
  uint32_t U32() { return static_cast<uint32_t>(Unsigned(4)); }
  uint64_t U64() { return Unsigned(8); }
  int32_t I32() { return static_cast<int32_t>(U32()); }
  double Double() {
    const uint64_t bits = U64();
    double v = 0.0;
    std::memcpy(&v, &bits, sizeof v);
    return v;
  }
  float Float() {
    const uint32_t bits = U32();
    float v = 0.0f;
    std::memcpy(&v, &bits, sizeof v);
    return v;
  }
  std::string Bytes(size_t n) {
    if (!Need(n)) return {};
    std::string s(bytes_.substr(at_, n));
    at_ += n;
    return s;
  }
  std::string Rest() { return Bytes(left()); }
  void Skip(size_t n) {
    if (Need(n)) at_ += n;
  }

 private:
  std::string_view bytes_;
  size_t at_ = 0;
  bool ok_ = true;
};

std::vector<std::string> SplitCommas(std::string_view text) {
  std::vector<std::string> out;
  size_t start = 0;
  while (start <= text.size()) {
    const size_t comma = text.find(',', start);
    const size_t end = comma == std::string_view::npos ? text.size() : comma;
    out.emplace_back(text.substr(start, end - start));
    if (comma == std::string_view::npos) break;
    start = comma + 1;
  }
  return out;
}

std::string JoinCommas(const std::vector<std::string>& items) {
  std::string out;
  for (size_t k = 0; k < items.size(); ++k) out += (k ? "," : "") + items[k];
  return out;
}

}  // namespace

std::string SoftwareVersion::Text() const {
  return fmt::format("{}.{}.{}.{}", major, minor, bugfix, build);
}

// --- RTDE ------------------------------------------------------------------------------

namespace rtde {

std::string Encode(Type type, std::string_view payload) {
  std::string out;
  out.reserve(kHeaderBytes + payload.size());
  PutU16(out, static_cast<uint16_t>(kHeaderBytes + payload.size()));
  PutU8(out, static_cast<uint8_t>(type));
  out.append(payload);
  return out;
}

std::optional<Package> Decode(std::string_view frame, std::string* why) {
  Reader r(frame);
  const uint16_t size = r.U16();
  const uint8_t type = r.U8();
  if (!r.ok() || size != frame.size()) {
    if (why) *why = fmt::format("RTDE package of {} bytes with size field {}", frame.size(), size);
    return std::nullopt;
  }
  return Package{type, std::string(frame.substr(kHeaderBytes))};
}

std::string RequestProtocolVersion(uint16_t version) {
  std::string payload;
  PutU16(payload, version);
  return Encode(Type::kRequestProtocolVersion, payload);
}
std::string GetUrControlVersion() { return Encode(Type::kGetUrControlVersion, ""); }
std::string SetupOutputs(double frequency_hz, const std::vector<std::string>& names) {
  std::string payload;
  PutDouble(payload, frequency_hz);
  payload += JoinCommas(names);
  return Encode(Type::kSetupOutputs, payload);
}
std::string Start() { return Encode(Type::kStart, ""); }
std::string Pause() { return Encode(Type::kPause, ""); }

std::optional<uint16_t> DecodeProtocolVersionRequest(std::string_view payload) {
  if (payload.size() != 2) return std::nullopt;
  return Reader(payload).U16();
}

std::optional<OutputsRequest> DecodeSetupOutputsRequest(std::string_view payload) {
  Reader r(payload);
  OutputsRequest out;
  out.frequency_hz = r.Double();
  if (!r.ok()) return std::nullopt;
  out.names = SplitCommas(r.Rest());
  return out;
}

std::string Accepted(Type type, bool accepted) {
  std::string payload;
  PutU8(payload, accepted ? 1 : 0);
  return Encode(type, payload);
}

std::optional<bool> DecodeAccepted(std::string_view payload) {
  if (payload.size() != 1) return std::nullopt;
  return payload[0] != 0;
}

std::string UrControlVersion(const SoftwareVersion& v) {
  std::string payload;
  for (const int part : {v.major, v.minor, v.bugfix, v.build}) PutU32(payload, static_cast<uint32_t>(part));
  return Encode(Type::kGetUrControlVersion, payload);
}

std::optional<SoftwareVersion> DecodeUrControlVersion(std::string_view payload) {
  if (payload.size() != 16) return std::nullopt;
  Reader r(payload);
  SoftwareVersion v;
  v.major = static_cast<int>(r.U32());
  v.minor = static_cast<int>(r.U32());
  v.bugfix = static_cast<int>(r.U32());
  v.build = static_cast<int>(r.U32());
  return v;
}

std::string SetupOutputsAnswer(const OutputsSetup& setup) {
  std::string payload;
  PutU8(payload, setup.recipe);
  payload += JoinCommas(setup.types);
  return Encode(Type::kSetupOutputs, payload);
}

std::optional<OutputsSetup> DecodeSetupOutputsAnswer(std::string_view payload) {
  if (payload.empty()) return std::nullopt;
  OutputsSetup out;
  out.recipe = static_cast<uint8_t>(payload[0]);
  out.types = SplitCommas(payload.substr(1));
  return out;
}

std::string Text(const TextMessage& text) {
  std::string payload;
  const auto put = [&](const std::string& s) {
    const size_t n = std::min<size_t>(s.size(), 255);
    PutU8(payload, static_cast<uint8_t>(n));
    payload.append(s, 0, n);
  };
  put(text.message);
  put(text.source);
  PutU8(payload, text.level);
  return Encode(Type::kTextMessage, payload);
}

std::optional<TextMessage> DecodeText(std::string_view payload) {
  Reader r(payload);
  TextMessage t;
  t.message = r.Bytes(r.U8());
  t.source = r.Bytes(r.U8());
  t.level = r.U8();
  if (!r.ok() || r.left() != 0) return std::nullopt;
  return t;
}

namespace {

struct TypeRow {
  ValueType type;
  const char* name;
  size_t count, bytes;  // components, bytes of each
};
constexpr TypeRow kTypes[] = {
    {ValueType::kBool, "BOOL", 1, 1},         {ValueType::kUint8, "UINT8", 1, 1},
    {ValueType::kUint32, "UINT32", 1, 4},     {ValueType::kUint64, "UINT64", 1, 8},
    {ValueType::kInt32, "INT32", 1, 4},       {ValueType::kDouble, "DOUBLE", 1, 8},
    {ValueType::kVector3d, "VECTOR3D", 3, 8}, {ValueType::kVector6d, "VECTOR6D", 6, 8},
    {ValueType::kVector6Int32, "VECTOR6INT32", 6, 4},
    {ValueType::kVector6Uint32, "VECTOR6UINT32", 6, 4},
};

const TypeRow& RowOf(ValueType type) {
  for (const auto& row : kTypes) {
    if (row.type == type) return row;
  }
  return kTypes[0];
}

// The output variables the virtual controller serves (the guide's names and types).
struct OutputRow {
  const char* name;
  ValueType type;
};
constexpr OutputRow kOutputs[] = {
    {"timestamp", ValueType::kDouble},          {"target_q", ValueType::kVector6d},
    {"target_qd", ValueType::kVector6d},        {"actual_q", ValueType::kVector6d},
    {"actual_qd", ValueType::kVector6d},        {"actual_TCP_pose", ValueType::kVector6d},
    {"robot_mode", ValueType::kInt32},          {"joint_mode", ValueType::kVector6Int32},
    {"safety_mode", ValueType::kInt32},         {"safety_status", ValueType::kInt32},
    {"runtime_state", ValueType::kUint32},      {"robot_status_bits", ValueType::kUint32},
    {"safety_status_bits", ValueType::kUint32}, {"speed_scaling", ValueType::kDouble},
    {"target_speed_fraction", ValueType::kDouble},
};

}  // namespace

std::optional<ValueType> ValueTypeOf(std::string_view name) {
  for (const auto& row : kTypes) {
    if (name == row.name) return row.type;
  }
  return std::nullopt;
}
const char* ValueTypeName(ValueType type) { return RowOf(type).name; }
size_t ValueCount(ValueType type) { return RowOf(type).count; }
size_t ValueBytes(ValueType type) { return RowOf(type).count * RowOf(type).bytes; }

std::optional<ValueType> OutputType(std::string_view name) {
  for (const auto& row : kOutputs) {
    if (name == row.name) return row.type;
  }
  return std::nullopt;
}

std::string EncodeData(uint8_t recipe, const std::vector<ValueType>& types,
                       const std::vector<std::vector<double>>& values) {
  std::string payload;
  PutU8(payload, recipe);
  for (size_t k = 0; k < types.size(); ++k) {
    const TypeRow& row = RowOf(types[k]);
    for (size_t c = 0; c < row.count; ++c) {
      const double v = k < values.size() && c < values[k].size() ? values[k][c] : 0.0;
      switch (row.type) {
        case ValueType::kBool:
        case ValueType::kUint8:
          PutU8(payload, static_cast<uint8_t>(v));
          break;
        case ValueType::kUint32:
        case ValueType::kVector6Uint32:
          PutU32(payload, static_cast<uint32_t>(v));
          break;
        case ValueType::kInt32:
        case ValueType::kVector6Int32:
          PutI32(payload, static_cast<int32_t>(v));
          break;
        case ValueType::kUint64:
          PutU64(payload, static_cast<uint64_t>(v));
          break;
        default:
          PutDouble(payload, v);
      }
    }
  }
  return Encode(Type::kDataPackage, payload);
}

std::optional<DataPackage> DecodeData(std::string_view payload, const std::vector<ValueType>& types,
                                      std::string* why) {
  Reader r(payload);
  DataPackage out;
  out.recipe = r.U8();
  size_t expected = 1;
  for (const auto type : types) expected += ValueBytes(type);
  if (payload.size() != expected) {
    if (why)
      *why = fmt::format("data package of {} bytes, the recipe's is {}", payload.size(), expected);
    return std::nullopt;
  }
  for (const auto type : types) {
    const TypeRow& row = RowOf(type);
    std::vector<double> value(row.count);
    for (auto& v : value) {
      switch (row.type) {
        case ValueType::kBool:
        case ValueType::kUint8:
          v = r.U8();
          break;
        case ValueType::kUint32:
        case ValueType::kVector6Uint32:
          v = r.U32();
          break;
        case ValueType::kInt32:
        case ValueType::kVector6Int32:
          v = r.I32();
          break;
        case ValueType::kUint64:
          v = static_cast<double>(r.U64());
          break;
        default:
          v = r.Double();
      }
    }
    out.values.push_back(std::move(value));
  }
  return out;
}

namespace {

constexpr const char* kRobotModes[] = {"DISCONNECTED", "CONFIRM_SAFETY", "BOOTING",
                                       "POWER_OFF",    "POWER_ON",       "IDLE",
                                       "BACKDRIVE",    "RUNNING",        "UPDATING_FIRMWARE"};
constexpr const char* kSafetyModes[] = {"NORMAL",
                                        "REDUCED",
                                        "PROTECTIVE_STOP",
                                        "RECOVERY",
                                        "SAFEGUARD_STOP",
                                        "SYSTEM_EMERGENCY_STOP",
                                        "ROBOT_EMERGENCY_STOP",
                                        "VIOLATION",
                                        "FAULT",
                                        "VALIDATE_JOINT_ID",
                                        "UNDEFINED_SAFETY_MODE",
                                        "AUTOMATIC_MODE_SAFEGUARD_STOP",
                                        "SYSTEM_THREE_POSITION_ENABLING_STOP"};

}  // namespace

std::string RobotModeName(int mode) {
  if (mode == robot_mode::kNoController) return "NO_CONTROLLER";
  if (mode < 0 || mode >= static_cast<int>(std::size(kRobotModes))) return "";
  return kRobotModes[mode];
}

std::string SafetyModeName(int mode) {
  if (mode < 1 || mode > static_cast<int>(std::size(kSafetyModes))) return "";
  return kSafetyModes[mode - 1];
}

std::optional<int> RobotModeFromName(std::string_view name) {
  if (name == "NO_CONTROLLER") return robot_mode::kNoController;
  for (int k = 0; k < static_cast<int>(std::size(kRobotModes)); ++k) {
    if (name == kRobotModes[k]) return k;
  }
  return std::nullopt;
}

std::optional<int> SafetyModeFromName(std::string_view name) {
  for (int k = 0; k < static_cast<int>(std::size(kSafetyModes)); ++k) {
    if (name == kSafetyModes[k]) return k + 1;
  }
  return std::nullopt;
}

}  // namespace rtde

// --- Primary / secondary ----------------------------------------------------------------

namespace primary {

namespace {

// Sub-package sizes of the Client Interface's tables (header of 5 bytes included).
constexpr size_t kRobotModeBytes = 5 + 8 + 7 + 2 + 3 * 8;  // CB3 3.x and e-Series (+1 reserved)
constexpr size_t kJointBytes = 5 + 6 * (3 * 8 + 4 * 4 + 1);
constexpr size_t kKinematicsBytes = 5 + 6 * 4 + 4 * 6 * 8 + 4;

void PutSubHeader(std::string& out, size_t size, uint8_t type) {
  PutI32(out, static_cast<int32_t>(size));
  PutU8(out, type);
}

void PutMessageSize(std::string& out) {
  const auto size = static_cast<uint32_t>(out.size());
  for (int k = 0; k < 4; ++k) out[k] = static_cast<char>(size >> (24 - 8 * k));
}

RobotModeData ReadMode(Reader& r) {
  RobotModeData m;
  m.timestamp = r.U64();
  m.real_robot_connected = r.U8();
  m.real_robot_enabled = r.U8();
  m.power_on = r.U8();
  m.emergency_stopped = r.U8();
  m.protective_stopped = r.U8();
  m.program_running = r.U8();
  m.program_paused = r.U8();
  m.robot_mode = r.U8();
  m.control_mode = r.U8();
  m.target_speed_fraction = r.Double();
  m.speed_scaling = r.Double();
  m.target_speed_fraction_limit = r.Double();
  return m;
}

JointData ReadJoints(Reader& r) {
  JointData j;
  for (int k = 0; k < 6; ++k) {
    j.q_actual[k] = r.Double();
    j.q_target[k] = r.Double();
    j.qd_actual[k] = r.Double();
    r.Skip(4 * 4);  // current, voltage, motor and micro temperatures (float)
    j.mode[k] = r.U8();
  }
  return j;
}

KinematicsInfo ReadKinematics(Reader& r) {
  KinematicsInfo k;
  for (auto& c : k.checksum) c = r.U32();
  for (auto* table : {&k.dh_theta, &k.dh_a, &k.dh_d, &k.dh_alpha})
    for (double& v : *table) v = r.Double();
  k.calibration_status = r.U32();
  return k;
}

}  // namespace

ControllerKinematics KinematicsInfo::ToKinematics() const {
  ControllerKinematics k;
  for (size_t j = 0; j < 6; ++j) {
    k.checksum += fmt::format("{}{:08x}", j ? "-" : "", checksum[j]);
    k.dh_theta_rad.push_back(dh_theta[j]);
    k.dh_a_mm.push_back(dh_a[j] * 1000.0);
    k.dh_d_mm.push_back(dh_d[j] * 1000.0);
    k.dh_alpha_rad.push_back(dh_alpha[j]);
  }
  k.calibration_status = static_cast<int>(calibration_status);
  return k;
}

std::optional<Message> Decode(std::string_view frame, std::string* why) {
  Reader r(frame);
  const auto size = static_cast<uint32_t>(r.I32());
  Message m;
  m.type = r.U8();
  if (!r.ok() || size != frame.size()) {
    if (why) *why = fmt::format("message of {} bytes with size field {}", frame.size(), size);
    return std::nullopt;
  }
  if (m.type == kRobotState) {
    while (r.left() > 0) {
      const auto sub_size = static_cast<uint32_t>(r.I32());
      const uint8_t sub_type = r.U8();
      if (!r.ok() || sub_size < 5 || sub_size - 5 > r.left()) {
        if (why) *why = fmt::format("robot state sub-package of size {} in {} bytes", sub_size, r.left() + 5);
        return std::nullopt;
      }
      const std::string body = r.Bytes(sub_size - 5);  // the reader views it: kept alive
      Reader sub(body);
      // A sub-package shorter than its table is refused; a longer one (a newer software's
      // fields appended) is read as far as the table goes.
      if (sub_type == kRobotModeData && sub_size >= kRobotModeBytes) {
        m.mode = ReadMode(sub);
      } else if (sub_type == kJointData && sub_size >= kJointBytes) {
        m.joints = ReadJoints(sub);
      } else if (sub_type == kKinematicsInfo && sub_size >= kKinematicsBytes) {
        m.kinematics = ReadKinematics(sub);
      } else if (sub_type == kRobotModeData || sub_type == kJointData ||
                 sub_type == kKinematicsInfo) {
        if (why) *why = fmt::format("sub-package {} of {} bytes: too short", sub_type, sub_size);
        return std::nullopt;
      }
    }
    return m;
  }
  if (m.type == kRobotMessage) {
    r.U64();  // timestamp
    r.U8();   // source
    m.message_type = r.U8();
    if (!r.ok()) {
      if (why) *why = "robot message shorter than its header";
      return std::nullopt;
    }
    if (m.message_type == kVersionMessage) {
      VersionMessage v;
      v.project = r.Bytes(r.U8());
      v.major = r.U8();
      v.minor = r.U8();
      v.bugfix = r.I32();
      v.build = r.I32();
      if (!r.ok()) {
        if (why) *why = "version message shorter than its table";
        return std::nullopt;
      }
      v.build_date = r.Rest();
      m.version = v;
    } else if (m.message_type == kTextMessage || m.message_type == kRuntimeExceptionMessage) {
      if (m.message_type == kRuntimeExceptionMessage) r.Skip(8);  // line, column
      m.text = r.Rest();
    }
  }
  return m;
}

std::string EncodeRobotState(const RobotState& s) {
  std::string out(4, '\0');
  PutU8(out, kRobotState);
  const RobotModeData& m = s.mode;
  PutSubHeader(out, kRobotModeBytes + (s.e_series ? 1 : 0), kRobotModeData);
  PutU64(out, m.timestamp);
  for (const bool flag : {m.real_robot_connected, m.real_robot_enabled, m.power_on,
                          m.emergency_stopped, m.protective_stopped, m.program_running,
                          m.program_paused})
    PutU8(out, flag ? 1 : 0);
  PutU8(out, m.robot_mode);
  PutU8(out, m.control_mode);
  PutDouble(out, m.target_speed_fraction);
  PutDouble(out, m.speed_scaling);
  PutDouble(out, m.target_speed_fraction_limit);
  if (s.e_series) PutU8(out, 0);  // e-Series: one reserved byte
  const JointData& j = s.joints;
  PutSubHeader(out, kJointBytes, kJointData);
  for (int k = 0; k < 6; ++k) {
    PutDouble(out, j.q_actual[k]);
    PutDouble(out, j.q_target[k]);
    PutDouble(out, j.qd_actual[k]);
    PutFloat(out, 0.5f);   // current, A
    PutFloat(out, 48.0f);  // voltage, V
    PutFloat(out, 32.0f);  // motor temperature, °C
    PutFloat(out, 0.0f);   // micro temperature (deprecated)
    PutU8(out, j.mode[k]);
  }
  if (s.kinematics) {
    const KinematicsInfo& k = *s.kinematics;
    PutSubHeader(out, kKinematicsBytes, kKinematicsInfo);
    for (const auto c : k.checksum) PutU32(out, c);
    for (const auto* table : {&k.dh_theta, &k.dh_a, &k.dh_d, &k.dh_alpha})
      for (const double v : *table) PutDouble(out, v);
    PutU32(out, k.calibration_status);
  }
  PutMessageSize(out);
  return out;
}

std::string EncodeVersion(uint64_t timestamp, const VersionMessage& v) {
  std::string out(4, '\0');
  PutU8(out, kRobotMessage);
  PutU64(out, timestamp);
  PutU8(out, 255);  // source: the controller (-1)
  PutU8(out, kVersionMessage);
  PutU8(out, static_cast<uint8_t>(std::min<size_t>(v.project.size(), 255)));
  out.append(v.project, 0, std::min<size_t>(v.project.size(), 255));
  PutU8(out, v.major);
  PutU8(out, v.minor);
  PutI32(out, v.bugfix);
  PutI32(out, v.build);
  out += v.build_date;
  PutMessageSize(out);
  return out;
}

std::string EncodeText(uint64_t timestamp, uint8_t message_type, std::string_view text) {
  std::string out(4, '\0');
  PutU8(out, kRobotMessage);
  PutU64(out, timestamp);
  PutU8(out, 255);
  PutU8(out, message_type);
  if (message_type == kRuntimeExceptionMessage) {
    PutI32(out, 1);  // line
    PutI32(out, 1);  // column
  }
  out.append(text);
  PutMessageSize(out);
  return out;
}

}  // namespace primary

// --- Dashboard -----------------------------------------------------------------------------

namespace dashboard {

std::optional<std::string> Field(std::string_view line, std::string_view label) {
  if (line.size() <= label.size() + 1 || line.compare(0, label.size(), label) != 0 ||
      line[label.size()] != ':')
    return std::nullopt;
  std::string_view rest = line.substr(label.size() + 1);
  while (!rest.empty() && rest.front() == ' ') rest.remove_prefix(1);
  while (!rest.empty() && (rest.back() == ' ' || rest.back() == '\r')) rest.remove_suffix(1);
  if (rest.empty()) return std::nullopt;
  return std::string(rest);
}

std::optional<bool> Boolean(std::string_view line) {
  while (!line.empty() && (line.back() == ' ' || line.back() == '\r')) line.remove_suffix(1);
  if (line == "true") return true;
  if (line == "false") return false;
  return std::nullopt;
}

std::optional<SoftwareVersion> PolyscopeVersion(std::string_view line) {
  constexpr std::string_view kPrefix = "URSoftware ";
  if (line.compare(0, kPrefix.size(), kPrefix) != 0) return std::nullopt;
  std::string_view rest = line.substr(kPrefix.size());
  SoftwareVersion v;
  int* parts[] = {&v.major, &v.minor, &v.bugfix, &v.build};
  const char* at = rest.data();
  const char* end = rest.data() + rest.size();
  for (int k = 0; k < 4; ++k) {
    const auto [next, error] = std::from_chars(at, end, *parts[k]);
    if (error != std::errc()) return k >= 2 ? std::optional(v) : std::nullopt;
    at = next;
    if (k < 3) {
      if (at == end || *at != '.') return k >= 2 ? std::optional(v) : std::nullopt;
      ++at;
    }
  }
  return v;
}

bool NotUnderstood(std::string_view line) { return line.starts_with("Could not understand"); }

}  // namespace dashboard

// --- URScript ------------------------------------------------------------------------------

double MoveJDuration(double distance_rad, double a, double v) {
  const double d = std::abs(distance_rad);
  if (d <= v * v / a) return 2.0 * std::sqrt(d / a);  // a triangle: v never reached
  return d / v + v / a;
}

std::string MoveJ(const Eigen::VectorXd& joints_rad, double a_rad_s2, double v_rad_s) {
  std::string list;
  for (Eigen::Index k = 0; k < joints_rad.size(); ++k)
    list += fmt::format("{}{:.12f}", k ? ", " : "", joints_rad(k));
  return fmt::format("movej([{}], a={:.6g}, v={:.6g})\n", list, a_rad_s2, v_rad_s);
}

std::string MoveL(const Eigen::VectorXd& joints_rad, double a_m_s2, double v_m_s) {
  std::string line = MoveJ(joints_rad, a_m_s2, v_m_s);
  line[4] = 'l';
  return line;
}

std::string MoveC(const Eigen::VectorXd& via_rad, const Eigen::VectorXd& joints_rad, double a_m_s2,
                  double v_m_s) {
  const auto list = [](const Eigen::VectorXd& q) {
    std::string out;
    for (Eigen::Index k = 0; k < q.size(); ++k) out += fmt::format("{}{:.12f}", k ? ", " : "", q(k));
    return out;
  };
  return fmt::format("movec([{}], [{}], a={:.6g}, v={:.6g})\n", list(via_rad), list(joints_rad),
                     a_m_s2, v_m_s);
}

namespace {

std::string_view Trim(std::string_view s) {
  while (!s.empty() && std::isspace(static_cast<unsigned char>(s.front()))) s.remove_prefix(1);
  while (!s.empty() && std::isspace(static_cast<unsigned char>(s.back()))) s.remove_suffix(1);
  return s;
}

std::optional<double> Number(std::string_view text) {
  text = Trim(text);
  double v = 0.0;
  const auto [end, error] = std::from_chars(text.data(), text.data() + text.size(), v);
  if (error != std::errc() || end != text.data() + text.size() || !std::isfinite(v))
    return std::nullopt;
  return v;
}

}  // namespace

std::optional<MoveCommand> ParseMove(std::string_view line, std::string* why) {
  const auto fail = [&](const std::string& what) -> std::optional<MoveCommand> {
    if (why) *why = what;
    return std::nullopt;
  };
  line = Trim(line);
  MoveCommand out;
  constexpr std::string_view kJoint = "movej(", kLinear = "movel(", kCircular = "movec(";
  if (line.compare(0, kLinear.size(), kLinear) == 0 || line.compare(0, kCircular.size(), kCircular) == 0) {
    out.linear = true;
    out.circular = line[4] == 'c';
    out.a = 1.2;
    out.v = 0.25;
  } else if (line.compare(0, kJoint.size(), kJoint) != 0) {
    return fail("not a movej(...), movel(...) or movec(...) call");
  }
  if (line.back() != ')') return fail("the call has no closing ')'");
  const std::string name(line.substr(0, 5));
  std::string_view args = Trim(line.substr(kJoint.size(), line.size() - kJoint.size() - 1));
  // A joint list "[q1, …, q6]" at the front of `args`, which moves past it.
  std::string list_error;
  const auto list = [&](const char* which) -> std::optional<Eigen::VectorXd> {
    if (args.empty() || args.front() != '[') {
      list_error = fmt::format("{}'s {} argument is no joint list", name, which);
      return std::nullopt;
    }
    const size_t close = args.find(']');
    if (close == std::string_view::npos) {
      list_error = "the joint list has no ']'";
      return std::nullopt;
    }
    std::vector<double> joints;
    for (const auto& item : SplitCommas(args.substr(1, close - 1))) {
      const auto v = Number(item);
      if (!v) {
        list_error = "joint " + std::to_string(joints.size() + 1) + " is no number";
        return std::nullopt;
      }
      joints.push_back(*v);
    }
    if (joints.size() != 6) {
      list_error = fmt::format("{} joints, a UR has 6", joints.size());
      return std::nullopt;
    }
    args = Trim(args.substr(close + 1));
    return Eigen::Map<const Eigen::VectorXd>(joints.data(), 6);
  };
  const auto first = list("first");
  if (!first) return fail(list_error);
  out.joints_rad = *first;
  if (out.circular) {  // movec(via, to, …): the first list is the via point
    if (args.empty() || args.front() != ',') return fail("movec takes a via point and a target");
    args = Trim(args.substr(1));
    const auto to = list("second");
    if (!to) return fail(list_error);
    out.via_rad = *first;
    out.joints_rad = *to;
  }
  std::string_view rest = args;
  while (!rest.empty()) {
    if (rest.front() != ',') return fail("expected ', a=…' or ', v=…' after the joint list");
    rest = Trim(rest.substr(1));
    const size_t next = rest.find(',');
    const std::string_view item = rest.substr(0, next);
    const size_t eq = item.find('=');
    if (eq == std::string_view::npos) return fail("expected a=… or v=…");
    const std::string_view key = Trim(item.substr(0, eq));
    const auto value = Number(item.substr(eq + 1));
    if (!value || !(*value > 1e-6) || *value > 1000.0)
      return fail(std::string(key) + " is no positive number up to 1000");
    if (key == "a")
      out.a = *value;
    else if (key == "v")
      out.v = *value;
    else if (key != "r")  // a blend radius changes nothing in a single move
      return fail("unsupported argument " + std::string(key) + " (the move takes a and v)");
    rest = next == std::string_view::npos ? std::string_view() : rest.substr(next);
  }
  return out;
}

}  // namespace armsig::robots::ur
