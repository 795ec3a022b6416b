// Leica emScon TPI binary codec (pure: bytes ⇄ messages, no I/O). Layouts, sources and
// uncertainties: instruments/EMSCON.md. Every packet starts with an 8-byte header
// {int32 lPacketSize (whole packet, header included), int32 type}; structures are packed
// to 4 bytes, little-endian, so a field's offset is the sum of the sizes before it. Every
// field is packed and unpacked explicitly at its offset (never a struct cast onto a buffer).
// Enumerated values (command ids, result statuses, status changes, units) are kept as raw
// int32: a value this table does not know is still carried and named by its number.
#pragma once

#include <Eigen/Core>
#include <array>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <variant>
#include <vector>

#include "instruments/frame_splitter.h"

namespace armsig::instruments::emscon {

// --- Framing -------------------------------------------------------------------------

inline constexpr size_t kHeaderBytes = 8;
// The smallest packet (SystemStatusChangeT, a parameterless command) and the largest one a
// client accepts (64 KiB; only the camera image of non-AT4xx trackers is larger).
inline constexpr int32_t kMinPacketBytes = 12;
inline constexpr int32_t kMaxPacketBytes = 65536;

// Splits a byte stream into packets by their size field (int32, little-endian, the whole
// packet): instruments/frame_splitter.h with emScon's bounds.
class FrameSplitter : public instruments::FrameSplitter {
 public:
  FrameSplitter() : instruments::FrameSplitter({4, false, kMinPacketBytes, kMaxPacketBytes}) {}
};

// --- Enumerations (ES_C_API_Def.h; EMSCON.md §1.3, §2) --------------------------------

namespace packet_type {  // ES_DataType
inline constexpr int32_t kCommand = 0;
inline constexpr int32_t kError = 1;
inline constexpr int32_t kSingleMeasResult = 2;
inline constexpr int32_t kMultiMeasResult = 3;
inline constexpr int32_t kNivelResult = 6;
inline constexpr int32_t kReflectorPosResult = 7;
inline constexpr int32_t kSystemStatusChange = 8;
inline constexpr int32_t kSingleMeasResult2 = 9;
}  // namespace packet_type

namespace status {  // ES_ResultStatus (a few; StatusName knows them all)
inline constexpr int32_t kAllOk = 0;
inline constexpr int32_t kServerBusy = 1;
inline constexpr int32_t kNotImplemented = 2;
inline constexpr int32_t kWrongParameter = 3;
inline constexpr int32_t kWrongParameter1 = 4;
inline constexpr int32_t kNoDistanceSet = 37;
inline constexpr int32_t kTrackerNotInitialized = 39;
inline constexpr int32_t kMeasurementStatusNotReady = 10004;
inline constexpr int32_t kNoStationaryResult = 10009;
inline constexpr int32_t kSensorNotStable = 10013;
}  // namespace status

namespace status_change {  // ES_SystemStatusChange (a few; StatusChangeName knows them all)
inline constexpr int32_t kEnvironmentParamsChanged = 2;
inline constexpr int32_t kUnitsChanged = 6;
inline constexpr int32_t kReflectorChanged = 7;
inline constexpr int32_t kSystemSettingsChanged = 8;
inline constexpr int32_t kCoordinateSystemTypeChanged = 12;
inline constexpr int32_t kMeasurementModeChanged = 17;
inline constexpr int32_t kStationaryModeParamsChanged = 18;
inline constexpr int32_t kMeasStatusNotReady = 25;
inline constexpr int32_t kMeasStatusBusy = 26;
inline constexpr int32_t kMeasStatusReady = 27;
inline constexpr int32_t kIsFace1 = 30;
inline constexpr int32_t kIsFace2 = 31;
inline constexpr int32_t kInitializationStatusChanged = 151;
}  // namespace status_change

namespace length_unit {  // ES_LengthUnit
inline constexpr int32_t kMeter = 0, kMillimeter = 1, kMicron = 2, kFoot = 3, kYard = 4, kInch = 5;
}
namespace angle_unit {  // ES_AngleUnit
inline constexpr int32_t kRadian = 0, kDegree = 1, kGon = 2;
}
namespace temperature_unit {  // ES_TemperatureUnit
inline constexpr int32_t kCelsius = 0, kFahrenheit = 1;
}
namespace pressure_unit {  // ES_PressureUnit (mbar = hPa)
inline constexpr int32_t kMbar = 0, kHPascal = 1, kKPascal = 2, kMmHg = 3, kPsi = 4, kInH2O = 5,
                         kInHg = 6;
}
namespace humidity_unit {  // ES_HumidityUnit
inline constexpr int32_t kRelativeHumidity = 0;
}
namespace coordinate_system {  // ES_CoordinateSystemType
inline constexpr int32_t kRHR = 0, kLHRX = 1, kLHRY = 2, kLHRZ = 3, kCCW = 4, kCCC = 5, kSCW = 6,
                         kSCC = 7;
}
namespace meas_mode {  // ES_MeasMode
inline constexpr int32_t kStationary = 0;
inline constexpr int32_t kContinuousTime = 1;
inline constexpr int32_t kContinuousDistance = 2;
}
namespace region_type {  // ES_RegionType (continuous modes' optional region)
inline constexpr int32_t kSphere = 0, kBox = 1;
}
namespace continuous_status {  // ES_MeasurementStatus of a continuous record
inline constexpr int32_t kAllOk = 0, kSpeedWarning = 1, kSpeedExceeded = 2, kPrismError = 3,
                         kTriggerTimeViolation = 4;
}
namespace tracker_processor_status {  // ES_TrackerProcessorStatus
inline constexpr int32_t kInitialized = 5;
}
namespace system_parameter {                              // ES_SystemParameter
inline constexpr int32_t kInclinationSensorState = 5002;  // AT4xx: 0 off, 2 apply corrections
}

// "Initialize", "ES_RS_ServerBusy", "MeasStatus_Ready"; a value not in the table is named
// by its number ("command 777", "ES_RS 24017", "status change 4711").
std::string CommandName(int32_t command);
std::string StatusName(int32_t status);
// What a status means at the tracker, in a technician's words, for the statuses a capture
// meets ("the beam broke or the reflector left it: no distance"); "" for the others.
std::string StatusAdvice(int32_t status);
std::string StatusChangeName(int32_t change);
std::string PacketTypeName(int32_t type);

// --- Parameter blocks -----------------------------------------------------------------

struct Units {  // SystemUnitsDataT: ES_LengthUnit, ES_AngleUnit, … (raw values)
  int32_t length = length_unit::kMillimeter;
  int32_t angle = angle_unit::kRadian;
  int32_t temperature = temperature_unit::kCelsius;
  int32_t pressure = pressure_unit::kMbar;
  int32_t humidity = humidity_unit::kRelativeHumidity;
  bool operator==(const Units&) const = default;
};

struct SystemSettings {  // SystemSettingsDataT
  int32_t weather_monitor_status = 0;
  bool apply_transformation = false, apply_station_orientation = false, keep_last_position = false,
       send_unsolicited_messages = false, send_reflector_position = false,
       try_measurement_mode = false, has_nivel = false, has_video_camera = false;
  bool operator==(const SystemSettings&) const = default;
};

// --- Commands (client → server: BasicCommandCT + parameters) ---------------------------
// One struct per command armsig sends; kCommand is its ES_Command id, the members its
// parameters in wire order.

struct Initialize {
  static constexpr int32_t kCommand = 7;
  bool operator==(const Initialize&) const = default;
};
struct GetSystemStatus {
  static constexpr int32_t kCommand = 1;
  bool operator==(const GetSystemStatus&) const = default;
};
struct SetUnits {
  static constexpr int32_t kCommand = 5;
  Units units;
  bool operator==(const SetUnits&) const = default;
};
struct SetEnvironmentParams {  // in the current units
  static constexpr int32_t kCommand = 20;
  double temperature = 0, pressure = 0, humidity = 0;
  bool operator==(const SetEnvironmentParams&) const = default;
};
struct GetEnvironmentParams {
  static constexpr int32_t kCommand = 21;
  bool operator==(const GetEnvironmentParams&) const = default;
};
struct SetMeasurementMode {
  static constexpr int32_t kCommand = 24;
  int32_t mode = meas_mode::kStationary;
  bool operator==(const SetMeasurementMode&) const = default;
};
struct SetCoordinateSystemType {
  static constexpr int32_t kCommand = 26;
  int32_t type = coordinate_system::kRHR;
  bool operator==(const SetCoordinateSystemType&) const = default;
};
struct SetStationaryModeParams {
  static constexpr int32_t kCommand = 28;
  int32_t meas_time_ms = 1000;
  bool use_adm = false;
  bool operator==(const SetStationaryModeParams&) const = default;
};
struct SetReflector {
  static constexpr int32_t kCommand = 40;
  int32_t reflector_id = 0;
  bool operator==(const SetReflector&) const = default;
};
struct GetReflector {
  static constexpr int32_t kCommand = 41;
  bool operator==(const GetReflector&) const = default;
};
struct GetReflectors {
  static constexpr int32_t kCommand = 42;
  bool operator==(const GetReflectors&) const = default;
};
struct SetSystemSettings {
  static constexpr int32_t kCommand = 47;
  SystemSettings settings;
  bool operator==(const SetSystemSettings&) const = default;
};
struct GetSystemSettings {
  static constexpr int32_t kCommand = 48;
  bool operator==(const GetSystemSettings&) const = default;
};
struct StartMeasurement {
  static constexpr int32_t kCommand = 49;
  bool operator==(const StartMeasurement&) const = default;
};
// ContinuousTimeModeDataT: a point every `time_separation_ms`, `number_of_points` of them (0:
// until StopMeasurement), optionally only inside a region.
struct SetContinuousTimeModeParams {
  static constexpr int32_t kCommand = 30;
  int32_t time_separation_ms = 10;
  int32_t number_of_points = 0;
  bool use_region = false;
  int32_t region_type = region_type::kSphere;
  bool operator==(const SetContinuousTimeModeParams&) const = default;
};
// ContinuousDistanceModeDataT: a point every `spatial_distance` (current length unit).
struct SetContinuousDistanceModeParams {
  static constexpr int32_t kCommand = 32;
  double spatial_distance = 1.0;
  int32_t number_of_points = 0;
  bool use_region = false;
  int32_t region_type = region_type::kSphere;
  bool operator==(const SetContinuousDistanceModeParams&) const = default;
};
struct StopMeasurement {
  static constexpr int32_t kCommand = 52;
  bool operator==(const StopMeasurement&) const = default;
};
struct ChangeFace {
  static constexpr int32_t kCommand = 53;
  bool operator==(const ChangeFace&) const = default;
};
struct GoPosition {  // in the current coordinate system type and units
  static constexpr int32_t kCommand = 55;
  double val1 = 0, val2 = 0, val3 = 0;
  bool use_adm = false;
  bool operator==(const GoPosition&) const = default;
};
struct FindReflector {  // approximate distance in the current length unit
  static constexpr int32_t kCommand = 63;
  double approx_distance = 0;
  bool operator==(const FindReflector&) const = default;
};
struct GetFace {
  static constexpr int32_t kCommand = 98;
  bool operator==(const GetFace&) const = default;
};
struct GetLongSystemParameter {
  static constexpr int32_t kCommand = 121;
  int32_t parameter = 0;
  bool operator==(const GetLongSystemParameter&) const = default;
};

using Request = std::variant<Initialize, GetSystemStatus, SetUnits, SetEnvironmentParams,
                             GetEnvironmentParams, SetMeasurementMode, SetCoordinateSystemType,
                             SetStationaryModeParams, SetReflector, GetReflector, GetReflectors,
                             SetSystemSettings, GetSystemSettings, StartMeasurement, ChangeFace,
                             GoPosition, FindReflector, GetFace, GetLongSystemParameter,
                             SetContinuousTimeModeParams, SetContinuousDistanceModeParams,
                             StopMeasurement>;

int32_t CommandOf(const Request& request);
std::string EncodeRequest(const Request& request);

// --- Server → client packets ----------------------------------------------------------

struct SystemStatus {  // GetSystemStatusRT payload
  int32_t last_result_status = 0, tracker_processor_status = 0, laser_status = 0, adm_status = 0;
  int32_t version_major = 0, version_minor = 0, version_build = 0;
  int32_t weather_monitor_status = 0, flags = 0, serial = 0;
  bool operator==(const SystemStatus&) const = default;
};
struct ReflectorInfo {  // one GetReflectorsRT (the server sends one per reflector)
  int32_t total = 0, id = 0, target_type = 0;
  double surface_offset = 0;  // in the current length unit
  std::string name;           // UTF-8 (UTF-16LE, 32 code units on the wire)
  bool operator==(const ReflectorInfo&) const = default;
};
struct EnvironmentParams {  // GetEnvironmentParamsRT payload, in the current units
  double temperature = 0, pressure = 0, humidity = 0;
  bool operator==(const EnvironmentParams&) const = default;
};
struct Int32Value {  // GetFace (ES_TrackerFace), GetReflector (internal reflector id)
  int32_t value = 0;
  bool operator==(const Int32Value&) const = default;
};
struct LongParameter {  // GetLongSystemParameterRT payload
  int32_t parameter = 0, value = 0;
  bool operator==(const LongParameter&) const = default;
};

// A command's reply (type 0): BasicCommandRT, the echo of the command id and the result
// status, then the command's payload. The payload is decoded only for status AllOK and a
// command whose reply layout this codec knows; otherwise `data` is empty.
struct CommandAnswer {
  int32_t command = 0;
  int32_t status = status::kAllOk;
  std::variant<std::monostate, SystemStatus, ReflectorInfo, EnvironmentParams, SystemSettings,
               Int32Value, LongParameter>
      data;
  bool operator==(const CommandAnswer&) const = default;
};

// ErrorResponseT (type 1): the command concerned (for an unsolicited error possibly
// another or ES_C_Unknown) and the status.
struct ErrorResponse {
  int32_t command = 0;
  int32_t status = 0;
  bool operator==(const ErrorResponse&) const = default;
};

// SingleMeasResultT (type 2, 156 bytes) or SingleMeasResult2T (type 9, 204 bytes, with
// covariances). Values in the current coordinate system type and units. Neither carries
// a time stamp.
struct MeasResult {
  bool extended = false;  // SingleMeasResult2T
  int32_t status = status::kAllOk;
  int32_t meas_mode = meas_mode::kStationary;
  bool try_mode = false;
  std::array<double, 3> value{}, std_dev{};
  double std_total = 0;
  std::array<double, 3> covariance{};  // 12, 13, 23 (extended only)
  std::array<double, 3> pointing_error{};
  std::array<double, 3> apriori_std{};
  double apriori_std_total = 0;
  std::array<double, 3> apriori_covariance{};  // extended only
  double temperature = 0, pressure = 0, humidity = 0;
  bool operator==(const MeasResult&) const = default;
};

// MultiMeasResultT (type 3): the continuous modes' results, `records` of MeasValueT (36
// bytes each: status, lTime1, lTime2, three values in the current coordinate system type
// and units) after a 48-byte head. The time stamp is the tracker's own clock: lTime1 whole
// seconds, lTime2 microseconds within them (instruments/EMSCON.md §3.2 [uncertain]: the
// header names the two fields only; TimeOf below is the one place that reads them).
struct MeasRecord {
  int32_t status = continuous_status::kAllOk;
  int32_t time1 = 0, time2 = 0;
  std::array<double, 3> value{};
  bool operator==(const MeasRecord&) const = default;
};
struct MultiMeasResult {
  int32_t status = status::kAllOk;
  int32_t meas_mode = meas_mode::kContinuousTime;
  bool try_mode = false;
  double temperature = 0, pressure = 0, humidity = 0;
  std::vector<MeasRecord> records;
  bool operator==(const MultiMeasResult&) const = default;
};
// A record's time stamp on the tracker's clock, seconds; and the fields for one.
double TimeOf(const MeasRecord& record);
void SetTime(MeasRecord& record, double tracker_time_s);
// The most records one packet can carry (64 KiB).
inline constexpr int kMaxRecordsPerPacket = 1800;

struct StatusChange {  // SystemStatusChangeT (type 8)
  int32_t change = 0;
  bool operator==(const StatusChange&) const = default;
};

struct ReflectorPosition {  // ReflectorPosResultT (type 7), streamed while locked
  int32_t status = 0;
  std::array<double, 3> value{};
  bool operator==(const ReflectorPosition&) const = default;
};

using Packet = std::variant<CommandAnswer, ErrorResponse, MeasResult, StatusChange,
                            ReflectorPosition, MultiMeasResult>;

std::string EncodePacket(const Packet& packet);

// --- Decoding -------------------------------------------------------------------------

enum class DecodeError {
  kTruncated,    // fewer bytes than the header, or than its size field says
  kBadSize,      // the size field is outside the bounds or differs from the frame's length
  kUnknownType,  // a type this codec does not decode (a real dispatcher skips it)
  kBadLength,    // the size does not fit the packet's type or the command's reply layout
};
std::string ToString(DecodeError error);

struct DecodedPacket {
  std::optional<Packet> packet;
  std::optional<DecodeError> error;
  int32_t type = -1;  // from the header when there was one
  std::string why;    // with error: what was expected
};
// Decodes one whole frame (as FrameSplitter hands it out).
DecodedPacket DecodePacket(std::string_view frame);

struct DecodedRequest {
  std::optional<Request> request;
  std::optional<DecodeError> error;
  int32_t command = -1;  // when the frame has a command id
  std::string why;
};
// A client's command frame (type 0); a command id this codec does not model is
// kUnknownType with `command` set, so a server can answer it NotImplemented.
DecodedRequest DecodeRequest(std::string_view frame);

// --- Units and armsig's conventions ---------------------------------------------------

// Millimetres per unit, radians per unit; nullopt for a value not in the enum.
std::optional<double> MillimetresPer(int32_t length_unit);
std::optional<double> RadiansPer(int32_t angle_unit);
// A temperature in `temperature_unit` → °C and back; a pressure in `pressure_unit` →
// hPa (= mbar) and back. nullopt for a value not in the enum.
std::optional<double> ToCelsius(double value, int32_t temperature_unit);
std::optional<double> FromCelsius(double celsius, int32_t temperature_unit);
std::optional<double> ToHectopascal(double value, int32_t pressure_unit);
std::optional<double> FromHectopascal(double hpa, int32_t pressure_unit);

// armsig's theodolite frame (the interface reference's "Conventions"): origin at the
// instrument's axes, z up along the standing axis, y towards horizontal circle zero,
// x = y × z; Hz grows clockwise seen from above (Hz = π/2 along +x), V is the zenith angle.
// A point is (d sin V sin Hz, d sin V cos Hz, d cos V). A tracker station's frame is the
// tracker's own Cartesian frame (RHR): its readings are these angles of the RHR point.
struct Spherical {
  double hz_rad = 0, v_rad = 0, distance_mm = 0;
};
Eigen::Vector3d PointFromSpherical(const Spherical& s);
// Hz in [0, 2π), V in [0, π], distance ≥ 0; the origin gives all zeros.
Spherical SphericalFromPoint(const Eigen::Vector3d& point_mm);

// The tracker's spherical counter-clockwise type (SCC, coordinate_system::kSCC) as public
// emScon clients read and write it (instruments/EMSCON.md §7): dVal1 = Hz = atan2(y, x),
// counter-clockwise from the tracker's +x; dVal2 = V = acos(z / d), the zenith angle;
// dVal3 = d, the slope distance; (x, y, z) the tracker's RHR frame. Any Hz (±2π) is read.
struct SphericalCcw {
  double hz_rad = 0, v_rad = 0, distance_mm = 0;
};
Eigen::Vector3d PointFromScc(const SphericalCcw& s);
// Hz in (−π, π] (atan2), V in [0, π], distance ≥ 0; the origin gives all zeros.
SphericalCcw SccFromPoint(const Eigen::Vector3d& point_mm);

}  // namespace armsig::instruments::emscon
