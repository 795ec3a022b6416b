#include "robots/abb_controller.h"

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <cmath>
#include <numbers>
#include <random>

#include "core/text.h"
#include "instruments/line_retry.h"

namespace armsig::robots {
using instruments::CheckJoints;
using instruments::Clock;
using instruments::ControllerError;
using instruments::ControllerIdentity;
using instruments::Deadline;
using instruments::DeviceInfo;
using instruments::InstrumentError;
using instruments::Millis;
using instruments::RetryPolicy;
using instruments::TransportError;

namespace {

using Kind = ControllerError::Kind;
constexpr double kDegPerRad = 180.0 / std::numbers::pi;

std::string Cnonce() {
  static thread_local std::mt19937_64 rng{std::random_device{}()};
  return fmt::format("{:016x}", rng());
}

std::string ModeWords(rws::OperationMode mode) {
  switch (mode) {
    case rws::OperationMode::kManualReduced:
      return "MANR (manual, reduced speed)";
    case rws::OperationMode::kManualFull:
      return "MANF (manual, full speed)";
    case rws::OperationMode::kAutoChange:
    case rws::OperationMode::kManualFullChange:
      return std::string(rws::Text(mode)) + " (a mode change waiting for confirmation)";
    default:
      return rws::Text(mode);
  }
}

bool SchemeIs(const http::Challenge& c, std::string_view lower) {
  if (c.scheme.size() != lower.size()) return false;
  for (size_t i = 0; i < lower.size(); ++i) {
    if (std::tolower(static_cast<unsigned char>(c.scheme[i])) != lower[i]) return false;
  }
  return true;
}

bool IsNotFound(const RwsRefused& e) {
  const auto& s = e.status();
  return e.http_status() == 404 ||
         (s && (s->code == rws::code::kNotFound || s->code == rws::code::kSymbolNotFound));
}

}  // namespace

DeviceInfo AbbIdentity::Info() const {
  return DeviceInfo{"ABB " + model + (controller_name.empty() ? "" : " '" + controller_name + "'"),
                    serial, "RobotWare " + robotware};
}

AbbController::AbbController(AbbSettings settings, std::unique_ptr<HttpTransport> transport,
                             RetryPolicy policy)
    : settings_(std::move(settings)),
      transport_(std::move(transport)),
      policy_(policy),
      name_("ABB controller at " + transport_->name() + " (" +
            rws::VersionName(settings_.version) + ")") {
  if (settings_.version == rws::Version::kRws2) {
    settings_.representation = rws::Representation::kHalJson;
  } else if (settings_.representation == rws::Representation::kHalJson) {
    settings_.representation = rws::Representation::kXhtml;
  }
  if (!(settings_.speed_percent >= 1.0 && settings_.speed_percent <= 100.0)) {
    throw std::invalid_argument("speed_percent must be from 1 to 100");
  }
}

AbbController::~AbbController() {
  if (cookies_.empty()) return;
  try {
    transport_->SetInterrupt(nullptr);
    Attempt(rws::Logout(settings_.version), Clock::now() + Millis(500));
  } catch (const std::exception& e) {
    spdlog::debug("{}: logout failed: {}", name_, e.what());
  }
}

rws::SymbolPath AbbController::PathOf(const abb_contract::Symbol& symbol) const {
  return {settings_.task, settings_.module, symbol.name};
}

// ---- One request: authentication, cookies, the reply decoded ----

void AbbController::Authenticate(const HttpResponse& refused, const std::string& method,
                                 const std::string& uri) {
  std::vector<http::Challenge> challenges;
  try {
    challenges = http::ParseChallenges(refused.Header("WWW-Authenticate"));
  } catch (const http::HeaderError& e) {
    throw InstrumentError(name_, 3074,
                          std::string("an authentication challenge armsig cannot read: ") +
                              e.what());
  }
  for (const auto& c : challenges) {
    if (SchemeIs(c, "digest")) {
      try {
        authorization_ = http::DigestAuthorization(c, settings_.user, settings_.password, method,
                                                   uri, Cnonce(), ++nonce_count_);
      } catch (const http::HeaderError& e) {
        throw InstrumentError(name_, 3074, std::string("a Digest challenge armsig cannot answer: ") +
                                               e.what());
      }
      return;
    }
  }
  for (const auto& c : challenges) {
    if (SchemeIs(c, "basic")) {
      if (settings_.version != rws::Version::kRws2) {
        throw AbbFault(AbbFault::Kind::kCredentials, name_,
                       "asks for Basic authentication over plain HTTP; armsig does not send a "
                       "password in clear text (RWS 1.0 controllers ask for Digest)");
      }
      authorization_ = http::BasicAuthorization(settings_.user, settings_.password);
      return;
    }
  }
  throw InstrumentError(name_, 3074,
                        "asks for authentication armsig does not speak (neither Digest nor Basic)");
}

rws::Document AbbController::Attempt(const rws::Request& request, Deadline deadline) {
  const std::string target =
      rws::TargetFor(request, settings_.version, settings_.representation);
  for (int pass = 0;; ++pass) {
    HttpRequest r;
    r.method = request.method;
    r.target = target;
    r.body = request.body;
    r.headers.emplace_back("Accept", rws::AcceptHeader(settings_.representation));
    if (request.method == "POST") {
      r.headers.emplace_back("Content-Type", rws::FormContentType(settings_.version));
    } else if (!request.content_type.empty()) {
      r.headers.emplace_back("Content-Type", request.content_type);
    }
    if (!cookies_.empty()) {
      std::string cookie;
      for (const auto& c : cookies_) cookie += (cookie.empty() ? "" : "; ") + c.name + "=" + c.value;
      r.headers.emplace_back("Cookie", cookie);
    }
    if (!authorization_.empty()) r.headers.emplace_back("Authorization", authorization_);
    authorization_.clear();

    spdlog::trace("{}: {} {}", name_, r.method, r.target);
    const HttpResponse response = transport_->Exchange(r, deadline);
    ++exchanges_;
    for (const std::string& header : response.Headers("Set-Cookie")) {
      const auto cookie = http::ParseSetCookie(header);
      if (!cookie) continue;
      std::erase_if(cookies_, [&](const http::Cookie& c) { return c.name == cookie->name; });
      cookies_.push_back(*cookie);
    }
    if (response.status == 401) {
      if (pass > 0) {
        throw AbbFault(AbbFault::Kind::kCredentials, name_,
                       fmt::format("refused the user {} with the password from {} (HTTP 401): "
                                   "check the user name and password in {} (the user must exist "
                                   "in the controller's user authorization system, UAS)",
                                   Quoted(settings_.user), settings_.credentials_source,
                                   settings_.credentials_source));
      }
      cookies_.clear();  // the session is gone: a new one comes with the answer
      Authenticate(response, r.method, target);
      continue;
    }
    const std::string content_type = response.Header("Content-Type");
    if (response.status >= 200 && response.status < 300) {
      if (response.body.empty()) return {};
      return rws::Parse(response.body, content_type);  // rws::DecodeError: the caller retries
    }
    std::optional<rws::Status> status;
    try {
      if (!response.body.empty()) status = rws::Parse(response.body, content_type).status;
    } catch (const rws::DecodeError&) {
    }
    std::string message = fmt::format("refused {} {} (HTTP {}", request.method, request.target,
                                      response.status);
    if (status) {
      message += fmt::format(", return code {}{}", status->code,
                             status->message.empty() ? "" : ": " + Printable(status->message));
    }
    throw RwsRefused(name_, response.status, status, message + ")");
  }
}

rws::Document AbbController::Call(const rws::Request& request, Deadline deadline) {
  instruments::Attempts a(policy_, deadline);
  for (; a.Left(); a.Next()) {
    try {
      return Attempt(request, a.Until());
    } catch (const CertificateError& e) {
      std::string message = "refused the TLS connection: " + e.message() + ". ";
      if (!e.fingerprint().empty()) {
        message += "If " + e.fingerprint() +
                   " is the fingerprint the controller shows for its own certificate "
                   "(RobotStudio or the FlexPendant), pin it in the lab file: "
                   "certificate_sha256: " + e.fingerprint();
      }
      throw AbbFault(AbbFault::Kind::kCertificate, name_, message);
    } catch (const TransportError& e) {
      if (e.kind() == TransportError::Kind::kInterrupted) throw;
      a.Failed(e);
      spdlog::debug("{}: attempt {} of {} failed: {}", name_, a.made() + 1, policy_.attempts, a.last());
      transport_->Close();
      transport_->Pause(policy_.reconnect_delay, deadline);
    } catch (const rws::DecodeError& e) {
      a.Failed(instruments::grc::kComCantDecode, std::string("a reply that is no RWS page: ") + e.what());
      spdlog::debug("{}: attempt {} of {}: {}", name_, a.made() + 1, policy_.attempts, a.last());
    }
  }
  ThrowLost(a.GaveUp());
}

void AbbController::ThrowLost(const std::string& why) const {
  throw ControllerError(Kind::kConnectionLost, name_, "Robot Web Services did not answer: " + why,
                        "check that the controller is on, its network cable and address (and "
                        "the service or WAN port in the lab file); the session resumes where it "
                        "stopped");
}

// ---- RAPID data ----

std::string AbbController::ReadSymbol(const abb_contract::Symbol& symbol, Deadline deadline) {
  try {
    return rws::DecodeSymbolValue(Call(rws::GetSymbol(settings_.version, PathOf(symbol)), deadline));
  } catch (const RwsRefused& e) {
    if (!IsNotFound(e)) throw;
    throw AbbFault(AbbFault::Kind::kContract, name_,
                   fmt::format("has no RAPID symbol {} in module {} of task {}: load armsig's "
                               "module controllers/abb/{}.mod into {} and start it "
                               "(docs/how-to/abb.md)",
                               symbol.name, settings_.module, settings_.task,
                               abb_contract::kModule, settings_.task));
  } catch (const rws::DecodeError& e) {
    throw InstrumentError(name_, 3074, std::string("the value of ") + symbol.name + ": " + e.what());
  }
}

double AbbController::ReadNum(const abb_contract::Symbol& symbol, Deadline deadline) {
  const std::string text = ReadSymbol(symbol, deadline);
  try {
    return rws::ParseRapidNum(text);
  } catch (const rws::DecodeError& e) {
    throw InstrumentError(name_, 3074, std::string("the value of ") + symbol.name + ": " + e.what());
  }
}

std::shared_ptr<void> AbbController::HoldMastership(const std::string& during, Deadline deadline) {
  try {
    Call(rws::RequestMastership(settings_.version), deadline);
  } catch (const RwsRefused& e) {
    const auto& s = e.status();
    if (s && s->code == rws::code::kHeldBySomeoneElse) {
      throw ControllerError(Kind::kNotRemote, name_,
                            "another client holds the write access (mastership) to RAPID" + during,
                            "release it there (RobotStudio: Release Write Access; or close the "
                            "other program), then resume the session");
    }
    throw;
  }
  return std::shared_ptr<void>(nullptr, [this, deadline](void*) {
    try {
      Call(rws::ReleaseMastership(settings_.version), std::max(deadline, Clock::now() + Millis(500)));
    } catch (const std::exception& e) {
      spdlog::debug("{}: releasing mastership: {}", name_, e.what());
    }
  });
}

void AbbController::WriteSymbols(
    const std::vector<std::pair<abb_contract::Symbol, std::string>>& values, Deadline deadline) {
  const auto mastership = HoldMastership("", deadline);
  for (const auto& [symbol, value] : values) {
    try {
      Call(rws::SetSymbol(settings_.version, PathOf(symbol), value), deadline);
    } catch (const RwsRefused& e) {
      const auto& s = e.status();
      if (s && s->code == rws::code::kRejected) {
        throw AbbFault(AbbFault::Kind::kCredentials, name_,
                       fmt::format("refused to write {}: the user {} lacks the UAS grant "
                                   "'Modify current value' (docs/how-to/abb.md)",
                                   symbol.name, Quoted(settings_.user)));
      }
      throw;
    }
  }
}

// ---- Identity and state ----

AbbIdentity AbbController::Details() {
  const Deadline deadline = Clock::now() + policy_.timeout;
  const auto v = settings_.version;
  AbbIdentity id;
  try {
    const rws::Identity ctrl = rws::DecodeIdentity(Call(rws::GetIdentity(v), deadline));
    id.controller_name = ctrl.name;
    id.controller_id = ctrl.id;
    id.controller_type = ctrl.type;
    const rws::SystemInfo system = rws::DecodeSystemInfo(Call(rws::GetSystem(v), deadline));
    id.robotware = system.rwversionname.empty() ? system.rwversion : system.rwversionname;
    id.model = rws::DecodeRobotTypes(Call(rws::GetRobotType(v), deadline)).front();
    id.serial = rws::DecodeRobotSerial(Call(rws::GetRobotSerial(v), deadline));
  } catch (const rws::DecodeError& e) {
    throw InstrumentError(name_, 3074, std::string("its identity: ") + e.what());
  }
  name_ = fmt::format("ABB {} '{}' at {}", id.model, Printable(id.controller_name),
                      transport_->name());
  const double version = ReadNum(abb_contract::kContractVersion, deadline);
  id.contract_version = static_cast<int>(version);
  if (version != abb_contract::kVersion) {
    throw AbbFault(AbbFault::Kind::kContract, name_,
                   fmt::format("runs module {} of contract version {}; this armsig speaks version "
                               "{}: load the module shipped with this armsig "
                               "(controllers/abb/{}.mod)",
                               settings_.module, version, abb_contract::kVersion,
                               abb_contract::kModule));
  }
  identity_ = id;
  spdlog::debug("{}: serial {}, RobotWare {}, controller id {}, contract {}", name_, id.serial,
                id.robotware, id.controller_id, id.contract_version);
  return id;
}

std::optional<ControllerIdentity> AbbController::Identify() {
  const AbbIdentity d = Details();
  ControllerIdentity id;
  id.protocol = "abb";
  id.vendor = "ABB";
  id.model = d.model;
  id.serial = d.serial;
  id.software = "RobotWare " + d.robotware;
  return id;
}

void AbbController::EnsureContract(Deadline) {
  if (!identity_) Details();
}

AbbController::State AbbController::ReadStateBy(Deadline deadline) {
  const auto v = settings_.version;
  try {
    // The controller state last: a stop switches the motors off and then stops the
    // program, so a program found stopped is put down to the stop that caused it.
    State s;
    s.execution = rws::DecodeExecutionState(Call(rws::GetExecution(v), deadline));
    s.mode = rws::DecodeOperationMode(Call(rws::GetOperationMode(v), deadline));
    s.controller = rws::DecodeControllerState(Call(rws::GetControllerState(v), deadline));
    return s;
  } catch (const rws::DecodeError& e) {
    throw InstrumentError(name_, 3074, std::string("its state: ") + e.what());
  }
}

AbbController::State AbbController::ReadState() {
  return ReadStateBy(Clock::now() + policy_.timeout);
}

bool AbbController::Ready(const State& s) const {
  return s.controller == rws::ControllerState::kMotorsOn && s.mode == rws::OperationMode::kAuto &&
         s.execution == rws::ExecutionState::kRunning;
}

void AbbController::ThrowForState(const State& s, const std::string& during) {
  using CS = rws::ControllerState;
  const std::string restart = fmt::format(
      "start the program again on the FlexPendant (task {}, module {}; continue, no PP to "
      "main): the session goes on once it runs",
      settings_.task, settings_.module);
  switch (s.controller) {
    case CS::kGuardStop:
      recovering_ = Kind::kProtectiveStop;
      throw ControllerError(Kind::kProtectiveStop, name_,
                            "guard stop" + during +
                                ": the safety run chain is open (a cell door, a light curtain, an "
                                "enabling device)",
                            "close it and reset the stop, switch the motors on and " + restart);
    case CS::kEmergencyStop:
    case CS::kEmergencyStopReset:
      recovering_ = Kind::kEmergencyStop;
      throw ControllerError(Kind::kEmergencyStop, name_, "emergency stop" + during,
                            "release the emergency stop button, reset the emergency stop, switch "
                            "the motors on and " + restart);
    default:
      break;
  }
  // After a guard stop, the motors off and the program stopped are its recovery: the same
  // stop, still waited out.
  if (recovering_ == Kind::kProtectiveStop && s.mode == rws::OperationMode::kAuto &&
      (s.controller == CS::kMotorsOff || s.controller == CS::kMotorsOn)) {
    throw ControllerError(Kind::kProtectiveStop, name_,
                          s.controller == CS::kMotorsOff
                              ? "the guard stop is reset; the motors are still off"
                              : "the guard stop is reset; the program is not running yet",
                          s.controller == CS::kMotorsOff ? "switch the motors on and " + restart
                                                         : restart);
  }
  switch (s.controller) {
    case CS::kMotorsOff:
      throw ControllerError(Kind::kNotRunning, name_, "motors off" + during,
                            "switch the motors on and, if it stopped, " + restart);
    case CS::kInit:
      throw ControllerError(Kind::kNotRunning, name_, "the controller is starting up",
                            "wait until it is ready, then resume the session");
    case CS::kSystemFailure:
      throw ControllerError(Kind::kNotRunning, name_, "the controller is in system failure",
                            "restart the controller, then " + restart);
    default:
      break;
  }
  if (s.mode != rws::OperationMode::kAuto) {
    throw ControllerError(Kind::kNotRemote, name_,
                          "in operating mode " + ModeWords(s.mode) + during +
                              ": armsig moves the robot in AUTO only",
                          "turn the mode key to AUTO, confirm on the FlexPendant, switch the "
                          "motors on and " + restart);
  }
  if (s.execution != rws::ExecutionState::kRunning) {
    throw ControllerError(Kind::kNotRunning, name_, "the RAPID program is not running" + during,
                          restart);
  }
  throw std::logic_error("ThrowForState called for a ready controller");
}

void AbbController::CheckReady() {
  const State s = ReadState();
  if (!Ready(s)) ThrowForState(s, "");
  recovering_.reset();
}

// ---- Joints ----

Eigen::VectorXd AbbController::ReadJointsRad() {
  const Deadline deadline = Clock::now() + policy_.timeout;
  EnsureContract(deadline);
  const double cmd = ReadNum(abb_contract::kCommand, deadline);
  const double done = ReadNum(abb_contract::kDone, deadline);
  if (cmd != done) {
    const State s = ReadStateBy(deadline);
    if (s.controller != rws::ControllerState::kMotorsOn ||
        s.execution != rws::ExecutionState::kRunning) {
      ThrowForState(s, fmt::format(" with move {:.0f} unfinished", cmd));
    }
    throw ControllerError(Kind::kArmMoving, name_,
                          fmt::format("the arm is moving (move {:.0f} not finished): no reading "
                                      "is taken while it moves",
                                      cmd),
                          "measure again once it stands");
  }
  std::vector<double> recorded;
  try {
    recorded = rws::ParseRapidArray(ReadSymbol(abb_contract::kJoints, deadline));
    if (recorded.size() != 6) throw rws::DecodeError("expected 6 joints");
  } catch (const rws::DecodeError& e) {
    throw InstrumentError(name_, 3074, std::string("the value of armsig_joints: ") + e.what());
  }
  Eigen::VectorXd now_deg;
  try {
    now_deg = rws::DecodeJointTargetDeg(
        Call(rws::GetJointTarget(settings_.version, settings_.mechunit), deadline));
  } catch (const rws::DecodeError& e) {
    throw InstrumentError(name_, 3074, std::string("the jointtarget: ") + e.what());
  }
  for (int i = 0; i < 6; ++i) {
    const double off = std::abs(now_deg(i) - recorded[static_cast<size_t>(i)]);
    if (!(off <= settings_.still_tolerance_deg)) {
      throw ControllerError(
          Kind::kArmMoving, name_,
          fmt::format("the arm is not where it stood after move {:.0f} (joint {} is {:.3f}° "
                      "away): it moves or was moved since; no reading taken",
                      done, i + 1, off),
          "nothing else may move the arm during a capture (another program, the pendant)");
    }
  }
  const double cmd_after = ReadNum(abb_contract::kCommand, deadline);
  const double done_after = ReadNum(abb_contract::kDone, deadline);
  if (cmd_after != cmd || done_after != done) {
    throw ControllerError(Kind::kArmMoving, name_,
                          fmt::format("a move began while the joints were read (request {:.0f}): "
                                      "no reading taken",
                                      cmd_after),
                          "measure again once it stands");
  }
  Eigen::VectorXd q(6);
  for (int i = 0; i < 6; ++i) q(i) = recorded[static_cast<size_t>(i)] / kDegPerRad;
  CheckJoints(name_, q);
  return q;
}

void AbbController::WaitDone(int request, Deadline deadline) {
  const std::string during = fmt::format(" during move {}", request);
  for (;;) {
    const Deadline call = std::min(deadline, Clock::now() + policy_.timeout);
    const double done = ReadNum(abb_contract::kDone, call);
    if (done == request) {
      const double error = ReadNum(abb_contract::kError, call);
      if (error != 0) {
        throw ControllerError(Kind::kMoveRefused, name_,
                              fmt::format("the module reported error {:.0f} for move {}; the arm "
                                          "stands where it stopped",
                                          error, request),
                              "see the event log on the FlexPendant (1: a speed outside 1 to "
                              "100 %, else the RAPID error number)");
      }
      return;
    }
    const State s = ReadStateBy(call);
    if (!Ready(s)) ThrowForState(s, during);
    if (Clock::now() >= deadline) {
      throw ControllerError(Kind::kMoveRefused, name_,
                            fmt::format("move {} not finished after {} s", request,
                                        settings_.move_timeout.count() / 1000.0),
                            "check that the module's loop runs (armsig_serve) and that the speed "
                            "is not too low for the lab's move timeout");
    }
    transport_->Pause(settings_.poll_interval, deadline);
  }
}

void AbbController::MoveTo(const Eigen::VectorXd& joints_rad) {
  if (!settings_.can_move) {
    throw std::logic_error(name_ + ": the lab file does not let armsig move this robot");
  }
  if (joints_rad.size() != 6) {
    throw std::invalid_argument(fmt::format("{}: a move needs 6 joints, got {}", name_,
                                            joints_rad.size()));
  }
  CheckJoints(name_, joints_rad);
  const Deadline deadline = Clock::now() + policy_.timeout;
  EnsureContract(deadline);
  CheckReady();
  double cmd = ReadNum(abb_contract::kCommand, deadline);
  const double done = ReadNum(abb_contract::kDone, deadline);
  if (cmd != done) {
    spdlog::info("{}: waiting for move {:.0f} to finish first", name_, cmd);
    WaitDone(static_cast<int>(cmd), Clock::now() + settings_.move_timeout);
  }
  const int request = cmd >= abb_contract::kMaxRequest ? 1 : static_cast<int>(cmd) + 1;
  rws::JointTarget target;
  for (int i = 0; i < 6; ++i) target.robax_deg[static_cast<size_t>(i)] = joints_rad(i) * kDegPerRad;
  WriteSymbols({{abb_contract::kTarget, rws::FormatRapidJointTarget(target)},
                {abb_contract::kSpeed, rws::FormatRapidNum(settings_.speed_percent)},
                {abb_contract::kCommand, std::to_string(request)}},
               Clock::now() + policy_.timeout);
  spdlog::debug("{}: move {} requested", name_, request);
  WaitDone(request, Clock::now() + settings_.move_timeout);
}

}  // namespace armsig::robots
