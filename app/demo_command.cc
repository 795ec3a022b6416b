// armsig demo [--json OUT] [--configurations N] [--select M] [--resume SESSION]: the main
// job on the embedded default (workflows/demo.h).
#include <fmt/format.h>
#include <spdlog/spdlog.h>
#include <unistd.h>

#include <atomic>
#include <cmath>
#include <csignal>
#include <iostream>

#include "app/command.h"
#include "io/atomic_file.h"
#include "workflows/demo.h"

namespace armsig::app {

namespace {

std::atomic<bool> g_demo_stop{false};

}  // namespace

struct DemoCommand {
  workflows::DemoOptions options;
  std::string json;
};

int RunDemo(DemoCommand c, const GlobalOptions& global) {
  c.options.db_path = global.DbPath();
  g_demo_stop = false;
  c.options.stop = &g_demo_stop;
  std::signal(SIGINT, [](int) {
    g_demo_stop = true;
    std::signal(SIGINT, SIG_DFL);  // a second Ctrl-C ends at once
  });
  // The handler stays until the process ends: a Ctrl-C after the work is done changes
  // nothing (the summary and the --json file are still written, exit as the work says).
  workflows::DemoObserver observer;
  observer.say = [](const std::string& text) { std::cout << text << std::flush; };
  const bool tty = ::isatty(STDERR_FILENO);
  observer.progress = [tty](const acquisition::Progress& p) {
    if (!tty) return;
    std::cerr << fmt::format("\r   capturing {}/{}  miss {}  ETA {:.0f} s   ", p.done, p.total,
                             std::isnan(p.last_miss_mm) ? std::string("-")
                                                        : fmt::format("{:.4f} mm", p.last_miss_mm),
                             p.eta_s)
              << (p.done == p.total ? "\r" + std::string(60, ' ') + "\r" : "") << std::flush;
  };
  const auto result = workflows::RunDemo(c.options, observer);
  if (!result.completed) {  // stopped by Ctrl-C
    if (result.session > 0) {
      spdlog::warn("demo: stopped; resume with: armsig --db {} demo --resume {} --time-scale {}{}",
                   ShellWord(AbsolutePath(c.options.db_path)), result.session, c.options.time_scale,
                   c.options.select ? fmt::format(" --select {}", c.options.select) : "");
    }
    return 130;
  }
  if (!c.json.empty()) io::WriteFileAtomically(c.json, result.json.dump(2) + "\n");
  return kOk;
}

void SetupDemoCommand(CLI::App& parent, const GlobalOptions& global, Runner& run) {
  auto c = std::make_shared<DemoCommand>();
  auto* sub = parent.add_subcommand(
      "demo", "The whole chain on a virtual lab: orientation, capture, reduction, calibration");
  OutputFile(sub->add_option("--json", c->json, "Write the demo's results as JSON"));
  sub->add_option("--configurations", c->options.configurations, "Configurations to capture")
      ->capture_default_str();
  sub->add_option("--select", c->options.select,
                  "Configurations to fit (default: 40 % of the configurations)");
  sub->add_option("--resume", c->options.resume_session,
                  "Continue a stopped demo session: capture the rest, then calibrate");
  sub->add_option("--time-scale", c->options.time_scale,
                  "Multiplies every simulated instrument latency")
      ->capture_default_str();
  sub->callback([&run, &global, c] { run = [&global, c] { return RunDemo(*c, global); }; });
}

}  // namespace armsig::app
