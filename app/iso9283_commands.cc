// armsig iso9283: ISO 9283 performance tests (plan, report, evaluate, evaluate-path; one file each).
#include "app/command.h"

namespace armsig::app {

void SetupIso9283Commands(CLI::App& parent, const GlobalOptions& global, Runner& run) {
  auto* iso = parent.add_subcommand(
      "iso9283", "ISO 9283 performance tests: the test plan, the evaluation and its certificate");
  iso->require_subcommand(1);
  SetupIso9283PlanCommand(*iso, global, run);
  SetupIso9283ReportCommand(*iso, global, run);
  SetupIso9283EvaluateCommand(*iso, global, run);
  SetupIso9283EvaluatePathCommand(*iso, global, run);
}

}  // namespace armsig::app
