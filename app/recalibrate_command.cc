// armsig recalibrate --robot NAME [--since …] [--select N] [--params …|auto] [--report DIR]
// [--json OUT]: the nightly job (workflows/recalibrate.h); exit 3 when a gate fails, 1 when
// the fit itself failed (not converged).
#include <fmt/format.h>

#include <iostream>

#include "app/command.h"
#include "core/plausibility.h"
#include "core/text.h"
#include "io/atomic_file.h"
#include "workflows/recalibrate.h"

namespace armsig::app {

struct RecalibrateCommand {
  workflows::RecalibrateOptions options;
  std::string json;
};

int RunRecalibrate(RecalibrateCommand c, const GlobalOptions& global) {
  c.options.db_path = global.DbPath();
  c.options.json_path = c.json;
  const auto d = workflows::Recalibrate(c.options);
  if (!c.json.empty()) io::WriteFileAtomically(c.json, JsonText(d.ToJson(), 2) + "\n");
  if (d.outcome == workflows::RecalibrationDecision::Outcome::kUpToDate) return kOk;
  if (d.outcome == workflows::RecalibrationDecision::Outcome::kFailed) {
    std::cout << d.robot << ": " << d.Describe() << "\n";  // no statistics of an unfinished fit
    return kFailure;
  }
  std::cout << fmt::format(
      "{}: {} (validation mean {:.4f} mm, max {:.4f} mm on {} configurations{})\n", d.robot,
      d.Describe(), d.validation.mean_mm, d.validation.max_mm, d.validation.poses,
      d.drift ? "; DRIFT" : "");
  return d.passed() ? kOk : kQualityGate;
}

void AddRecalibrateOptions(CLI::App& sub, workflows::RecalibrateOptions& o) {
  sub.add_option("--since", o.since, "Only sessions started at or after this ISO date/time");
  NumberOption(
      sub.add_option("--select", o.select, "Configurations to fit (default, 0: 60 %, at most 80)"),
      0, kMaxPoses);
  sub.add_option("--params", o.params, "geometric | all | auto | list")->capture_default_str();
  sub.add_option("--residual-model", o.residual_model,
                  "auto: a cross-validated residual map stored with the set when it clearly "
                  "helps; off: parametric only")
      ->check(CLI::IsMember({"auto", "off"}))
      ->capture_default_str();
  // Gates and drift thresholds: mm within a robot cell, sigmas within reason; a gate of 0
  // or less could never pass, a NaN would pass everything.
  constexpr double kMaxMm = plausible::kMaxLengthMm;
  NumberOption(sub.add_option("--max-validation-mean-mm", o.max_validation_mean_mm,
                               "Gate (default: lab file, else 0.5)"),
               1e-6, kMaxMm);
  NumberOption(sub.add_option("--max-validation-max-mm", o.max_validation_max_mm,
                               "Gate (default: lab file, else 2.0)"),
               1e-6, kMaxMm);
  NumberOption(sub.add_option("--tolerance-mm", o.tolerance_mm,
                               "Allowed worsening against the active set (default 0.02)"),
               0, kMaxMm);
  NumberOption(
      sub.add_option("--drift-sigma", o.drift_sigma,
                      "Parameter change (in sigmas) named when there is drift (default 5)"),
      1e-3, 1e6);
  NumberOption(sub.add_option("--drift-mm", o.drift_mm,
                               "Smallest change of predicted positions called drift (default: lab "
                               "file, else 0.05)"),
               0, kMaxMm);
  NumberOption(sub.add_option("--max-iterations", o.max_iterations,
                               "Iterations of the fit; one that needs more fails (exit 1)"),
               1, 10000)
      ->capture_default_str();
  NumberOption(sub.add_option("--lock-wait", o.lock_wait_s,
                               "Seconds to wait for another running recalibration"),
               0, 24 * 3600)
      ->capture_default_str();
  sub.add_flag("--force", o.force, "Refit even if the active set already uses these measurements");
}

void SetupRecalibrateCommand(CLI::App& parent, const GlobalOptions& global, Runner& run) {
  auto c = std::make_shared<RecalibrateCommand>();
  auto& o = c->options;
  auto* sub = parent.add_subcommand("recalibrate", "The nightly recalibration job");
  NameOption(sub->add_option("--robot", o.robot, "Robot name"))->required();
  AddRecalibrateOptions(*sub, o);
  OutputDirectory(
      sub->add_option("--report", o.report_dir, "Write an HTML report into this directory"));
  OutputFile(sub->add_option("--json", c->json, "Write a JSON summary for monitoring"));
  sub->callback([&run, &global, c] { run = [&global, c] { return RunRecalibrate(*c, global); }; });
}

}  // namespace armsig::app
