// KUKA KR C4 / KR C5 through a variable server: the open-source KukaVarProxy (IMTS,
// github.com/ImtsSrl/KUKAVARPROXY, src/basMain.bas and src/frmMain.frm at commit 2745373) or
// the C3 Bridge Interface server, whose protocol document says the same for these two
// messages ("C3 Bridge Interface — Application Protocol Specification", version 1 revision
// 5, 24 March 2022, §3.1–3.5.2, github.com/ulsu-tech/c3bridge-server). Both run on the
// controller's Windows side, reach KRL variables through KUKA's CrossComm, and listen on
// TCP 7000. Pure codec: bytes ⇄ messages and KRL value text ⇄ numbers, no I/O.
//
// Why a variable server: it costs nothing (KUKA.Ethernet KRL and KUKA.RSI are paid options,
// KUKA.OPC UA and mxAutomation too), it needs no change to the controller's I/O or safety
// configuration, and reading $AXIS_ACT after an exact stop is all a calibration capture
// needs from the controller; moves go through a small KRL program armsig ships
// (controllers/kuka/ARMSIG.src, contract below). It has **no authentication**: anyone who
// reaches TCP 7000 can read and write any variable, ARMSIG's targets included. The
// controller belongs on an isolated cell network (docs/how-to/kuka.md); armsig has no
// credentials to keep for it.
//
// Message (all integers big-endian, "network byte order", C3 §1.3):
//   request   tag u16 | length u16 | type u8 | name length u16 | name
//             [type 1, write: | value length u16 | value]
//   response  tag u16 | length u16 | type u8 | value length u16 | value
//             | error code u16 | success u8
// `length` counts every byte after itself. The response echoes the request's tag (any
// value the client chose) and type. Success is 1, failure 0; KukaVarProxy always sends
// 00 01 before it (the length of a one-byte block), C3 Bridge an error code (1 =
// success). A write's response echoes the value written. KukaVarProxy answers a read of a
// variable CrossComm does not know with an empty value and success 1 (basMain.bas ShowVar);
// an empty value is never a reading. The name "PING" reads "PONG" on both servers.
//
// KRL value text (what CrossComm's ShowVar gives and SetVar takes): TRUE / FALSE, decimal
// INT, REAL as "-90.0" or "-1.52587891E-05" (REAL is a 32-bit float on the controller:
// about 7 significant digits), enum values as "#AUT", strings (a CHAR array read as
// NAME[]) in double quotes, structures as {E6AXIS: A1 0.0, A2 -90.0, …} (the type name
// and colon optional, the components by name).
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "instruments/frame_splitter.h"

namespace armsig::robots::kuka {

inline constexpr unsigned short kDefaultPort = 7000;

// The two messages armsig uses (C3 §3.4: CommandReadVariableAscii, CommandWriteVariableAscii;
// KukaVarProxy's function byte 0 and 1).
enum class MessageType : uint8_t { kRead = 0, kWrite = 1 };

// Bounds of a frame (header included). A request has at least a type, a name length and a
// one-byte name; a response at least a type, a value length and the footer. KukaVarProxy
// reads at most 2,048 bytes at a time, so no request armsig sends comes near the maximum;
// a variable's text longer than 8 KiB is no value armsig reads.
inline constexpr int kHeaderBytes = 4;
inline constexpr int kMinRequestBytes = kHeaderBytes + 4;
inline constexpr int kMinResponseBytes = kHeaderBytes + 6;
inline constexpr int kMaxFrameBytes = kHeaderBytes + 8192;
inline constexpr size_t kMaxNameBytes = 256;

struct Request {
  uint16_t tag = 0;
  MessageType type = MessageType::kRead;
  std::string name;
  std::string value;  // kWrite only
};

struct Response {
  uint16_t tag = 0;
  uint8_t type = 0;
  std::string value;
  uint16_t error_code = 1;
  bool success = true;
};

// Throws std::invalid_argument for an empty name, a name beyond kMaxNameBytes or a
// frame beyond kMaxFrameBytes (a driver error, never the controller's).
std::string EncodeRequest(const Request& request);
std::string EncodeResponse(const Response& response);

// A whole frame as FrameSplitter hands it out, decoded; `why` says what was wrong.
struct DecodedRequest {
  std::optional<Request> request;
  std::string why;
};
struct DecodedResponse {
  std::optional<Response> response;
  std::string why;
};
DecodedRequest DecodeRequest(std::string_view frame);
DecodedResponse DecodeResponse(std::string_view frame);

// How FrameSplitter (instruments/frame_splitter.h) splits the stream: the length field
// after the tag counts the bytes after itself. A length outside the bounds means the stream
// lost its framing. A client splits responses, a server requests (a shorter minimum).
inline constexpr instruments::FrameSplitter::Format kResponseFrames{2, true, kMinResponseBytes,
                                                       kMaxFrameBytes, 2, kHeaderBytes};
inline constexpr instruments::FrameSplitter::Format kRequestFrames{2, true, kMinRequestBytes, kMaxFrameBytes,
                                                      2, kHeaderBytes};

// --- KRL value text ---------------------------------------------------------------------

std::optional<bool> ParseBool(std::string_view text);
std::optional<int64_t> ParseInt(std::string_view text);  // decimal, within INT's 32 bits
std::optional<double> ParseReal(std::string_view text);  // finite
// "#AUT" → "AUT" (the enum value without '#').
std::optional<std::string> ParseEnum(std::string_view text);
// "\"KR 16-2\"" → KR 16-2. KRL doubles no quote inside a string; the text between the
// first and the last quote is taken, and trailing blanks of a CHAR array are dropped.
std::optional<std::string> ParseString(std::string_view text);

// A structure value: its type (empty when the text gives none) and its components by name,
// in the order given, values as text.
struct Structure {
  std::string type;
  std::vector<std::pair<std::string, std::string>> components;
  const std::string* Find(std::string_view component) const;
};
std::optional<Structure> ParseStructure(std::string_view text, std::string* why = nullptr);

// The robot axes A1 … An of an AXIS / E6AXIS value, degrees (n = 1 … 6). Refused: another
// structure type, a missing, repeated or non-numeric component.
std::optional<Eigen::VectorXd> ParseAxes(std::string_view text, int axes,
                                         std::string* why = nullptr);
// x, y, z (mm) and A, B, C (deg) of a FRAME / POS / E6POS value.
std::optional<Eigen::Matrix<double, 6, 1>> ParsePose(std::string_view text,
                                                     std::string* why = nullptr);

// A REAL as KRL shows it: at most 9 significant digits, at least one decimal ("-90.0",
// "1339.90503", "-1.52587891E-05").
std::string FormatReal(double value);
std::string FormatBool(bool value);
// {E6AXIS: A1 …, A6 …} with the given axes (deg) and nothing of E1 … E6: a partial
// aggregate, which leaves the other components as they are.
std::string FormatAxes(const Eigen::VectorXd& axes_deg, std::string_view type = "E6AXIS");
std::string FormatString(std::string_view text);  // in double quotes

// --- KRL declarations -------------------------------------------------------------------

// One `DECL [GLOBAL] [CONST] TYPE NAME[=value]` line of a data list (a CHAR array as
// `DECL CHAR NAME[16]`): its type, name and initial value text. Comments (';' to the end
// of the line) and folds are skipped; names and types are upper-cased (KRL ignores case).
struct Declaration {
  std::string type, name, value;
  int line = 0;
};
// Throws std::invalid_argument naming the line of a DECL that is not of that form.
std::vector<Declaration> ParseDeclarations(std::string_view text);

// --- The ARMSIG contract (controllers/kuka: ARMSIG.src, config_globals.dat) ----------

namespace contract {
inline constexpr int kVersion = 1;
inline constexpr char kCommand[] = "ARMSIG_CMD";
inline constexpr char kTarget[] = "ARMSIG_TARGET";
inline constexpr char kVelocity[] = "ARMSIG_VEL";
inline constexpr char kAcceleration[] = "ARMSIG_ACC";
inline constexpr char kBusy[] = "ARMSIG_BUSY";
inline constexpr char kDone[] = "ARMSIG_DONE";
inline constexpr char kResult[] = "ARMSIG_RESULT";
inline constexpr char kContractVersion[] = "ARMSIG_VERSION";
inline constexpr char kProgram[] = "ARMSIG";  // the .src module's name
// The program runner (controllers/kuka/ARMSIG_SPS.sub, in the submit interpreter).
inline constexpr char kRunName[] = "ARMSIG_RUN_NAME[]";
inline constexpr char kRunCommand[] = "ARMSIG_RUN_CMD";
inline constexpr char kRunBusy[] = "ARMSIG_RUN_BUSY";
inline constexpr char kRunDone[] = "ARMSIG_RUN_DONE";
inline constexpr char kRunResult[] = "ARMSIG_RUN_RESULT";
inline constexpr char kRunPhase[] = "ARMSIG_RUN_PHASE";

struct Global {
  const char* name;
  const char* type;  // as declared in $CONFIG.DAT
};
// Every global of the contract, in config_globals.dat's order.
inline constexpr Global kGlobals[] = {
    {kCommand, "INT"},       {kTarget, "E6AXIS"}, {kVelocity, "INT"}, {kAcceleration, "INT"},
    {kBusy, "INT"},          {kDone, "INT"},      {kResult, "INT"},   {kContractVersion, "INT"},
    {kRunName, "CHAR"},      {kRunCommand, "INT"}, {kRunBusy, "INT"},  {kRunDone, "INT"},
    {kRunResult, "INT"},     {kRunPhase, "INT"}};

// ARMSIG_RESULT values (ARMSIG.src).
enum Result : int {
  kReached = 0,
  kBeyondSoftwareLimit = 1,
  kVelocityOutOfRange = 2,
  kNotExecuted = 3,
};
inline constexpr int kResults[] = {kReached, kBeyondSoftwareLimit, kVelocityOutOfRange,
                                   kNotExecuted};
// What an ARMSIG_RESULT value means, in words ("result 7 (not one of ARMSIG's)" when unknown).
std::string ResultMeaning(int result);
// ARMSIG_RUN_RESULT values (ARMSIG_SPS.sub).
enum RunResult : int { kRunEnded = 0, kRunNotAutomatic = 1, kRunNotSelected = 2, kRunStopped = 3 };
}  // namespace contract

// --- KRL system variables armsig reads (KUKA "System Variables, KSS 8.1, 8.2, 8.3, 8.4",
// V2, 26.09.2016) ------------------------------------------------------------------------

namespace system_variable {
inline constexpr char kAxisAct[] = "$AXIS_ACT";      // E6AXIS, deg: where the axes are
inline constexpr char kPosAct[] = "$POS_ACT";        // E6POS: the TCP in $BASE, mm / deg
inline constexpr char kModeOp[] = "$MODE_OP";        // #T1 #T2 #AUT #EX
inline constexpr char kProState[] = "$PRO_STATE1";   // robot interpreter: #P_FREE #P_RESET
                                                     // #P_ACTIVE #P_STOP #P_END
inline constexpr char kProName[] = "$PRO_NAME1[]";   // the selected robot program
inline constexpr char kStopMess[] = "$STOPMESS";     // TRUE: a message that stops the robot
inline constexpr char kAlarmStop[] = "$ALARM_STOP";  // FALSE: an EMERGENCY STOP is active
inline constexpr char kUserSaf[] = "$USER_SAF";      // FALSE: operator safety (gate) open
inline constexpr char kPeriRdy[] = "$PERI_RDY";      // TRUE: drives on
inline constexpr char kRobStopped[] = "$ROB_STOPPED";  // TRUE: the robot stands still
inline constexpr char kRobName[] = "$ROBNAME[]";       // the robot's name, set by the user
inline constexpr char kSerialNo[] = "$KR_SERIALNO";    // INT: the robot's serial number
inline constexpr char kTrafoName[] = "$TRAFONAME[]";   // the kinematic model, "#KR16_2 C4 …"
inline constexpr char kSoftware[] = "$RCV_INFO[]";     // KUKA System Software version
}  // namespace system_variable

}  // namespace armsig::robots::kuka
