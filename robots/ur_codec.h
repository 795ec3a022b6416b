// Universal Robots controller protocols, pure codec (bytes ⇄ messages, no I/O), written from
// Universal Robots' public documents:
//   - "Real-Time Data Exchange (RTDE) Guide", support article 22229 (protocol version 2):
//     packages {uint16 size (whole package), uint8 type, payload}, big-endian; the requests
//     V (protocol version), v (URControl version), O (setup outputs: double frequency + the
//     variable names, comma-separated), S (start), P (pause); the controller's answers and
//     its data packages U {uint8 recipe id, the recipe's values in order}; text messages M.
//   - "Client Interface" (the primary/secondary interfaces, ports 30001/30002) and its Excel of
//     packet layouts (CB3 3.x and e-Series 5.x): messages {int32 size, uint8 type, payload},
//     big-endian; type 16 robot state = sub-packages {int32 size, uint8 type, …}: 0 robot
//     mode data, 1 joint data, 5 KinematicsInfo; type 20 robot message {uint64 timestamp,
//     int8 source, uint8 message type, …}: 3 version message.
//   - "Dashboard Server CB-Series" (port 29999, software 3.x) and "Dashboard Server e-Series"
//     (5.x): one text command per line, one text line per answer.
// URScript `movej([q1, …, q6], a=…, v=…)` lines ("The URScript Programming Language") are
// what the secondary interface is sent.
// The codec serves both ends: the driver (robots/ur_device.h) and the virtual controller
// (simulation/ur_simulator.h).
#pragma once

#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "instruments/device.h"
#include "instruments/frame_splitter.h"

namespace armsig::robots::ur {

// The controller's software version: URControl's over RTDE (major, minor, bugfix, build),
// PolyScope's on the dashboard ("URSoftware 5.11.1.108318 (Nov 03 2021)").
struct SoftwareVersion {
  int major = 0, minor = 0, bugfix = 0, build = 0;
  bool ESeries() const { return major >= 5; }
  // "5.11.1.108318"
  std::string Text() const;
  bool AtLeast(int major_at_least, int minor_at_least) const {
    return major > major_at_least || (major == major_at_least && minor >= minor_at_least);
  }
};

// --- RTDE ------------------------------------------------------------------------------

namespace rtde {

inline constexpr unsigned short kPort = 30004;
inline constexpr uint16_t kProtocolVersion = 2;
inline constexpr size_t kHeaderBytes = 3;
// A package's size field: at least its header; the guide's packages stay far below 64 KiB.
inline constexpr instruments::FrameSplitter::Format kFrames{2, true, 3, 65535};
// The output frequencies the controllers take (the guide: CB3 125 Hz, e-Series 500 Hz).
inline constexpr double kCb3MaxHz = 125.0;
inline constexpr double kESeriesMaxHz = 500.0;

enum class Type : uint8_t {
  kRequestProtocolVersion = 'V',  // 86
  kGetUrControlVersion = 'v',     // 118
  kTextMessage = 'M',             // 77
  kDataPackage = 'U',             // 85
  kSetupOutputs = 'O',            // 79
  kSetupInputs = 'I',             // 73
  kStart = 'S',                   // 83
  kPause = 'P',                   // 80
};

struct Package {
  uint8_t type = 0;
  std::string payload;
};
// One package with its header.
std::string Encode(Type type, std::string_view payload);
// A whole frame (as FrameSplitter hands it out) into its type and payload; nullopt when its
// size field does not match its length (`why` says so).
std::optional<Package> Decode(std::string_view frame, std::string* why);

// Requests, as a client sends them.
std::string RequestProtocolVersion(uint16_t version);
std::string GetUrControlVersion();
std::string SetupOutputs(double frequency_hz, const std::vector<std::string>& names);
std::string Start();
std::string Pause();

// The same decoded (the controller's side).
std::optional<uint16_t> DecodeProtocolVersionRequest(std::string_view payload);
struct OutputsRequest {
  double frequency_hz = 0.0;
  std::vector<std::string> names;
};
std::optional<OutputsRequest> DecodeSetupOutputsRequest(std::string_view payload);

// Answers, as the controller sends them, and decoded (the client's side).
std::string Accepted(Type type, bool accepted);  // V, S, P: uint8 accepted
std::optional<bool> DecodeAccepted(std::string_view payload);
std::string UrControlVersion(const SoftwareVersion& version);  // v: 4 × uint32
std::optional<SoftwareVersion> DecodeUrControlVersion(std::string_view payload);
struct OutputsSetup {
  uint8_t recipe = 0;              // 0: the controller refused the recipe
  std::vector<std::string> types;  // per name: DOUBLE, VECTOR6D, … or NOT_FOUND
};
std::string SetupOutputsAnswer(const OutputsSetup& setup);
std::optional<OutputsSetup> DecodeSetupOutputsAnswer(std::string_view payload);
// Protocol v2 text message: {uint8 n, message, uint8 n, source, uint8 level}.
struct TextMessage {
  std::string message, source;
  uint8_t level = 3;  // 0 exception, 1 error, 2 warning, 3 info
};
std::string Text(const TextMessage& text);
std::optional<TextMessage> DecodeText(std::string_view payload);

// The value types of the guide's data packages.
enum class ValueType {
  kBool,
  kUint8,
  kUint32,
  kUint64,
  kInt32,
  kDouble,
  kVector3d,
  kVector6d,
  kVector6Int32,
  kVector6Uint32,
};
// "DOUBLE" → kDouble; nullopt for NOT_FOUND, IN_USE or a name the guide does not have.
std::optional<ValueType> ValueTypeOf(std::string_view name);
const char* ValueTypeName(ValueType type);
size_t ValueCount(ValueType type);  // 1, 3 or 6
size_t ValueBytes(ValueType type);  // of the whole value
// The type of an output variable the virtual controller knows (the names armsig asks for
// and a few more); nullopt: NOT_FOUND.
std::optional<ValueType> OutputType(std::string_view name);

// A data package's values, each a list of its components (a number for a scalar), as
// doubles: every integer the guide's outputs carry fits a double exactly except uint64
// beyond 2^53, which no output armsig reads is.
struct DataPackage {
  uint8_t recipe = 0;
  std::vector<std::vector<double>> values;
};
std::string EncodeData(uint8_t recipe, const std::vector<ValueType>& types,
                       const std::vector<std::vector<double>>& values);
std::optional<DataPackage> DecodeData(std::string_view payload, const std::vector<ValueType>& types,
                                      std::string* why);

// RTDE's enumerations (the guide's output table).
namespace robot_mode {  // robot_mode, INT32
inline constexpr int kNoController = -1, kDisconnected = 0, kConfirmSafety = 1, kBooting = 2,
                     kPowerOff = 3, kPowerOn = 4, kIdle = 5, kBackdrive = 6, kRunning = 7,
                     kUpdatingFirmware = 8;
}
namespace safety_mode {  // safety_mode, INT32
inline constexpr int kNormal = 1, kReduced = 2, kProtectiveStop = 3, kRecovery = 4,
                     kSafeguardStop = 5, kSystemEmergencyStop = 6, kRobotEmergencyStop = 7,
                     kViolation = 8, kFault = 9, kValidateJointId = 10, kUndefined = 11,
                     kAutomaticModeSafeguardStop = 12, kSystemThreePositionEnablingStop = 13;
}
namespace runtime_state {  // runtime_state, UINT32
inline constexpr int kStopping = 0, kStopped = 1, kPlaying = 2, kPausing = 3, kPaused = 4,
                     kResuming = 5;
}
// "RUNNING", "POWER_OFF", … (the dashboard's words); "" for a value the guide has not.
std::string RobotModeName(int mode);
std::string SafetyModeName(int mode);
// The codes back from the dashboard's words; nullopt for a word the documents have not.
std::optional<int> RobotModeFromName(std::string_view name);
std::optional<int> SafetyModeFromName(std::string_view name);

}  // namespace rtde

// --- Primary / secondary interfaces ----------------------------------------------------

namespace primary {

inline constexpr unsigned short kPrimaryPort = 30001;
inline constexpr unsigned short kSecondaryPort = 30002;
// int32 size, big-endian; a robot state message is a few kilobytes.
inline constexpr instruments::FrameSplitter::Format kFrames{4, true, 5, 1 << 20};

inline constexpr uint8_t kRobotState = 16;
inline constexpr uint8_t kRobotMessage = 20;
// Robot state sub-packages.
inline constexpr uint8_t kRobotModeData = 0;
inline constexpr uint8_t kJointData = 1;
inline constexpr uint8_t kKinematicsInfo = 5;
// Robot message types.
inline constexpr uint8_t kTextMessage = 0;
inline constexpr uint8_t kVersionMessage = 3;
inline constexpr uint8_t kRuntimeExceptionMessage = 10;

struct RobotModeData {
  uint64_t timestamp = 0;  // the controller's clock, µs (CB3 from 3.2 / e-Series: as sent)
  bool real_robot_connected = true, real_robot_enabled = true, power_on = true,
       emergency_stopped = false, protective_stopped = false, program_running = false,
       program_paused = false;
  uint8_t robot_mode = 7, control_mode = 0;
  double target_speed_fraction = 1.0, speed_scaling = 1.0, target_speed_fraction_limit = 1.0;
};
struct JointData {
  std::array<double, 6> q_actual{}, q_target{}, qd_actual{};
  std::array<uint8_t, 6> mode{};  // 253: running
};
// KinematicsInfo: per joint a checksum (uint32) and the DH parameters of the controller's own
// calibration (double; m and rad on the wire), and the calibration status (uint32).
struct KinematicsInfo {
  std::array<uint32_t, 6> checksum{};
  std::array<double, 6> dh_theta{}, dh_a{}, dh_d{}, dh_alpha{};  // rad, m, m, rad
  uint32_t calibration_status = 0;
  // As armsig keeps it (mm, rad; the checksums as 8 hex digits each, joined by '-').
  instruments::ControllerKinematics ToKinematics() const;
};
struct VersionMessage {
  std::string project = "URControl";
  uint8_t major = 0, minor = 0;
  int32_t bugfix = 0, build = 0;
  std::string build_date;
};

// One message of the interface, decoded; what it does not model is skipped.
struct Message {
  uint8_t type = 0;
  std::optional<RobotModeData> mode;
  std::optional<JointData> joints;
  std::optional<KinematicsInfo> kinematics;
  std::optional<VersionMessage> version;
  std::optional<std::string> text;  // a text or runtime-exception message's text
  uint8_t message_type = 0;         // robot messages
};
// A whole frame; nullopt with `why` when a size field does not fit.
std::optional<Message> Decode(std::string_view frame, std::string* why);

// The controller's side.
struct RobotState {
  bool e_series = false;  // robot mode data with the e-Series' reserved byte
  RobotModeData mode;
  JointData joints;
  std::optional<KinematicsInfo> kinematics;
};
std::string EncodeRobotState(const RobotState& state);
std::string EncodeVersion(uint64_t timestamp, const VersionMessage& version);
std::string EncodeText(uint64_t timestamp, uint8_t message_type, std::string_view text);

}  // namespace primary

// --- Dashboard server ------------------------------------------------------------------

namespace dashboard {

inline constexpr unsigned short kPort = 29999;
inline constexpr size_t kMaxLineBytes = 1024;
inline constexpr std::string_view kWelcome = "Connected: Universal Robots Dashboard Server";

// "Robotmode: RUNNING" → "RUNNING"; "Safetymode: NORMAL" / "Safetystatus: PROTECTIVE_STOP" →
// the word; nullopt for another reply.
std::optional<std::string> Field(std::string_view line, std::string_view label);
// "true" / "false" (is in remote control), nullopt otherwise.
std::optional<bool> Boolean(std::string_view line);
// "URSoftware 5.11.1.108318 (Nov 03 2021)" → 5.11.1.108318.
std::optional<SoftwareVersion> PolyscopeVersion(std::string_view line);
// The documents' answer to a command the server does not know: "Could not understand: 'x'".
bool NotUnderstood(std::string_view line);

}  // namespace dashboard

// --- URScript ----------------------------------------------------------------------------

// How long URScript's movej takes: the leading joint (the largest turn, `distance_rad`)
// accelerates at a to v, cruises and brakes at a (a trapezoid; a triangle when it never
// reaches v), the others scaled to end with it.
double MoveJDuration(double distance_rad, double a_rad_s2, double v_rad_s);

// "movej([q1, …, q6], a=A, v=V)\n", joints in rad with 12 decimals (sub-nanoradian).
std::string MoveJ(const Eigen::VectorXd& joints_rad, double a_rad_s2, double v_rad_s);
// "movel([q1, …, q6], a=A, v=V)\n": a linear move of the TCP to the pose the controller's
// forward kinematics gives those joints (the URScript manual: "pose can also be specified as
// joint positions"), a in m/s², v in m/s.
std::string MoveL(const Eigen::VectorXd& joints_rad, double a_m_s2, double v_m_s);
// "movec([via…], [to…], a=A, v=V)\n": a circular move of the TCP through the pose of the
// via joints (its position only) to the pose of the target joints (URScript's movec with
// joint positions, r = 0 and mode 0: the orientation interpolated from start to target).
std::string MoveC(const Eigen::VectorXd& via_rad, const Eigen::VectorXd& joints_rad, double a_m_s2,
                  double v_m_s);
struct MoveCommand {
  bool linear = false;    // movel or movec (the TCP's path and speed); else movej
  bool circular = false;  // movec: through `via_rad` to `joints_rad`
  Eigen::VectorXd joints_rad;
  std::optional<Eigen::VectorXd> via_rad;
  // URScript's defaults: movej a = 1.4 rad/s², v = 1.05 rad/s; movel a = 1.2 m/s², v = 0.25 m/s.
  double a = 1.4, v = 1.05;
};
// One script line that is a movej, movel or movec with joint lists (a, v optional, in either
// order); nullopt with `why` for any other line.
std::optional<MoveCommand> ParseMove(std::string_view line, std::string* why);

}  // namespace armsig::robots::ur
