// ABB Robot Web Services (RWS), the controller's REST interface, as pure functions: the
// requests armsig sends and the replies it reads, in both generations and all three of
// their representations. No I/O; table-driven tests in tests/instruments/rws_codec_test.cc.
//
// Followed: ABB, "Application Manual - Robot Web Services", 3HAC050973-001 Revision M (RWS
// 1.0, RobotWare 6, IRC5; developercenter.robotstudio.com/api/rwsApi), and ABB's OmniCore App
// SDK 1.5.0 RWS client library (omnicore-rws.js, © ABB 2020-2024, the RobotWare 7 resource
// paths and media types of RWS 2.0) where the RWS 2.0 manual is not public. Why RWS and not
// EGM or a socket program: docs/how-to/abb.md.
//
// The generations differ in:
//                      RWS 1.0 (IRC5, RobotWare 6)      RWS 2.0 (OmniCore, RobotWare 7)
//   transport          HTTP, port 80                     HTTPS (TLS), port 443
//   authentication     Digest (MD5, qop=auth)            Basic (inside TLS)
//   representation     XHTML (default) or ?json=1       application/hal+json;v=2.0
//   form bodies        application/x-www-form-urlencoded the same with ";v=2.0"
//   controller state   /rw/panel/ctrlstate               /rw/panel/ctrl-state
//   symbol value       /rw/rapid/symbol/data/RAPID/T/M/S /rw/rapid/symbol/RAPID/T/M/S/data
//   symbol write       POST …?action=set  value=…        POST …/data  value=…
//   mastership         POST /rw/mastership/rapid?action=request   /rw/mastership/edit/request
//   execution          POST /rw/rapid/execution?action=start|stop  …/execution/start|stop
// and share: /ctrl/identity (ctrl-identity-info: ctrl-name, ctrl-type, ctrl-id), /rw/system
// (sys-system-li: rwversion, rwversionname, sysid), /rw/system/robottype (sys-robottype:
// robot-type), /rw/cfg/moc/ROBOT_SERIAL_NUMBER/instances (the manipulator's serial number,
// robot_serial_number_high_part and _low_part), /rw/panel/opmode (pnl-opmode: AUTO, MANR …),
// /rw/rapid/execution (rap-execution: ctrlexecstate running | stopped) and
// /rw/motionsystem/mechunits/{unit}/jointtarget (ms-jointtarget: rax_1 … rax_6, degrees), the
// same session cookies and the same error status (code and msg).
//
// Every reply is read into one Document (resources with their type, title, text fields and
// nested resources, and the error status) whatever its representation, so the typed
// decoders below serve all three. A body that is not what RWS sends throws DecodeError, the
// only exception the decoders throw.
#pragma once

#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace armsig::robots::rws {

enum class Version { kRws1, kRws2 };
const char* VersionName(Version version);  // "RWS 1.0", "RWS 2.0"

enum class Representation {
  kXhtml,    // RWS 1.0's default: XHTML with <li class=TYPE title=TITLE><span class=NAME>
  kJson1,    // RWS 1.0 with ?json=1: {"_embedded": {"_state": [ {"_type": …} ]}}
  kHalJson,  // RWS 2.0: application/hal+json;v=2.0, {"state": [ {"_type": …} ]}
};

class DecodeError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// The largest reply body and the deepest nesting a decoder reads (an RWS reply is a few
// kilobytes and nests five elements deep).
inline constexpr size_t kMaxBodyBytes = 1 << 20;
inline constexpr int kMaxDepth = 48;

struct Resource {
  std::string type;   // XHTML: the li's class; JSON: "_type"
  std::string title;  // XHTML: the li's title; JSON: "_title"
  std::vector<std::pair<std::string, std::string>> fields;  // span class / member → text
  std::vector<Resource> children;                           // nested li / arrays of objects
  const std::string* Field(std::string_view name) const;
};

// The controller's return code and message of a refused request (HTTP 4xx/5xx with
// <div class="status"> or "status": {"code", "msg"}).
struct Status {
  int64_t code = 0;
  std::string message;
};

struct Document {
  std::vector<Resource> resources;
  std::optional<Status> status;
  // The first resource of that type, depth first (children included); nullptr if none.
  const Resource* Find(std::string_view type) const;
};

Document ParseXhtml(std::string_view body);
Document ParseJson(std::string_view body);  // RWS 1.0 ?json=1 and RWS 2.0 hal+json
// By media type: JSON for "application/json" and "application/hal+json", else XHTML.
Document Parse(std::string_view body, std::string_view content_type);

// Writing a Document as a controller does (the virtual controller): `service` is the
// page's title (panel, rapid, system, ctrl, motionsystem, cfg), `base` the base href.
std::string FormatXhtml(const Document& document, std::string_view service,
                        std::string_view base);
std::string FormatJson1(const Document& document, std::string_view base);
std::string FormatHalJson(const Document& document, std::string_view base);
std::string Format(const Document& document, Representation representation,
                   std::string_view service, std::string_view base);
const char* MediaType(Representation representation);

// Return codes seen on RobotWare 6.16 and 7.21 (the same code space in both generations).
namespace code {
inline constexpr int64_t kHeldBySomeoneElse = -1073445862;  // mastership held by another
inline constexpr int64_t kNoMastership = -1073445859;       // the user has no mastership
inline constexpr int64_t kRejected = -1073445881;           // UAS grant / RMMP missing
inline constexpr int64_t kNotFound = -1073414146;           // resource or symbol not found
inline constexpr int64_t kSymbolNotFound = -1073442816;     // RWS 2.0 symbol GET
inline constexpr int64_t kWrongState = -1073442809;         // execution start refused
// A module that did not load (syntax or semantic errors, a name already in the task): the code
// armsig's virtual controller gives; the public manual's list was not checked for RobotWare's
// own, so armsig's messages name the module and the controller's message, never the code alone.
inline constexpr int64_t kModuleNotLoaded = -1073442796;
}  // namespace code

// ---- Controller state, operation mode, RAPID execution ----

enum class ControllerState {
  kInit,
  kMotorsOn,
  kMotorsOff,
  kGuardStop,           // the safety run chain is open (a cell door, a light curtain)
  kEmergencyStop,       // an emergency stop button is pressed
  kEmergencyStopReset,  // released, not yet confirmed
  kSystemFailure,       // restart needed
};
const char* Text(ControllerState state);  // "motoron" …
std::optional<ControllerState> ControllerStateFromText(std::string_view text);

enum class OperationMode { kInit, kAutoChange, kManualFullChange, kManualReduced, kManualFull,
                           kAuto, kUndefined };
const char* Text(OperationMode mode);  // "AUTO", "MANR" …
std::optional<OperationMode> OperationModeFromText(std::string_view text);

enum class ExecutionState { kRunning, kStopped };
const char* Text(ExecutionState state);
std::optional<ExecutionState> ExecutionStateFromText(std::string_view text);

ControllerState DecodeControllerState(const Document& document);  // pnl-ctrlstate
OperationMode DecodeOperationMode(const Document& document);      // pnl-opmode
ExecutionState DecodeExecutionState(const Document& document);   // rap-execution

// ---- Identity ----

struct Identity {
  std::string name, type, id;  // ctrl-name, ctrl-type ("Real Controller"), ctrl-id
};
Identity DecodeIdentity(const Document& document);
struct SystemInfo {
  std::string name, rwversion, rwversionname, sysid;
};
SystemInfo DecodeSystemInfo(const Document& document);
std::vector<std::string> DecodeRobotTypes(const Document& document);  // "IRB 4600-40/2.55"
// The manipulator's serial number, "HIGH-LOW" from ROBOT_SERIAL_NUMBER instance `instance`.
std::string DecodeRobotSerial(const Document& document, std::string_view instance = "rob_1");

// ---- Motion and RAPID data ----

// rax_1 … rax_6 of ms-jointtarget, degrees, as the controller wrote them.
Eigen::VectorXd DecodeJointTargetDeg(const Document& document);
// The value text of a rap-data resource (a RAPID literal).
std::string DecodeSymbolValue(const Document& document);

// RAPID literals (RAPID Reference Manual: num, dnum, arrays, jointtarget). A num is written
// with 9 significant digits, enough to give back the controller's float exactly.
double ParseRapidNum(std::string_view text);
std::string FormatRapidNum(double value);
std::vector<double> ParseRapidArray(std::string_view text);  // "[1,2.5,-3E+02]"
std::string FormatRapidArray(const std::vector<double>& values, int significant_digits = 15);
struct JointTarget {
  std::array<double, 6> robax_deg{};
  std::array<double, 6> extax{9e9, 9e9, 9e9, 9e9, 9e9, 9e9};  // 9E+09: no external axis
};
JointTarget ParseRapidJointTarget(std::string_view text);  // [[j1,…,j6],[e1,…,e6]]
std::string FormatRapidJointTarget(const JointTarget& target);

// ---- Requests ----

struct Request {
  std::string method;  // GET, POST or PUT
  std::string target;  // path and query, without the representation's parameter
  std::string body;    // form-encoded, empty for GET; a file's bytes for PUT
  std::string content_type;  // PUT: the file's media type (a POST's is the form's)
};
struct SymbolPath {
  std::string task, module, name;  // T_ROB1, ArmsigServer, armsig_cmd
};

Request GetIdentity(Version version);
Request GetSystem(Version version);
Request GetRobotType(Version version);
Request GetRobotSerial(Version version);
Request GetControllerState(Version version);
Request GetOperationMode(Version version);
Request GetExecution(Version version);
Request GetJointTarget(Version version, std::string_view mechunit);
Request GetSymbol(Version version, const SymbolPath& symbol);
Request SetSymbol(Version version, const SymbolPath& symbol, std::string_view value);
Request RequestMastership(Version version);
Request ReleaseMastership(Version version);
// Continue where the program pointer is, cycle `cycle` (forever, once, asis), no breakpoints.
Request StartExecution(Version version, std::string_view cycle = "forever");
// Programs (Application Manual - Robot Web Services: "Upload a file", "Load module into a
// rapid task", "Unload module", "Set the Program pointer position to routine", "Reset RAPID
// program pointer to main"; RWS 2.0 as simulation/rws_programs.h says). `path` is the
// controller's, "$HOME/NAME.mod"; a PUT's body is the file as it is (text/plain).
Request UploadFile(Version version, std::string_view path, std::string text);
Request LoadModule(Version version, std::string_view task, std::string_view path, bool replace);
Request UnloadModule(Version version, std::string_view task, std::string_view module);
Request SetProgramPointer(Version version, std::string_view task, std::string_view module,
                          std::string_view routine);
Request ResetProgramPointer(Version version);
Request StopExecution(Version version);
Request Logout(Version version);

// The request target with the representation's query parameter (RWS 1.0 JSON: json=1).
std::string TargetFor(const Request& request, Version version, Representation representation);
// The Accept value for a representation; the Content-Type of a form body.
const char* AcceptHeader(Representation representation);
const char* FormContentType(Version version);

// application/x-www-form-urlencoded (RFC 3986 unreserved characters kept, the rest %XX).
std::string FormEncode(std::string_view text);
// Decodes %XX and '+'; nullopt for a malformed escape.
std::optional<std::string> FormDecode(std::string_view text);
// name=value pairs of a form body or query; throws DecodeError for a malformed escape.
std::vector<std::pair<std::string, std::string>> ParseForm(std::string_view body);

}  // namespace armsig::robots::rws
