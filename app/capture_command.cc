// armsig capture --lab LAB.yaml --plan PLAN --robot NAME [--skip-on-fault]
// armsig capture --lab LAB.yaml --resume SESSION
#include <fmt/format.h>
#include <spdlog/spdlog.h>
#include <unistd.h>

#include <atomic>
#include <cmath>
#include <csignal>
#include <iostream>
#include <optional>

#include "acquisition/lab.h"
#include "acquisition/plan.h"
#include "acquisition/session.h"
#include "app/command.h"
#include "core/error.h"
#include "core/units.h"
#include "db/database.h"
#include "db/store.h"

namespace armsig::app {

struct CaptureCommandOptions {
  std::string lab, plan, robot;
  int64_t resume = 0;
  bool skip_on_fault = false;
};

namespace {

std::atomic<bool> g_capture_stop{false};

std::string Duration(double seconds) {
  const int s = static_cast<int>(seconds + 0.5);
  return s >= 60 ? fmt::format("{}m{:02d}s", s / 60, s % 60) : fmt::format("{}s", s);
}

// A length for the progress line: "-" when there is none (NaN).
std::string Mm(double mm) { return std::isnan(mm) ? "-" : fmt::format("{:.3f}", mm); }

void PrintProgress(const acquisition::Progress& p) {
  if (!::isatty(STDERR_FILENO)) return;
  const int width = 30;
  const int filled = p.total ? width * p.done / p.total : width;
  std::cerr << fmt::format(
                   "\r[{}{}] {}/{} {:<10} miss {} mm (mean {}, max {}) remeasured {} flagged {} "
                   "failed {} skipped {} ETA {}   ",
                   std::string(filled, '#'), std::string(width - filled, ' '), p.done, p.total,
                   p.label, Mm(p.last_miss_mm), Mm(p.mean_miss_mm), Mm(p.max_miss_mm), p.remeasured,
                   p.flagged, p.failed, p.skipped, Duration(p.eta_s))
            << std::flush;
}

// "C3 (parallel_rays: …), C7 (…)"
std::string Named(const std::vector<acquisition::ConfigurationVerdict>& list) {
  std::string out;
  for (const auto& v : list) out += (out.empty() ? "" : ", ") + v.label + " (" + v.why + ")";
  return out;
}

std::string ResumeHint(const std::string& db, const std::string& lab, int64_t session) {
  return fmt::format("armsig --db {} capture --lab {} --resume {}", ShellWord(AbsolutePath(db)),
                     ShellWord(AbsolutePath(lab)), session);
}

std::string Summary(const acquisition::CaptureSummary& s) {
  std::string text = fmt::format(
      "session {}: {} of {} configurations stored ({} now, {} before): {} usable, {} flagged, {} "
      "failed, {} skipped; {} re-measured\n",
      s.session, s.already + s.measured + s.skipped, s.total, s.measured + s.skipped, s.already,
      s.usable, s.flagged, s.failed, s.skipped, s.remeasured);
  if (s.mean_miss_mm) {
    text += fmt::format("  miss distance of the usable points: mean {:.4f} mm, max {:.4f} mm\n",
                        *s.mean_miss_mm, *s.max_miss_mm);
  } else if (s.measured > 0) {
    text += "  no usable point in this run: no miss distance to report\n";
  }
  if (!s.failed_configurations.empty())
    text += "  failed (no point): " + Named(s.failed_configurations) + "\n";
  if (!s.flagged_configurations.empty())
    text += "  flagged (beyond tolerances): " + Named(s.flagged_configurations) + "\n";
  if (!s.skipped_configurations.empty())
    text += "  skipped (instrument fault): " + Named(s.skipped_configurations) + "\n";
  if (s.measured + s.skipped > 0) {
    text += fmt::format("  {:.1f} s, {:.1f} ms per configuration ({:.2f} ms software)\n", s.seconds,
                        s.mean_cycle_ms, s.mean_overhead_ms);
  }
  return text;
}

}  // namespace

int RunCaptureCommand(const CaptureCommandOptions& o, const GlobalOptions& global) {
  // Ctrl-C from the first moment: stop at the next safe point and leave the session
  // paused, never killed half-way with the session marked running.
  g_capture_stop = false;
  std::signal(SIGINT, [](int) {
    g_capture_stop = true;
    std::signal(SIGINT, SIG_DFL);  // a second Ctrl-C ends at once
  });
  // The handler stays until the process ends: a Ctrl-C after the work is done changes
  // nothing (the summary and the --json file are still written, exit as the work says).
  // Resuming only continues what is there: a mistyped --db must not become a new file.
  std::optional<db::Database> opened;
  if (o.resume > 0) opened.emplace(global.DbPath(), db::OpenMode::kMustExist);
  const acquisition::LabConfig lab = acquisition::LoadLab(o.lab);
  if (lab.stations.empty()) {
    throw InputError({o.lab, 0, 0, "stations"},
                     "no oriented stations (give 'stations:' a file from armsig orient)");
  }
  if (!opened) opened.emplace(global.DbPath());  // a new session: after the lab file is read
  db::Database& database = *opened;
  int64_t session = o.resume;
  if (session > 0) {
    const auto row = db::LoadSession(database, session);
    if (!row)
      throw InputError({database.path(), 0, 0, ""},
                       "no session " + std::to_string(session) + " to resume");
    if (row->state == "completed") {
      std::cout << "session " << session << " is already complete\n";
      return kOk;
    }
  } else {
    if (o.plan.empty() || o.robot.empty()) {
      throw InputError({"capture", 0, 0, ""},
                       "a new session needs --plan and --robot (or --resume SESSION)");
    }
    const acquisition::Plan plan = acquisition::MakePlan(o.plan, lab.model);
    session = acquisition::CreateSession(database, lab, o.robot, plan);
    spdlog::info("capture: session {}, {} configurations", session, plan.size());
  }
  const std::string resume = ResumeHint(database.path(), o.lab, session);
  if (g_capture_stop) {  // before any device was opened
    db::SetSessionState(database, session, "paused");
    spdlog::warn("capture: stopped before the first configuration; resume with: {}", resume);
    return kFailure;
  }
  acquisition::CaptureSummary s;
  try {
    auto devices = acquisition::OpenInstruments(lab);
    auto controller = acquisition::OpenController(lab);
    acquisition::CaptureOptions options;
    options.skip_on_fault = o.skip_on_fault;
    options.stop = &g_capture_stop;
    options.progress = PrintProgress;
    options.prompt_move = [](const acquisition::PlannedConfiguration& c) {
      std::string joints;
      for (int i = 0; i < c.joints_rad.size(); ++i)
        joints += fmt::format(" {:.2f}", c.joints_rad(i) / kRadPerDeg);
      std::cerr << "\nmove the robot to " << c.label << " (deg:" << joints << ")";
      if (::isatty(STDIN_FILENO)) {
        std::cerr << " and press Enter ";
        std::string line;
        std::getline(std::cin, line);
      } else {
        std::cerr << "; not a terminal: measuring where the robot is\n";
      }
    };
    s = acquisition::RunCapture(database, lab, session, devices, *controller, options);
  } catch (...) {
    // A device that cannot be opened (or a failure mid-way): the session stays resumable.
    db::SetSessionState(database, session, "paused");
    spdlog::info("capture: session {} paused; resume with: {}", session, resume);
    throw;
  }
  if (::isatty(STDERR_FILENO)) std::cerr << "\n";
  std::cout << Summary(s);
  if (s.paused) {
    spdlog::error("capture: session {} paused: {}", s.session, s.pause_reason);
    spdlog::info("fix it, then resume with: {}", resume);
    return kFailure;
  }
  if (s.stopped) {
    spdlog::warn("capture: stopped; resume with: {}", resume);
    return kFailure;
  }
  if (s.already + s.usable == 0) {
    spdlog::error("capture: session {} has no usable configuration", s.session);
    return kFailure;
  }
  if (s.failed + s.flagged + s.skipped > 0 && !o.skip_on_fault) {
    spdlog::error(
        "capture: session {}: {} failed and {} flagged configurations (named above); "
        "--skip-on-fault accepts such a session",
        s.session, s.failed, s.flagged);
    return kFailure;
  }
  return kOk;
}

void SetupCaptureCommand(CLI::App& parent, const GlobalOptions& global, Runner& run) {
  auto o = std::make_shared<CaptureCommandOptions>();
  auto* sub = parent.add_subcommand("capture", "Run a capture session with the lab's instruments");
  sub->add_option("--lab", o->lab, "Lab configuration YAML")->required();
  sub->add_option("--plan", o->plan, "PLAN.csv, auto:N (well spread) or single-joint:J:STEPS");
  NameOption(sub->add_option("--robot", o->robot, "Robot name (created in the database if new)"));
  sub->add_option("--resume", o->resume, "Continue this session where it stopped");
  sub->add_flag("--skip-on-fault", o->skip_on_fault,
                "Record a configuration whose instrument keeps failing as skipped and go on "
                "(default: pause), and exit 0 although configurations failed or were flagged "
                "(default: exit 1, naming them)");
  sub->callback(
      [&run, &global, o] { run = [&global, o] { return RunCaptureCommand(*o, global); }; });
}

}  // namespace armsig::app
