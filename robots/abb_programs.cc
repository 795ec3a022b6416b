// AbbController's program runs: how a lab gets a RAPID module onto the controller and runs it
// over Robot Web Services (robots/abb_controller.h; the resources as
// robots/rws_codec.h names them). The sequence is RobotStudio's and the PC SDK's:
// the file uploaded to the controller's $HOME, loaded into the motion task with RAPID
// mastership, the program pointer set to the routine, execution started (cycle once) and
// watched until it stops; afterwards the program pointer back to main and the module
// unloaded, so that the task is as it was (armsig's own module's main).
#include <fmt/format.h>

#include "core/text.h"
#include "robots/abb_controller.h"

namespace armsig::robots {
using instruments::Clock;
using instruments::ControllerError;
using instruments::Deadline;
using instruments::InstrumentError;

namespace {

using Kind = ControllerError::Kind;

std::string StatusWords(const RwsRefused& e) {
  const auto& s = e.status();
  if (!s) return fmt::format("HTTP {}", e.http_status());
  return fmt::format("{} (return code {}, HTTP {})", s->message.empty() ? "no message" : s->message,
                     s->code, e.http_status());
}

}  // namespace

void AbbController::LoadProgram(const std::string& file_name, const std::string& text,
                                const std::string& module, const std::string& routine) {
  const Deadline deadline = Clock::now() + policy_.timeout;
  const std::string path = "$HOME/" + file_name;
  // A module loads only while RAPID stands: armsig's own module's main, when it runs, is
  // stopped first and started again from main by UnloadProgram.
  if (ReadStateBy(deadline).execution == rws::ExecutionState::kRunning) {
    Call(rws::StopExecution(settings_.version), deadline);
    resume_main_ = true;
  }
  try {
    Call(rws::UploadFile(settings_.version, path, text), deadline);
  } catch (const RwsRefused& e) {
    throw RwsRefused(
        name_, e.http_status(), e.status(),
        fmt::format("refused the upload of {} to {}: {}", file_name, path, StatusWords(e)));
  }
  const auto mastership = HoldMastership(fmt::format(" (loading {})", file_name), deadline);
  try {
    Call(rws::LoadModule(settings_.version, settings_.task, path, /*replace=*/true), deadline);
  } catch (const RwsRefused& e) {
    throw RwsRefused(
        name_, e.http_status(), e.status(),
        fmt::format("did not load {} into task {}: {}. Check the module in RobotStudio or "
                    "on the FlexPendant's event log: nothing of it was loaded",
                    file_name, settings_.task, StatusWords(e)));
  }
  try {
    Call(rws::SetProgramPointer(settings_.version, settings_.task, module, routine), deadline);
  } catch (const RwsRefused& e) {
    throw RwsRefused(name_, e.http_status(), e.status(),
                     fmt::format("did not set the program pointer to {} of module {}: {}", routine,
                                 module, StatusWords(e)));
  }
}

void AbbController::StartProgram(const std::string& module) {
  const Deadline deadline = Clock::now() + policy_.timeout;
  const State s = ReadStateBy(deadline);
  const std::string during = " (starting " + module + ")";
  if (s.controller != rws::ControllerState::kMotorsOn || s.mode != rws::OperationMode::kAuto) {
    ThrowForState(s, during);
  }
  try {
    Call(rws::StartExecution(settings_.version, "once"), deadline);
  } catch (const RwsRefused& e) {
    throw RwsRefused(name_, e.http_status(), e.status(),
                     fmt::format("refused to start {}: {}", module, StatusWords(e)));
  }
}

bool AbbController::ProgramRunning() {
  const State s = ReadStateBy(Clock::now() + policy_.timeout);
  if (s.execution == rws::ExecutionState::kRunning) return true;
  if (s.controller != rws::ControllerState::kMotorsOn &&
      s.controller != rws::ControllerState::kMotorsOff) {
    ThrowForState(s, " while the program ran");
  }
  return false;
}

void AbbController::UnloadProgram(const std::string& module) {
  const Deadline deadline = Clock::now() + policy_.timeout;
  const auto mastership = HoldMastership(fmt::format(" (unloading {})", module), deadline);
  Call(rws::ResetProgramPointer(settings_.version), deadline);
  Call(rws::UnloadModule(settings_.version, settings_.task, module), deadline);
  if (resume_main_) Call(rws::StartExecution(settings_.version), deadline);
  resume_main_ = false;
}

Eigen::VectorXd AbbController::ReadJointTargetDeg() {
  const Deadline deadline = Clock::now() + policy_.timeout;
  try {
    return rws::DecodeJointTargetDeg(
        Call(rws::GetJointTarget(settings_.version, settings_.mechunit), deadline));
  } catch (const rws::DecodeError& e) {
    throw InstrumentError(name_, 3074, std::string("the jointtarget: ") + e.what());
  }
}

}  // namespace armsig::robots
