// The virtual KUKA controller's program runner: what the shipped submit-interpreter part
// controllers/kuka/ARMSIG_SPS.sub does on a KR C4 / KR C5, run natively each interpreter
// cycle (as ARMSIG.src's contract is in kuka_simulator.cc).
//
// A new ARMSIG_RUN_CMD is taken at once (ARMSIG_RUN_BUSY). Not in AUT or EXT: result 1.
// Otherwise what the robot interpreter has is stopped and cancelled (STOP 1, CANCEL 1: the
// arm brakes along its path, ARMSIG's command is dropped) and RUN /R1/NAME() selects
// NAME.src with its NAME.dat from the program folder (KukaSimulatorOptions::program_folder;
// the names compared without case, as the controller's file system does), compiled by
// programs/krl.h with the controller's TOOL_DATA and BASE_DATA: a program missing, or one the
// reader refuses, or a motion of it the controller cannot run (a target out of reach, an
// unknown tool) is not selected — result 2, as the smartPAD's message would stop it. RUN
// starts it in AUT and EXT (KSS 8.x: selection and start in one; an assumption where KUKA's
// manual is not public, see ARMSIG_SPS.sub). Its DEF's motions run as
// simulation/program_runner.h executes them (each Cartesian target through the controller's
// inverse kinematics on its nominal model, in the configuration S and T state), each a
// synchronous PTP at 100 % of the axes' velocity and acceleration, and each WAIT SEC the
// time it says, in the order written. Its END: #P_END, result 0; a stop before (the STOP
// key, a mode change, the drives off, an EMERGENCY STOP): #P_STOP, result 3.
#include <fmt/format.h>

#include <cctype>
#include <filesystem>

#include "io/atomic_file.h"
#include "simulation/kuka_simulator.h"

namespace armsig::simulation {

namespace contract = robots::kuka::contract;

namespace {

constexpr double kRadPerDeg = 3.14159265358979323846 / 180.0;

std::string UpperCase(std::string s) {
  for (char& c : s) c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
  return s;
}

// The file of the program folder whose name is `name` (any case), or nullopt.
std::optional<std::filesystem::path> FindInFolder(const std::string& folder,
                                                  const std::string& name) {
  std::error_code ec;
  for (const auto& entry : std::filesystem::directory_iterator(folder, ec))
    if (UpperCase(entry.path().filename().string()) == UpperCase(name)) return entry.path();
  return std::nullopt;
}

}  // namespace

void KukaSimulator::EndRun(int result) {
  SetGlobal(contract::kRunResult, result);
  SetGlobal(contract::kRunDone, GlobalInt(contract::kRunBusy));
  SetGlobal(contract::kRunPhase, 0);
  run_.reset();
}

std::optional<std::string> KukaSimulator::SelectRun(const std::string& name) {
  if (options_.program_folder.empty()) return "no program folder";
  const auto src = FindInFolder(options_.program_folder, name + ".src");
  if (!src) return fmt::format("{}.src is not in the program folder", name);
  const auto dat = FindInFolder(options_.program_folder, name + ".dat");
  programs::Program program;
  try {
    std::optional<programs::ProgramFile> data;
    if (dat)
      data = programs::ProgramFile{dat->filename().string(),
                                   io::ReadWholeFile(dat->string(), io::kProgramFileLimit)};
    program = programs::ParseKrl(
        {src->filename().string(), io::ReadWholeFile(src->string(), io::kProgramFileLimit)}, data,
        &options_.config);
  } catch (const std::exception& e) {
    return e.what();
  }
  std::erase_if(program.motions,
                [&](const programs::Motion& m) { return UpperCase(m.routine) != UpperCase(name); });
  std::erase_if(program.waits,
                [&](const programs::Wait& w) { return UpperCase(w.routine) != UpperCase(name); });
  const Execution run = RunProgram(program, controller_, arm_state_.q);
  if (!run.skipped.empty())
    return fmt::format("{}: {}", programs::Where(program, run.skipped.front().place),
                       run.skipped.front().why);
  run_.emplace(StepsOf(run, program.waits));
  return std::nullopt;
}

void KukaSimulator::AdvanceRunner() {
  const int64_t cmd = GlobalInt(contract::kRunCommand);
  if (cmd != GlobalInt(contract::kRunBusy)) {  // a new run
    SetGlobal(contract::kRunBusy, cmd);
    if (!Automatic()) return EndRun(contract::kRunNotAutomatic);
    arm_->ProtectiveStop();  // STOP 1: it brakes along its path
    arm_->ClearProtectiveStop();
    command_.reset();  // CANCEL 1: ARMSIG's motion is dropped with it
    run_.reset();
    program_.clear();
    program_state_ = "P_FREE";
    const std::string name =
        robots::kuka::ParseString(globals_.at(contract::kRunName).text).value_or("");
    if (const auto why = SelectRun(name)) {
      last_run_refusal_ = *why;
      return EndRun(contract::kRunNotSelected);
    }
    program_ = name;
    program_state_ = "P_ACTIVE";
    SetGlobal(contract::kRunPhase, 3);
    ++runs_;
  }
  if (!run_) return;
  if (program_state_ != "P_ACTIVE") {
    return EndRun(contract::kRunStopped);
  }
  const auto status = run_->Tick(*arm_, [&](const Eigen::VectorXd& q) {
    for (int i = 0; i < axes_; ++i) {
      if (q(i) / kRadPerDeg >= limits_[i].first && q(i) / kRadPerDeg <= limits_[i].second) continue;
      program_state_ = "P_STOP";  // a software limit: the motion is refused, the program stops
      return;
    }
    Ptp(q, 100, 100);
  });
  if (status == ProgramPlayer::Status::kFinished) {
    program_state_ = "P_END";
    EndRun(contract::kRunEnded);
  } else if (status == ProgramPlayer::Status::kStopped || program_state_ != "P_ACTIVE") {
    program_state_ = "P_STOP";
    EndRun(contract::kRunStopped);
  }
}

}  // namespace armsig::simulation
