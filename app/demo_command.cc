// armsig demo [--json OUT] [--configurations N] [--select M] [--robot puma|ur10|kuka|abb]
// [--instrument theodolites|tracker] [--resume SESSION]: the main
// job on the embedded default (demo/demo.h).
#include <fmt/format.h>
#include <spdlog/spdlog.h>
#include <unistd.h>

#include <cmath>
#include <iostream>

#include "app/command.h"
#include "demo/demo.h"

namespace armsig::app {

void SetupDemoCommand(CLI::App& parent, const GlobalOptions& global, Runner& run) {
  auto o = std::make_shared<demo::DemoOptions>();
  auto* sub = parent.add_subcommand(
      "demo", "The whole chain on a virtual lab: orientation, capture, reduction, calibration");
  OutputFile(sub->add_option("--json", o->json_path, "Write the demo's results as JSON"));
  NumberOption(sub->add_option("--configurations", o->configurations, "Configurations to capture"),
               1, kMaxPoses)
      ->capture_default_str();
  NumberOption(sub->add_option("--select", o->select,
                               "Configurations to fit (default, 0: 40 % of the configurations)"),
               0, kMaxPoses);
  NumberOption(sub->add_option("--resume", o->resume_session,
                               "Continue a stopped demo session: capture the rest, then calibrate"),
               1, kMaxId);
  ChoiceOption(sub->add_option("--robot", o->robot,
                               "The virtual robot: puma (a PUMA 760 with three theodolites or a "
                               "tracker; the default), ur10 (a UR10 and its controller over "
                               "RTDE, with a laser tracker), kuka (a KR 16-2 and its KR C4 "
                               "through a variable server, with a laser tracker) or abb (an IRB "
                               "4600 and its OmniCore over Robot Web Services 2.0, with a laser "
                               "tracker); --resume keeps the session's"),
               {"puma", "ur10", "kuka", "abb"});
  ChoiceOption(sub->add_option("--instrument", o->instrument,
                  "theodolites (three GeoCOM theodolites, oriented by mutual pointings; the "
                  "default) or tracker (one laser tracker speaking emScon on loopback TCP); "
                  "--resume keeps the session's"), {"theodolites", "tracker"});
  sub->add_option("--serve", o->serve_dir,
                  "Only start the virtual lab and keep it up in this folder (lab.yaml beside "
                  "its devices) for armsig capture by hand; nothing is captured")
      ->type_name("DIR");
  NumberOption(sub->add_option("--seconds", o->serve_seconds,
                               "With --serve: how long to serve (default: until Ctrl-C)"),
               0.0, 7 * 24 * 3600.0);
  NumberOption(sub->add_option("--seed", o->seed,
                               "The virtual lab's noise and plan (default: 1985 plus the demo "
                               "sessions already stored, so every run measures anew)"),
               0, 4294967295.0);
  sub->add_option("--change", o->changes,
                  "Plant a change in the virtual robot (repeatable), to rehearse the nightly "
                  "job: joint2_zero=0.02deg, link2_length=0.2mm, a parameter such as a3=-50um; "
                  "units mm, um, deg, mrad, urad, rad");
  NumberOption(sub->add_option("--setup", o->setup,
                               "Another day's set-up: the instruments set up anew at their N-th "
                               "place (0: the first day's), so the robot's base lies elsewhere in "
                               "their frame; the robot and its errors the same, the noise drawn "
                               "anew; to use a set fitted on one day on another's"),
               0, 1000)
      ->capture_default_str();
  NumberOption(sub->add_option("--repeatability-mm", o->repeatability_mm,
                               "The virtual robot's own repeatability: every move lands N(0, "
                               "sigma^2) per axis off, apart from the instruments' noise"),
               0.0, 10.0)
      ->capture_default_str();
  NumberOption(sub->add_option("--time-scale", o->time_scale,
                               "Multiplies every simulated latency and move time (default: the "
                               "robot's, puma 0.25, ur10 and kuka 0.02)"),
               0.0, 100.0);
  sub->add_flag("--on-the-move", o->on_the_move,
                "With --robot ur10: sweep well-spread waypoints without stopping while the "
                "tracker measures continuously on its own clock; the clocks' offset and drift "
                "estimated from the data (the JSON adds robot_time_s and sync)");
  NumberOption(sub->add_option("--waypoints", o->waypoints,
                               "With --on-the-move: the well-spread configurations swept through"),
               3, 10000)
      ->capture_default_str();
  NumberOption(sub->add_option("--clock-offset-ms", o->clock_offset_ms,
                               "With --on-the-move: the virtual tracker's clock offset from the "
                               "controller's (default: drawn from the seed, within ±250 ms)"),
               -1e7, 1e7);
  NumberOption(sub->add_option("--clock-drift-ppm", o->clock_drift_ppm,
                               "With --on-the-move: the virtual tracker's clock drift (default: "
                               "drawn from the seed, within ±30 ppm)"),
               -1000.0, 1000.0);
  sub->callback([&run, &global, o] {
    run = [&global, o] {
      demo::DemoOptions options = *o;
      options.db_path = global.DbPath();
      options.stop = &StopRequested();
      demo::DemoObserver observer;
      observer.say = [](const std::string& text) { std::cout << text << std::flush; };
      observer.progress = TerminalCaptureProgress(true);
      const auto result = demo::RunDemo(options, observer);
      if (observer.progress) std::cerr << "\r\x1b[K" << std::flush;  // a stopped capture's line
      if (result.completed) return kOk;
      if (!result.resume_hint.empty())
        spdlog::warn("demo: stopped; resume with: {}", result.resume_hint);
      return kStopped;
    };
  });
}

}  // namespace armsig::app
