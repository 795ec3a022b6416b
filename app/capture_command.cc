// armsig capture --lab LAB.yaml --plan PLAN --robot NAME [--skip-on-fault]
// armsig capture --lab LAB.yaml --resume SESSION
#include <fmt/format.h>
#include <spdlog/spdlog.h>
#include <unistd.h>

#include <atomic>
#include <csignal>
#include <iostream>

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

void PrintProgress(const acquisition::Progress& p) {
  if (!::isatty(STDERR_FILENO)) return;
  const int width = 30;
  const int filled = p.total ? width * p.done / p.total : width;
  std::cerr << fmt::format(
                   "\r[{}{}] {}/{} {:<10} miss {:.3f} mm (mean {:.3f}, max {:.3f}) remeasured {} "
                   "skipped {} ETA {}   ",
                   std::string(filled, '#'), std::string(width - filled, ' '), p.done, p.total,
                   p.label, p.last_miss_mm, p.mean_miss_mm, p.max_miss_mm, p.remeasured, p.skipped,
                   Duration(p.eta_s))
            << std::flush;
}

}  // namespace

int RunCaptureCommand(const CaptureCommandOptions& o, const GlobalOptions& global) {
  const acquisition::LabConfig lab = acquisition::LoadLab(o.lab);
  if (lab.stations.empty()) {
    throw InputError({o.lab, 0, 0, "stations"},
                     "no oriented stations (give 'stations:' a file from armsig orient)");
  }
  db::Database database(global.DbPath());
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
  auto devices = acquisition::OpenInstruments(lab);
  auto controller = acquisition::OpenController(lab);
  g_capture_stop = false;
  std::signal(SIGINT, [](int) {
    g_capture_stop = true;
    std::signal(SIGINT, SIG_DFL);  // a second Ctrl-C ends at once
  });
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
  const auto s = acquisition::RunCapture(database, lab, session, devices, *controller, options);
  if (::isatty(STDERR_FILENO)) std::cerr << "\n";
  std::cout << fmt::format(
      "session {}: {} of {} configurations stored ({} now, {} before), {} skipped, {} re-measured; "
      "miss distance mean {:.4f} mm, max {:.4f} mm; {:.1f} s, {:.1f} ms per configuration "
      "({:.2f} ms software)\n",
      s.session, s.already + s.measured + s.skipped, s.total, s.measured, s.already, s.skipped,
      s.remeasured, s.mean_miss_mm, s.max_miss_mm, s.seconds, s.mean_cycle_ms, s.mean_overhead_ms);
  if (s.paused) {
    spdlog::error("capture: session {} paused: {}", s.session, s.pause_reason);
    spdlog::info("fix it, then resume with: armsig --db {} capture --lab {} --resume {}",
                 database.path(), o.lab, s.session);
    return kFailure;
  }
  if (s.stopped) {
    spdlog::warn("capture: stopped; resume with: armsig --db {} capture --lab {} --resume {}",
                 database.path(), o.lab, s.session);
    return kFailure;
  }
  return kOk;
}

void SetupCaptureCommand(CLI::App& parent, const GlobalOptions& global, Runner& run) {
  auto o = std::make_shared<CaptureCommandOptions>();
  auto* sub = parent.add_subcommand("capture", "Run a capture session with the lab's instruments");
  sub->add_option("--lab", o->lab, "Lab configuration YAML")->required();
  sub->add_option("--plan", o->plan, "PLAN.csv, auto:N (well spread) or single-joint:J:STEPS");
  sub->add_option("--robot", o->robot, "Robot name (created in the database if new)");
  sub->add_option("--resume", o->resume, "Continue this session where it stopped");
  sub->add_flag("--skip-on-fault", o->skip_on_fault,
                "Record a configuration whose instrument keeps failing as skipped and go on "
                "(default: pause)");
  sub->callback(
      [&run, &global, o] { run = [&global, o] { return RunCaptureCommand(*o, global); }; });
}

}  // namespace armsig::app
