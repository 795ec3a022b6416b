// KukaController's program runs: the files copied into the controller's program folder (its
// network share), the submit interpreter's part ARMSIG_SPS.sub asked through the variable
// server to select and start them (controllers/kuka/ARMSIG_SPS.sub says how), and its report
// read back (ARMSIG_RUN_DONE, ARMSIG_RUN_RESULT).
#include <fmt/format.h>

#include <filesystem>

#include "robots/kuka_controller.h"

namespace armsig::robots {
using instruments::ControllerError;
using instruments::Deadline;
using instruments::InstrumentError;

namespace contract = kuka::contract;

void CopyToProgramFolder(const std::vector<std::string>& files, const std::string& folder) {
  for (const std::string& file : files) {
    std::error_code ec;
    const std::filesystem::path to =
        std::filesystem::path(folder) / std::filesystem::path(file).filename();
    std::filesystem::copy_file(file, to, std::filesystem::copy_options::overwrite_existing, ec);
    if (ec)
      throw InstrumentError(
          folder, 0,
          fmt::format("cannot copy {} into the controller's program folder {}: {}", file, folder,
                      ec.message()));
  }
}

int64_t KukaController::RunProgram(const std::string& name) {
  const Deadline deadline = CallDeadline();
  WriteBy(contract::kRunName, kuka::FormatString(name), deadline);
  const int64_t n =
      std::max(ReadInt(contract::kRunCommand, deadline), ReadInt(contract::kRunDone, deadline)) + 1;
  WriteBy(contract::kRunCommand, std::to_string(n), deadline);
  return n;
}

bool KukaController::ProgramRunning(int64_t n, const std::string& name) {
  const Deadline deadline = CallDeadline();
  if (ReadInt(contract::kRunDone, deadline) != n) return true;
  switch (ReadInt(contract::kRunResult, deadline)) {
    case contract::kRunEnded:
      return false;
    case contract::kRunNotAutomatic:
      throw Error(ControllerError::Kind::kNotRemote,
                  fmt::format("did not run {}: the controller is not in AUT or EXT", name),
                  "turn the mode selector to AUT or EXT, then run it again");
    case contract::kRunNotSelected:
      throw Error(
          ControllerError::Kind::kNotRunning,
          fmt::format("did not select {}: no {}.src in KRC:\\R1\\Program, or a program with errors",
                      name, name),
          "the smartPAD's message window names the line; copy the program again");
    default:
      throw Error(ControllerError::Kind::kNotRunning,
                  fmt::format("{} stopped before its END", name),
                  "see the smartPAD's messages, then run it again");
  }
}

}  // namespace armsig::robots
