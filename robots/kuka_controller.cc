#include "robots/kuka_controller.h"

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <limits>
#include <numbers>

#include "instruments/line_retry.h"

namespace armsig::robots {
using instruments::CheckJoints;
namespace geocom = instruments::geocom;
using instruments::Clock;
using instruments::ControllerError;
using instruments::ControllerIdentity;
using instruments::Deadline;
using instruments::InstrumentError;
using instruments::Millis;
using instruments::PacketTransport;
using instruments::RetryPolicy;
using instruments::TransportError;

namespace sv = kuka::system_variable;
namespace contract = kuka::contract;

namespace {

constexpr double kDegPerRad = 180.0 / std::numbers::pi;
// A target read back from the controller is the one armsig sent when it agrees within this
// (the controller keeps REALs as 32-bit floats: 2e-5° at 350°).
constexpr double kSameTargetDeg = 1e-3;

bool IsContractVariable(const std::string& variable) {
  return variable.rfind("ARMSIG_", 0) == 0;
}

std::string Seconds(Millis ms) { return fmt::format("{:.1f} s", ms.count() / 1000.0); }

std::string AxesText(const Eigen::VectorXd& q_deg) {
  std::string out;
  for (Eigen::Index i = 0; i < q_deg.size(); ++i)
    out += fmt::format("{}A{} {:.3f}", i ? ", " : "", i + 1, q_deg(i));
  return out;
}

}  // namespace

bool KukaState::ProgramIsArmsig() const {
  // "/R1/ARMSIG.src", "ARMSIG", "KRC:\R1\ARMSIG.SRC": the module name, any case.
  std::string base = program_name.substr(program_name.find_last_of("/\\") + 1);
  base = base.substr(0, base.find('.'));
  std::transform(base.begin(), base.end(), base.begin(),
                 [](unsigned char c) { return static_cast<char>(std::toupper(c)); });
  return base == contract::kProgram;
}

std::string KukaArmOf(const std::string& trafo_name) {
  std::string arm = trafo_name.substr(0, trafo_name.find_first_of(" \t"));
  if (!arm.empty() && arm.front() == '#') arm.erase(0, 1);
  return arm;
}

ControllerError KukaController::Error(ControllerError::Kind kind, const std::string& what,
                                      const std::string& action) const {
  return ControllerError(kind, name_, what, action);
}

KukaController::KukaController(std::unique_ptr<PacketTransport> transport, bool can_move,
                               RetryPolicy policy, KukaOptions options)
    : transport_(std::move(transport)),
      can_move_(can_move),
      policy_(policy),
      options_(options),
      name_("KUKA controller " + transport_->name()) {
  if (options_.axes < 1 || options_.axes > 6)
    throw std::invalid_argument("a KUKA robot has 1 to 6 axes, not " + std::to_string(options_.axes));
}

// --- Variable exchanges ----------------------------------------------------------------

kuka::Response KukaController::ExchangeOnce(const kuka::Request& request, Deadline deadline) {
  transport_->Write(kuka::EncodeRequest(request), deadline);
  for (;;) {
    const std::string frame = transport_->ReadPacket(deadline);
    const auto decoded = kuka::DecodeResponse(frame);
    if (!decoded.response) {
      throw TransportError(TransportError::Kind::kBadFrame, transport_->name(),
                           "an answer to " + request.name + " that is no variable server message (" +
                               decoded.why + ")");
    }
    if (decoded.response->tag != request.tag) {
      ++stats_.stale_answers;  // the late answer of an earlier attempt
      continue;
    }
    if (decoded.response->type != static_cast<uint8_t>(request.type)) {
      throw TransportError(TransportError::Kind::kBadFrame, transport_->name(),
                           fmt::format("an answer of type {} to a {} of {}", decoded.response->type,
                                       request.type == kuka::MessageType::kRead ? "read" : "write",
                                       request.name));
    }
    return *decoded.response;
  }
}

kuka::Response KukaController::Exchange(kuka::MessageType type, const std::string& variable,
                                        const std::string& value, Deadline deadline) {
  instruments::Attempts a(policy_, deadline);
  for (; a.Left(); a.Next()) {
    const Deadline until = a.Until();
    try {
      if (!transport_->IsOpen()) {
        if (stats_.exchanges > 0 || a.made() > 0) ++stats_.reconnects;
        transport_->Open();
      }
      kuka::Request request{next_tag_, type, variable, value};
      next_tag_ = static_cast<uint16_t>(next_tag_ == 0xFFFF ? 1 : next_tag_ + 1);
      auto response = ExchangeOnce(request, until);
      ++stats_.exchanges;
      stats_.retries += a.made();
      return response;
    } catch (const TransportError& e) {
      if (e.kind() == TransportError::Kind::kInterrupted) throw;
      a.Failed(e);
      spdlog::debug("{}: {} attempt {} of {} failed: {}", name_, variable, a.made() + 1,
                    policy_.attempts, a.last());
      if (e.kind() == TransportError::Kind::kBadFrame) ++stats_.bad_frames;
      // A late answer is told by its tag: a timeout keeps the connection. A lost
      // connection or a stream out of frame is opened again.
      if (e.kind() != TransportError::Kind::kTimeout) {
        transport_->Close();
        transport_->Pause(policy_.reconnect_delay, deadline);
      }
    }
  }
  throw Error(ControllerError::Kind::kConnectionLost,
              fmt::format("the variable server did not answer for {} ({}: {})", variable,
                          geocom::CodeName(a.code()), a.GaveUp()),
              "check that the controller is on, that its variable server (KukaVarProxy or C3 "
              "Bridge) runs and listens on TCP " +
                  std::to_string(kuka::kDefaultPort) +
                  ", and the cell network; the session resumes where it stopped");
}

std::string KukaController::ReadBy(const std::string& variable, Deadline deadline) {
  const kuka::Response r = Exchange(kuka::MessageType::kRead, variable, "", deadline);
  if (r.success && !r.value.empty()) return r.value;
  if (IsContractVariable(variable)) {
    throw Error(ControllerError::Kind::kVersionRefused,
                variable + " cannot be read (" + (r.success ? "empty" : "refused") +
                    "): ARMSIG's variables are not declared on the controller",
                "add controllers/kuka/config_globals.dat to $CONFIG.DAT's USER GLOBALS and load "
                "ARMSIG.src (docs/how-to/kuka.md)");
  }
  throw InstrumentError(name_, 1,
                        variable + " cannot be read (" + (r.success ? "an empty value" : "refused") +
                            "): a KUKA System Software 8 variable armsig needs; is this a KR C4 or "
                            "KR C5 with KukaVarProxy or C3 Bridge on TCP 7000?");
}

void KukaController::WriteBy(const std::string& variable, const std::string& value,
                             Deadline deadline) {
  const kuka::Response r = Exchange(kuka::MessageType::kWrite, variable, value, deadline);
  if (r.success) return;
  if (IsContractVariable(variable)) {
    throw Error(ControllerError::Kind::kVersionRefused,
                variable + " = " + value.substr(0, 80) + " was refused",
                "declare it in $CONFIG.DAT as controllers/kuka/config_globals.dat does");
  }
  throw InstrumentError(name_, 1, variable + " = " + value.substr(0, 80) + " was refused");
}

std::string KukaController::Read(const std::string& variable) {
  return ReadBy(variable, CallDeadline());
}

void KukaController::Write(const std::string& variable, const std::string& value) {
  WriteBy(variable, value, CallDeadline());
}

int64_t KukaController::ReadInt(const std::string& variable, Deadline deadline) {
  const std::string text = ReadBy(variable, deadline);
  const auto v = kuka::ParseInt(text);
  if (!v) {
    throw InstrumentError(name_, 3074,
                          variable + " is '" + text.substr(0, 40) + "', not an INT");
  }
  return *v;
}

bool KukaController::ReadBool(const std::string& variable, Deadline deadline) {
  const std::string text = ReadBy(variable, deadline);
  const auto v = kuka::ParseBool(text);
  if (!v) {
    throw InstrumentError(name_, 3074,
                          variable + " is '" + text.substr(0, 40) + "', not TRUE or FALSE");
  }
  return *v;
}

// --- State and identity ---------------------------------------------------------------

KukaState KukaController::StateBy(Deadline deadline) {
  auto enumeration = [&](const char* variable) {
    const std::string text = ReadBy(variable, deadline);
    const auto v = kuka::ParseEnum(text);
    if (!v) {
      throw InstrumentError(name_, 3074,
                            std::string(variable) + " is '" + text.substr(0, 40) + "', no #VALUE");
    }
    return *v;
  };
  KukaState s;
  s.mode = enumeration(sv::kModeOp);
  s.program_state = enumeration(sv::kProState);
  s.program_name = kuka::ParseString(ReadBy(sv::kProName, deadline)).value_or("");
  s.emergency_stop = !ReadBool(sv::kAlarmStop, deadline);
  s.stop_message = ReadBool(sv::kStopMess, deadline);
  s.operator_safety = ReadBool(sv::kUserSaf, deadline);
  s.drives_on = ReadBool(sv::kPeriRdy, deadline);
  s.robot_stopped = ReadBool(sv::kRobStopped, deadline);
  s.contract_version = static_cast<int>(ReadInt(contract::kContractVersion, deadline));
  return s;
}

KukaState KukaController::State() { return StateBy(CallDeadline()); }

std::optional<ControllerError> KukaController::NotReady(const KukaState& s,
                                                       const std::string& during) const {
  using Kind = ControllerError::Kind;
  auto error = [&](Kind kind, const std::string& what, const std::string& action) {
    return Error(kind, during.empty() ? what : during + ": " + what, action);
  };
  if (s.emergency_stop) {
    return error(Kind::kEmergencyStop, "EMERGENCY STOP is pressed ($ALARM_STOP FALSE)",
                 "release it, acknowledge the messages on the smartPAD, switch the drives on "
                 "and start ARMSIG again; the session resumes where it stopped");
  }
  if (s.stop_message) {
    return error(Kind::kProtectiveStop,
                 s.operator_safety
                     ? "a stopping message is active ($STOPMESS TRUE)"
                     : "a safety stop: operator safety is open, the cell's gate ($STOPMESS "
                       "TRUE, $USER_SAF FALSE)",
                 std::string(s.operator_safety ? "clear its cause" : "close the gate") +
                     ", acknowledge the message on the smartPAD and start ARMSIG again (the "
                     "Start key in AUT, $EXT_START in EXT); the session goes on by itself");
  }
  if (!s.Automatic()) {
    return error(Kind::kNotRemote,
                 "the controller is in " + s.mode + ": armsig moves the robot only in AUT or EXT",
                 "turn the smartPAD's mode switch to AUT (or EXT) and start ARMSIG, or capture "
                 "with can_move: false and move the robot by hand");
  }
  if (!s.drives_on) {
    return error(Kind::kNotRunning, "the drives are off ($PERI_RDY FALSE)",
                 "switch the drives on (the smartPAD's drives key in AUT, $DRIVES_ON from the "
                 "cell's PLC in EXT) and start ARMSIG again; the session resumes where it stopped");
  }
  if (s.program_state == "P_STOP" && s.ProgramIsArmsig()) {
    return error(Kind::kProtectiveStop, "ARMSIG is stopped ($PRO_STATE1 #P_STOP)",
                 "start it again (the Start key in AUT, $EXT_START in EXT); the session goes on "
                 "by itself");
  }
  if (s.program_state != "P_ACTIVE") {
    const std::string which = s.program_name.empty() ? "no program" : s.program_name;
    return error(Kind::kNotRunning,
                 "the robot program is not running ($PRO_STATE1 #" + s.program_state +
                     ", selected: " + which + ")",
                 "select ARMSIG and start it (the Start key in AUT, $EXT_START from the cell's "
                 "PLC in EXT)");
  }
  if (s.contract_version != contract::kVersion) {
    return error(Kind::kVersionRefused,
                 fmt::format("ARMSIG_VERSION is {}; armsig speaks contract {}",
                             s.contract_version, contract::kVersion),
                 "install the controllers/kuka files of this armsig on the controller and "
                 "start ARMSIG");
  }
  return std::nullopt;
}

void KukaController::CheckReady() {
  if (auto e = NotReady(State())) throw *e;
}

void KukaController::ThrowStopped(Deadline deadline, const char* during) {
  if (auto e = NotReady(StateBy(deadline), during)) throw *e;
  throw Error(ControllerError::Kind::kNotRunning, std::string(during) + ": the robot program stopped",
              "start ARMSIG again");
}

std::optional<ControllerIdentity> KukaController::Identify() {
  const Deadline deadline = CallDeadline();
  auto text = [&](const char* variable) {
    const std::string raw = ReadBy(variable, deadline);
    return kuka::ParseString(raw).value_or(raw);
  };
  ControllerIdentity id;
  id.protocol = "kuka";
  id.vendor = "KUKA";
  id.model = KukaArmOf(text(sv::kTrafoName));
  id.serial = std::to_string(ReadInt(sv::kSerialNo, deadline));
  id.software = text(sv::kSoftware);
  return id;
}

Eigen::Matrix<double, 6, 1> KukaController::ReadPoseAct() {
  const std::string text = ReadBy(sv::kPosAct, CallDeadline());
  std::string why;
  const auto pose = kuka::ParsePose(text, &why);
  if (!pose) throw InstrumentError(name_, 3074, std::string(sv::kPosAct) + ": " + why);
  return *pose;
}

// --- Joints -------------------------------------------------------------------------------

Eigen::VectorXd KukaController::ReadJointsRad() {
  const Deadline deadline = CallDeadline();
  auto still = [&](const char* when) {
    if (ReadBool(sv::kRobStopped, deadline)) return;
    throw Error(ControllerError::Kind::kArmMoving,
                std::string("the arm is moving ($ROB_STOPPED FALSE ") + when +
                    " reading $AXIS_ACT): joints read now are not where the instruments "
                    "measure, so none are taken",
                "wait until it stands");
  };
  still("before");
  const std::string text = ReadBy(sv::kAxisAct, deadline);
  std::string why;
  const auto q_deg = kuka::ParseAxes(text, options_.axes, &why);
  if (!q_deg) throw InstrumentError(name_, 3074, std::string(sv::kAxisAct) + ": " + why);
  still("after");
  const Eigen::VectorXd q = *q_deg / kDegPerRad;
  CheckJoints(name_, q);
  return q;
}

// --- Moves --------------------------------------------------------------------------------

int KukaController::WaitFor(int64_t n, Deadline move_deadline) {
  const auto sent = Clock::now();
  bool taken = false;
  for (;;) {
    ++stats_.move_polls;
    const Deadline call = std::min(move_deadline, CallDeadline());
    if (ReadInt(contract::kDone, call) == n)
      return static_cast<int>(ReadInt(contract::kResult, call));
    if (!taken) taken = ReadInt(contract::kBusy, call) == n;
    if (ReadBool(sv::kStopMess, call)) {
      ThrowStopped(call, taken ? "the move stopped" : "before the move");
    }
    const std::string text = ReadBy(sv::kProState, call);
    if (kuka::ParseEnum(text).value_or("") != "P_ACTIVE") {
      ThrowStopped(call, taken ? "the move stopped" : "before the move");
    }
    if (!taken && Clock::now() - sent > options_.accept_timeout) {
      const KukaState s = StateBy(call);
      const std::string which = s.program_name.empty() ? "no program" : s.program_name;
      throw Error(ControllerError::Kind::kNotRunning,
                  fmt::format("{} = {} was not taken within {} (the running program is {}{})",
                              contract::kCommand, n, Seconds(options_.accept_timeout), which,
                              s.ProgramIsArmsig() ? ", stuck" : ", not ARMSIG"),
                  s.ProgramIsArmsig()
                      ? "reset ARMSIG and start it again"
                      : "select ARMSIG (or call it from CELL.SRC in EXT) and start it");
    }
    if (Clock::now() >= move_deadline) {
      throw Error(ControllerError::Kind::kMoveRefused,
                  fmt::format("move {} not done within {}", n, Seconds(options_.move_timeout)),
                  "look at the robot and the smartPAD (a very low override $OV_PRO?)");
    }
    transport_->Pause(options_.poll, move_deadline);
  }
}

void KukaController::MoveTo(const Eigen::VectorXd& joints_rad) {
  if (!can_move_) {
    throw InstrumentError(name_, 5,
                          "this controller is not commanded by armsig (the lab file says "
                          "can_move: false)");
  }
  if (joints_rad.size() != options_.axes) {
    throw std::invalid_argument(fmt::format("{}: {} joint values for a robot of {} axes", name_,
                                            joints_rad.size(), options_.axes));
  }
  const Eigen::VectorXd q_deg = joints_rad * kDegPerRad;
  const Deadline move_deadline = Clock::now() + options_.move_timeout;
  Deadline deadline = CallDeadline();
  if (auto e = NotReady(StateBy(deadline))) throw *e;

  int64_t cmd = ReadInt(contract::kCommand, deadline);
  int64_t done = ReadInt(contract::kDone, deadline);
  if (cmd != done) {
    // A command still open: a session resumed after a stop or a lost connection. The same
    // target is waited for; another one is let finish first.
    std::string why;
    const auto pending = kuka::ParseAxes(ReadBy(contract::kTarget, deadline), options_.axes, &why);
    const bool same = pending && ((*pending - q_deg).cwiseAbs().maxCoeff() < kSameTargetDeg);
    spdlog::info("{}: command {} is still open ({}); {}", name_, cmd,
                 pending ? AxesText(*pending) : why,
                 same ? "waiting for it" : "letting it finish first");
    const int result = WaitFor(cmd, move_deadline);
    if (same && result == contract::kReached) {
      ++stats_.resumed_moves;
      return;
    }
    done = cmd;
    deadline = CallDeadline();
  }

  for (int sends = 0;; ++sends) {
    int64_t n = std::max(cmd, done) + 1;
    if (n > std::numeric_limits<int32_t>::max()) n = 1;  // KRL INT is 32 bits
    WriteBy(contract::kTarget, kuka::FormatAxes(q_deg), deadline);
    WriteBy(contract::kVelocity, std::to_string(options_.velocity_percent), deadline);
    WriteBy(contract::kAcceleration, std::to_string(options_.acceleration_percent), deadline);
    WriteBy(contract::kCommand, std::to_string(n), deadline);
    ++stats_.moves;
    const int result = WaitFor(n, move_deadline);
    if (result == contract::kReached) return;
    if (result == contract::kNotExecuted && sends == 0) {
      ++stats_.resent_moves;
      cmd = done = n;
      deadline = CallDeadline();
      continue;
    }
    throw Error(ControllerError::Kind::kMoveRefused,
                fmt::format("ARMSIG did not move to {}: {}", AxesText(q_deg),
                            contract::ResultMeaning(result)),
                result == contract::kBeyondSoftwareLimit
                    ? "correct the plan (the model file's joint_limits_deg) or the controller's "
                      "software limits"
                    : "look at ARMSIG on the controller");
  }
}

}  // namespace armsig::robots
