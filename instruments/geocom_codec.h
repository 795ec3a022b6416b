// Leica GeoCOM ASCII codec (pure: bytes ⇄ messages, no I/O).
//   request  [LF]%R1Q,<RPC>[,<TrId>[,<CRC>]]:<P0>,<P1>…CRLF
//   reply    %R1P,<RC_COM>[,<TrId>[,<CRC>]]:<RC>[,<V0>,<V1>…]CRLF
// CRC-16/ARC over the frame without its CRC field and terminator. Units: rad, m, ms.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

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

enum class ParseError { kNotAFrame, kMalformed, kBadCrc };
struct ParsedReply {
  std::optional<Reply> reply;
  std::optional<ParseError> error;
  bool had_crc = false;
};
// Parses one line (terminator stripped; leading noise before '%' is skipped).
ParsedReply ParseReply(std::string_view line);
struct ParsedRequest {
  std::optional<Request> request;
  std::optional<ParseError> error;
  bool had_crc = false;
};
ParsedRequest ParseRequest(std::string_view line);

// Parameter encodings (GeoCOM manual, "ASCII protocol parameter types").
std::string EncodeDouble(double value, int digits = 15);
std::string EncodeString(std::string_view text);  // "…" with \xNN and \" escapes
std::optional<double> DecodeDouble(std::string_view text);
std::optional<long> DecodeLong(std::string_view text);  // decimal or 0x hex
std::optional<std::string> DecodeString(std::string_view text);
std::optional<int> DecodeByte(std::string_view text);  // '2f'

// Return codes.
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
