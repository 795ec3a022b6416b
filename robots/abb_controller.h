// An ABB robot controller, IRC5 (RobotWare 6, RWS 1.0) or OmniCore (RobotWare 7, RWS 2.0),
// through Robot Web Services (robots/rws_codec.h over robots/http_transport.h),
// running armsig's RAPID module controllers/abb/ArmsigServer.mod in its motion task.
//
// Why Robot Web Services: it is part of every RobotWare 6 and 7 system at no cost, over the
// controller's ordinary Ethernet port, and it reads the controller's identity, states and
// RAPID data with the user rights (UAS) the lab grants. Externally Guided Motion (EGM,
// option 689-1) and PC Interface (616-1) are paid options a lab may not have; a RAPID socket
// server (Socket Messaging: on RobotWare 6 part of the PC Interface option) would need its own
// protocol.
// RWS cannot command motion itself, so the module does: armsig writes a target and a request
// number into its persistent variables, the module moves there (MoveAbsJ, zone fine), waits
// for zero speed, records where the arm stands (CJointT) and the request number it finished.
//
// Contract (the module's PERS data; tests/instruments/abb_contract_test.cc parses the
// shipped module and checks these names and types):
//   armsig_version  num          1: the contract this driver speaks
//   armsig_target   jointtarget  written by armsig: where to go (degrees)
//   armsig_speed    num          written by armsig: velocity override, percent (VelSet)
//   armsig_cmd      num          written by armsig: the request number, one more each move
//   armsig_done     num          written by the module: the last request finished, the arm
//                                still (a restart from main sets it to armsig_cmd: a pending
//                                request is dropped, never carried out later by surprise)
//   armsig_error    num          written by the module: 0, or the error of request done
//   armsig_joints   dnum{6}      written by the module: the joints (degrees) where the arm
//                                stood still after request done (or when the program began)
//
// A reading is taken only while the arm stands still: the module has finished every request
// (armsig_done = armsig_cmd, read before and after), and the arm is still where the module
// recorded it (the mechanical unit's jointtarget within still_tolerance_deg of
// armsig_joints). The joints returned are the module's record, written as dnum (15
// significant digits): the precision of the jointtarget resource's text is not stated by
// the manual, so armsig never depends on it.
//
// The cell's states come as the framework's ControllerError (instruments/device.h), each
// naming the controller, what happened and what to do: a guard stop (the safety run chain
// opened: ABB's protective stop; the whole recovery — reset, motors on, program started —
// is one stop the session waits out), an emergency stop, manual mode or another client
// holding RAPID's write access (not in remote control), motors off or the program stopped
// (not running), the arm moving, a move the module refused, the connection lost. What the
// lab must set right comes as AbbFault: credentials refused, a certificate not trusted, the
// module missing. Credentials are never written to a log or a message.
#pragma once

#include <Eigen/Core>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "instruments/device.h"
#include "robots/http_auth.h"
#include "robots/http_transport.h"
#include "robots/rws_codec.h"

namespace armsig::robots {

namespace abb_contract {
inline constexpr int kVersion = 1;
struct Symbol {
  const char* name;
  const char* type;  // RAPID data type
  int elements;      // 0: a scalar; N: an array {N}
};
inline constexpr Symbol kContractVersion{"armsig_version", "num", 0};
inline constexpr Symbol kTarget{"armsig_target", "jointtarget", 0};
inline constexpr Symbol kSpeed{"armsig_speed", "num", 0};
inline constexpr Symbol kCommand{"armsig_cmd", "num", 0};
inline constexpr Symbol kDone{"armsig_done", "num", 0};
inline constexpr Symbol kError{"armsig_error", "num", 0};
inline constexpr Symbol kJoints{"armsig_joints", "dnum", 6};
inline constexpr Symbol kAll[] = {kContractVersion, kTarget, kSpeed, kCommand,
                                  kDone,            kError,  kJoints};
inline constexpr const char* kModule = "ArmsigServer";
// Request numbers wrap here (a num holds integers exactly up to 2^24).
inline constexpr int kMaxRequest = 1 << 23;
}  // namespace abb_contract

struct AbbSettings {
  rws::Version version = rws::Version::kRws2;
  // RWS 1.0: kXhtml (its default) or kJson1; RWS 2.0 always kHalJson.
  rws::Representation representation = rws::Representation::kHalJson;
  std::string user, password;
  // Where the credentials came from, for messages: "the credentials file abb.yaml".
  std::string credentials_source = "the credentials file";
  std::string task = "T_ROB1", module = abb_contract::kModule, mechunit = "ROB_1";
  bool can_move = false;
  double speed_percent = 20.0;  // VelSet override for armsig's moves, 1 … 100
  instruments::Millis poll_interval{20};     // while a move runs
  instruments::Millis move_timeout{120000};  // a move (and the wait for a pending one)
  double still_tolerance_deg = 0.05;
};

struct AbbIdentity {
  std::string model;   // the robot type: "IRB 4600-40/2.55"
  std::string serial;  // the manipulator's serial number: "4600-501234"
  std::string controller_name, controller_id, controller_type;
  std::string robotware;  // "6.15.03.00" (rwversionname, else rwversion)
  int contract_version = 0;
  instruments::DeviceInfo Info() const;  // name: model, serial, firmware: RobotWare
};

// What the lab must set right before armsig can work with the controller (not a state of
// the cell: those are ControllerError, instruments/device.h).
class AbbFault : public instruments::InstrumentError {
 public:
  enum class Kind {
    kCredentials,  // the login refused, or the user lacks a grant
    kCertificate,  // the TLS certificate not pinned or not verifiable
    kContract,     // the module is not loaded, or of another contract version
  };
  AbbFault(Kind kind, std::string device, const std::string& message)
      : instruments::InstrumentError(std::move(device), 0, message), kind_(kind) {}
  Kind kind() const { return kind_; }

 private:
  Kind kind_;
};

// The controller refused a request (HTTP 4xx/5xx): its HTTP status and RWS return code.
class RwsRefused : public instruments::InstrumentError {
 public:
  RwsRefused(std::string device, unsigned http_status, std::optional<rws::Status> status,
             const std::string& message)
      : instruments::InstrumentError(std::move(device), status ? static_cast<int>(status->code) : 0, message),
        http_status_(http_status),
        status_(std::move(status)) {}
  unsigned http_status() const { return http_status_; }
  const std::optional<rws::Status>& status() const { return status_; }

 private:
  unsigned http_status_;
  std::optional<rws::Status> status_;
};

class AbbController : public instruments::RobotController {
 public:
  AbbController(AbbSettings settings, std::unique_ptr<HttpTransport> transport,
                instruments::RetryPolicy policy = {});
  ~AbbController() override;  // logs out (RWS 1.0 allows a few dozen sessions at once)
  AbbController(const AbbController&) = delete;
  AbbController& operator=(const AbbController&) = delete;

  const std::string& name() const override { return name_; }
  // Who the controller says it is, and the module's contract version (AbbFault kContract
  // when the module is missing or speaks another version).
  AbbIdentity Details();
  // The framework's form of it: vendor ABB, the robot type, the arm's serial number,
  // RobotWare.
  std::optional<instruments::ControllerIdentity> Identify() override;

  Eigen::VectorXd ReadJointsRad() override;
  bool CanMove() const override { return settings_.can_move; }
  void MoveTo(const Eigen::VectorXd& joints_rad) override;
  void SetInterrupt(const std::atomic<bool>* flag) override { transport_->SetInterrupt(flag); }
  // Not a stream, but the session's read after the instruments is what a calibration needs
  // here too: that second reading's still-check (the arm where the module recorded it)
  // refuses a configuration whose arm something moved while the instruments measured.
  bool StreamsJoints() const override { return true; }

  struct State {
    rws::ControllerState controller;
    rws::OperationMode mode;
    rws::ExecutionState execution;
  };
  State ReadState();
  // Throws the ControllerError of the state unless the controller runs the module in AUTO
  // with the motors on: what a move needs.
  void CheckReady() override;

  // A RAPID program run as a lab runs one (instruments/abb_programs.cc; docs/how-to/
  // compensate-programs.md): the module's text uploaded to $HOME/`file_name`, loaded into the
  // task (replacing a module of its name), the program pointer set to `routine` of `module`
  // (RAPID mastership held meanwhile; RAPID stopped first when it runs), then execution
  // started once from there. A module the
  // controller does not load comes as RwsRefused naming the file and the controller's
  // message; mastership held elsewhere, manual mode, motors off or a stop of the cell as
  // ControllerError.
  void LoadProgram(const std::string& file_name, const std::string& text, const std::string& module,
                   const std::string& routine);
  void StartProgram(const std::string& module);
  // Whether RAPID still executes; a stop of the cell meanwhile as ControllerError.
  bool ProgramRunning();
  // The program pointer back to main and the module unloaded; main started again when
  // LoadProgram stopped it.
  void UnloadProgram(const std::string& module);
  // The mechanical unit's joints as the jointtarget resource states them (degrees, to its
  // precision: not a reading for a calibration, which ReadJointsRad is).
  Eigen::VectorXd ReadJointTargetDeg();

  int exchanges() const { return exchanges_; }  // HTTP exchanges so far
  const AbbSettings& settings() const { return settings_; }

 private:
  rws::Document Call(const rws::Request& request, instruments::Deadline deadline);
  rws::Document Attempt(const rws::Request& request, instruments::Deadline deadline);
  void Authenticate(const HttpResponse& refused, const std::string& method,
                    const std::string& uri);
  std::string ReadSymbol(const abb_contract::Symbol& symbol, instruments::Deadline deadline);
  double ReadNum(const abb_contract::Symbol& symbol, instruments::Deadline deadline);
  void WriteSymbols(const std::vector<std::pair<abb_contract::Symbol, std::string>>& values,
                    instruments::Deadline deadline);
  void EnsureContract(instruments::Deadline deadline);
  State ReadStateBy(instruments::Deadline deadline);
  [[noreturn]] void ThrowForState(const State& state, const std::string& during);
  [[noreturn]] void ThrowLost(const std::string& why) const;
  bool Ready(const State& state) const;
  void WaitDone(int request, instruments::Deadline deadline);
  rws::SymbolPath PathOf(const abb_contract::Symbol& symbol) const;
  // RAPID mastership for the calls of `during`, released when the returned guard ends;
  // ControllerError kNotRemote when another client holds it.
  std::shared_ptr<void> HoldMastership(const std::string& during, instruments::Deadline deadline);

  AbbSettings settings_;
  std::unique_ptr<HttpTransport> transport_;
  instruments::RetryPolicy policy_;
  std::string name_;
  std::vector<http::Cookie> cookies_;
  std::string authorization_;  // for the next request, from the last challenge
  unsigned nonce_count_ = 0;
  std::optional<AbbIdentity> identity_;
  // A guard or emergency stop was reported and the controller has not been ready since: its
  // recovery (reset, motors on, program started) is still that stop.
  std::optional<instruments::ControllerError::Kind> recovering_;
  int exchanges_ = 0;
  bool resume_main_ = false;  // LoadProgram stopped armsig's module's main: UnloadProgram restarts it
};

}  // namespace armsig::robots
