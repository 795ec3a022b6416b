// armsig recalibrate --robot NAME [--since …] [--select N] [--params …|auto] [--report DIR]
// [--json OUT] [--notify CMD]: the nightly job (nightly/recalibrate.h). Exit codes: 0
// stored or up to date, 4 drift (a set fitted after the change stored), 5 drift suspected
// (too few configurations since the change; nothing stored), 3 a gate failed, 1 the fit
// failed, 2 input.
#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <iostream>

#include "app/command.h"
#include "core/error.h"
#include "core/plausibility.h"
#include "core/text.h"
#include "db/sessions.h"
#include "io/atomic_file.h"
#include "io/notify.h"
#include "nightly/recalibrate.h"

namespace armsig::app {

struct RecalibrateCommand {
  nightly::RecalibrateOptions options;
  std::string json;
  std::string notify;
  double notify_timeout_s = 60;
};

namespace {

// The lab's command (mail, chat) on every night a person must see — drift, a suspected
// change, a rejected or failed fit, an input error — fed the JSON summary on stdin.
// Its failure is logged, never hidden, and does not change the job's exit code.
void Notify(const RecalibrateCommand& c, const nlohmann::json& summary, int exit_code) {
  if (c.notify.empty() || exit_code == kOk) return;
  const auto r = io::RunNotifyCommand(
      c.notify, JsonText(summary, 2) + "\n",
      {{"ARMSIG_ROBOT", c.options.robot},
       {"ARMSIG_EXIT_CODE", std::to_string(exit_code)},
       {"ARMSIG_DECISION", summary.value("decision", std::string("error"))},
       {"ARMSIG_DRIFT_LINE", summary.value("drift_line", std::string())}},
      std::chrono::milliseconds(static_cast<int64_t>(c.notify_timeout_s * 1000)));
  if (r.ok()) {
    spdlog::info("recalibrate: {}: --notify ran (exit {})", c.options.robot, exit_code);
  } else if (!r.started) {
    spdlog::error("recalibrate: {}: --notify {}: {}", c.options.robot, Quoted(c.notify), r.error);
  } else if (r.timed_out) {
    spdlog::error("recalibrate: {}: --notify {} did not finish within {} s: stopped",
                  c.options.robot, Quoted(c.notify), c.notify_timeout_s);
  } else {
    spdlog::error("recalibrate: {}: --notify {} failed with exit code {}", c.options.robot,
                  Quoted(c.notify), r.exit_code);
  }
}

}  // namespace

int RunRecalibrate(RecalibrateCommand c, const GlobalOptions& global) {
  c.options.db_path = global.DbPath();
  c.options.json_path = c.json;
  c.options.stop = &StopRequested();  // Ctrl-C, SIGTERM: stop before storing, exit 130
  nightly::RecalibrationDecision d;
  try {
    d = nightly::Recalibrate(c.options);
  } catch (const InputError& e) {
    // The job did not run: a person must see that as much as a drift.
    Notify(c, {{"robot", c.options.robot}, {"decision", "error"}, {"exit_code", kInputError},
               {"error", e.what()}},
           kInputError);
    throw;
  } catch (const std::exception& e) {
    Notify(c, {{"robot", c.options.robot}, {"decision", "error"}, {"exit_code", kFailure},
               {"error", e.what()}},
           kFailure);
    throw;
  }
  if (d.stopped) {
    std::cerr << fmt::format(
        "armsig: recalibrate: {}: stopped before storing anything; run the same command again\n",
        d.robot);
    return kStopped;
  }
  if (!c.json.empty()) {
    // The summary follows the commit (it names the stored version): a failure to write it
    // is said with what was stored, never taken for the run's.
    try {
      io::WriteFileAtomically(c.json, JsonText(d.ToJson(), 2) + "\n");
    } catch (const std::exception& e) {
      if (d.version <= 0) throw;
      d.output_error += (d.output_error.empty() ? "" : "; ") +
                        fmt::format("version {} is stored, but the summary could not be "
                                    "written to {}: {}",
                                    d.version, c.json, e.what());
      spdlog::error("recalibrate: {}: {}", d.robot, d.output_error);
    }
  }
  const nlohmann::json summary = d.ToJson();
  using Outcome = nightly::RecalibrationDecision::Outcome;
  if (d.outcome == Outcome::kFailed || d.outcome == Outcome::kDriftSuspected) {
    std::cout << d.robot << ": " << d.Describe() << "\n";  // no statistics of an unfinished fit
  } else if (d.outcome != Outcome::kUpToDate) {
    std::cout << fmt::format(
        "{}: {} (validation mean {:.4f} mm, max {:.4f} mm on {} configurations{})\n", d.robot,
        d.Describe(), d.validation.mean_mm, d.validation.max_mm, d.validation.poses,
        d.drift ? "; DRIFT" : "");
  }
  // The drift line on stdout, where a person reading the mail or the journal sees it.
  if (const std::string line = d.DriftLine(); !line.empty())
    std::cout << line << "\n";
  else if (!d.controller_calibration.empty())  // said even when the arm's errors did not move
    std::cout << d.robot << ": " << d.controller_calibration << "\n";
  if (!d.output_error.empty()) std::cout << d.robot << ": " << d.output_error << "\n";
  std::cout.flush();
  Notify(c, summary, d.ExitCode());
  return d.ExitCode();
}

void AddRecalibrateOptions(CLI::App& sub, nightly::RecalibrateOptions& o) {
  sub.add_option("--since", o.since, "Only sessions started at or after this ISO date/time")
      ->type_name("DATE");
  NumberOption(
      sub.add_option("--select", o.select, "Configurations to fit (default, 0: 60 %, at most 2000)"),
      0, kMaxPoses);
  sub.add_option("--params", o.params,
                 "auto: the geometric model plus the terms that pay on sessions or joint-space "
                 "regions the fit did not see | geometric | all | list")
      ->capture_default_str();
  EnumOption(sub.add_option("--kinds", o.kinds,
                            "Session kinds to fit, comma-separated: calibration, check, test (ISO 9283)")
                 ->delimiter(','),
             {db::SessionKind::kCalibration, db::SessionKind::kCheck, db::SessionKind::kTest},
             db::SessionKind::kCalibration);
  ChoiceOption(sub.add_option("--residual-model", o.residual_model,
                  "auto: a cross-validated residual map stored with the set when it clearly "
                  "helps; off: parametric only"), {"auto", "off"})
      ->capture_default_str();
  ChoiceOption(sub.add_option("--orientation", o.orientation,
                  "auto: sessions with measured orientations (6-DoF probes) fit them too; "
                  "off: positions only"), {"auto", "off"})
      ->capture_default_str();
  ChoiceOption(sub.add_option("--tool-rotation", o.tool_rotation,
                  "per-session: each session's probe rotation on the flange is fitted apart "
                  "(it may have been remounted); shared: one for every session (it stayed on)"),
               {"per-session", "shared"})
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
  NumberOption(sub.add_option("--window-sessions", o.window_sessions,
                               fmt::format("Fit at most the newest N sessions (0: all; default: "
                                           "lab file, else {})",
                                           nightly::kDefaultWindowSessions)),
               0, 100000);
  NumberOption(sub.add_option("--window-days", o.window_days,
                               fmt::format("Fit only sessions started within the last D days (0: "
                                           "no limit; default: lab file, else {})",
                                           nightly::kDefaultWindowDays)),
               0, 100000);
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
  sub->add_option("--notify", c->notify,
                  "Shell command run on every night a person must see (any exit code but 0), "
                  "the JSON summary on its stdin; ARMSIG_ROBOT, ARMSIG_EXIT_CODE, "
                  "ARMSIG_DECISION, ARMSIG_DRIFT_LINE in its environment")
      ->type_name("COMMAND");
  NumberOption(sub->add_option("--notify-timeout", c->notify_timeout_s,
                                "Seconds the --notify command may take before it is stopped"),
               0.1, 3600)
      ->capture_default_str();
  sub->callback([&run, &global, c] { run = [&global, c] { return RunRecalibrate(*c, global); }; });
}

}  // namespace armsig::app
