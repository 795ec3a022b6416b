// Leica GeoCOM ASCII codec (pure: bytes ⇄ messages, no I/O).
//   request  [LF]%R1Q,<RPC>[,<TrId>[,<CRC>]]:<P0>,<P1>…CRLF
//   reply    %R1P,<RC_COM>[,<TrId>[,<CRC>]]:<RC>[,<V0>,<V1>…]CRLF
// CRC-16/ARC over the frame without its CRC field and terminator. Units: rad, m, ms.
#pragma once

#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "instruments/return_codes.h"

namespace armsig::instruments::geocom {

// CRC-16/ARC: reflected polynomial 0xA001, init 0, no final xor ("123456789" → 0xBB3D).
uint16_t Crc16Arc(std::string_view data);

struct Request {
  int rpc = 0;
  std::optional<int> trid;
  std::vector<std::string> params;  // already encoded
};

struct Reply {
  int rc_com = 0;
  int trid = 0;  // 0 when the request had none
  int rc = 0;
  std::vector<std::string> values;  // encoded, after rc
};

// "\n%R1Q,rpc,trid[,crc]:p0,p1\r\n" (the leading LF clears the instrument's buffer).
std::string EncodeRequest(const Request& request, bool with_crc);
std::string EncodeReply(const Reply& reply, bool with_crc);

// The longest line a GeoCOM driver accepts. The longest reply armsig reads, TMC_GetAngle1
// (rc and 9 values of up to 20 characters each), is under 250 bytes; instrument names
// and versions are short. A longer line is noise or a flood (COM_OVERRUN).
inline constexpr size_t kMaxLineBytes = 512;

// kMissingCrc: the reply has no CRC field although the link runs with CRCs.
enum class ParseError { kNotAFrame, kMalformed, kBadCrc, kMissingCrc };
struct ParsedReply {
  std::optional<Reply> reply;
  std::optional<ParseError> error;
  bool had_crc = false;
  std::string why;  // with error: the field and what was expected
};
// Parses one line (terminator stripped; leading noise before '%' is skipped, and so is
// a frame cut short by the next one: the last "%R1P," starts the frame). With
// `require_crc` (a link with CRC-16 on every frame) a reply without its CRC field is
// refused (kMissingCrc), never accepted unchecked.
ParsedReply ParseReply(std::string_view line, bool require_crc = false);
struct ParsedRequest {
  std::optional<Request> request;
  std::optional<ParseError> error;
  bool had_crc = false;
  std::string why;  // with error: the field and what was expected
};
ParsedRequest ParseRequest(std::string_view line);

// Parameter encodings (GeoCOM manual, "ASCII protocol parameter types").
std::string EncodeDouble(double value, int digits = 15);
std::string EncodeString(std::string_view text);  // "…" with \xNN and \" escapes
std::string EncodeLong(long value);
std::optional<double> DecodeDouble(std::string_view text);
std::optional<long> DecodeLong(std::string_view text);  // decimal or 0x hex
std::optional<std::string> DecodeString(std::string_view text);
std::optional<int> DecodeByte(std::string_view text);  // '2f'

// Typed reply values (after <rc>) of the RPCs armsig uses, in both directions. Angles
// in rad with 15 decimals (COM_GetDoublePrecision's default), distances in m to the µm
// (6 decimals), times in ms. A decoder names the RPC, the value and what was expected
// in `why`; extra trailing values are ignored (newer firmware may append some).
struct AngleComplete {  // TMC_GetAngle1 (2003)
  double hz_rad = 0, v_rad = 0, angle_accuracy_rad = 0;
  long angle_time_ms = 0;
  double cross_incline_rad = 0, length_incline_rad = 0, incline_accuracy_rad = 0;
  long incline_time_ms = 0;
  long face = 0;  // TMC_FACE: 0 face I, 1 face II
  bool operator==(const AngleComplete&) const = default;
};
std::vector<std::string> EncodeValues(const AngleComplete& values);
std::optional<AngleComplete> DecodeAngleComplete(const std::vector<std::string>& values,
                                                 std::string* why = nullptr);

struct AngleSimple {  // TMC_GetAngle5 (2107)
  double hz_rad = 0, v_rad = 0;
  bool operator==(const AngleSimple&) const = default;
};
std::vector<std::string> EncodeValues(const AngleSimple& values);
std::optional<AngleSimple> DecodeAngleSimple(const std::vector<std::string>& values,
                                             std::string* why = nullptr);

struct SimpleMeasurement {  // TMC_GetSimpleMea (2108): Hz, V, slope distance
  double hz_rad = 0, v_rad = 0;
  std::optional<double> slope_distance_m;  // absent when the reply carries angles only
  bool operator==(const SimpleMeasurement&) const = default;
};
std::vector<std::string> EncodeValues(const SimpleMeasurement& values);
std::optional<SimpleMeasurement> DecodeSimpleMeasurement(const std::vector<std::string>& values,
                                                         std::string* why = nullptr);

struct DistanceAngle {  // BAP_MeasDistanceAngle (17017): Hz, V, slope distance, DistMode
  double hz_rad = 0, v_rad = 0, slope_distance_m = 0;
  long dist_mode = 0;
  bool operator==(const DistanceAngle&) const = default;
};
std::vector<std::string> EncodeValues(const DistanceAngle& values);
std::optional<DistanceAngle> DecodeDistanceAngle(const std::vector<std::string>& values,
                                                 std::string* why = nullptr);

struct Version {  // COM_GetSWVersion (110), CSV_GetSWVersion (5034)
  long release = 0, version = 0, subversion = 0;
  bool operator==(const Version&) const = default;
};
std::vector<std::string> EncodeValues(const Version& values);
std::optional<Version> DecodeVersion(const std::vector<std::string>& values,
                                     std::string* why = nullptr);

// Single-value replies: CSV_GetInstrumentName (string), CSV_GetInstrumentNo,
// TMC_GetFace, TMC_GetInclineSwitch, COM_GetDoublePrecision (long). `what` names the
// RPC in `why`.
std::optional<std::string> DecodeStringValue(const std::vector<std::string>& values,
                                             std::string_view what, std::string* why = nullptr);
std::optional<long> DecodeLongValue(const std::vector<std::string>& values, std::string_view what,
                                    std::string* why = nullptr);

// Return codes: the constants in instruments/return_codes.h (geocom::grc::kOk …).
namespace grc = instruments::grc;

enum class CodeClass {
  kOk,
  kWarningDataValid,  // 1283, 1284: data valid, a correction or accuracy caveat
  kAnglesOnly,        // 1285, 1288, 1289: angles valid, no distance
  kBusy,              // retry after a delay: 13, 786, 1293, 1793, 3107, 3108
  kError,
};
CodeClass Classify(int code);
// "TMC_ACCURACY_GUARANTEE" etc.; "GRC_<code>" for codes not in the table.
std::string CodeName(int code);
// A short explanation for the technician.
std::string CodeMeaning(int code);

// RPC numbers used by the driver and the simulator.
namespace rpc {
inline constexpr int kNullProc = 0;
inline constexpr int kGetDoublePrecision = 108;
inline constexpr int kSetDoublePrecision = 107;
inline constexpr int kGetGeoComVersion = 110;
inline constexpr int kGetInstrumentNo = 5003;
inline constexpr int kGetInstrumentName = 5004;
inline constexpr int kGetFirmwareVersion = 5034;
inline constexpr int kGetAngleComplete = 2003;  // TMC_GetAngle1
inline constexpr int kGetAngleSimple = 2107;    // TMC_GetAngle5
inline constexpr int kGetSimpleMea = 2108;
inline constexpr int kDoMeasure = 2008;
inline constexpr int kSetInclineSwitch = 2006;
inline constexpr int kGetInclineSwitch = 2007;
inline constexpr int kGetFace = 2026;
inline constexpr int kMakePositioning = 9027;
inline constexpr int kChangeFace = 9028;
inline constexpr int kFineAdjust = 9037;
inline constexpr int kMeasDistanceAngle = 17017;
}  // namespace rpc

}  // namespace armsig::instruments::geocom
