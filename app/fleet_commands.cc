// armsig schedule recalibrate (--robot NAME… | --all) [recalibrate options] [--queue URI]
// armsig worker [--jobs N] [--once] [--lease-s S] [--queue URI]
// armsig jobs [--json] [--queue URI]
// The nightly job as a queue (nightly/worker.h); exit codes as docs/reference/cli.md.
#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <iostream>
#include <mutex>
#include <nlohmann/json.hpp>

#include "app/command.h"
#include "core/text.h"
#include "core/text_layout.h"
#include "core/wording.h"
#include "db/postgres_address.h"
#include "db/stored_json.h"
#include "nightly/worker.h"

namespace armsig::app {

namespace {

constexpr char kQueueHelp[] =
    "Where the queue lives: a postgresql:// URI or key/value string (credentials from libpq's "
    "environment, ~/.pgpass or a service file) or a SQLite file (default: the --db file)";

struct ScheduleCommand {
  nightly::ScheduleOptions options;
};

struct WorkerCommand {
  nightly::WorkerOptions options;
};

struct JobsCommand {
  std::string queue;
  bool json = false;
  int limit = 0;
};

std::string Time(const std::optional<int64_t>& ms) {
  return ms ? db::IsoUtcFromMs(*ms) : std::string();
}

std::string QueueName(const std::string& queue) { return db::StoreName(queue); }

// A job as JSON; its stored options and result are input (db/stored_json.h).
nlohmann::json JobJson(const db::Job& j, const std::string& queue) {
  auto optional_time = [](const std::optional<int64_t>& ms) {
    return ms ? nlohmann::json(db::IsoUtcFromMs(*ms)) : nlohmann::json();
  };
  nlohmann::json out = {{"id", j.id},
                        {"kind", j.kind},
                        {"robot", j.robot},
                        {"state", db::ToString(j.state)},
                        {"attempts", j.attempts},
                        {"worker", j.worker.empty() ? nlohmann::json() : nlohmann::json(j.worker)},
                        {"created", db::IsoUtcFromMs(j.created_ms)},
                        {"started", optional_time(j.started_ms)},
                        {"finished", optional_time(j.finished_ms)},
                        {"lease_expires", optional_time(j.lease_expires_ms)},
                        {"version", j.version ? nlohmann::json(*j.version) : nlohmann::json()},
                        {"summary", j.summary.empty() ? nlohmann::json() : nlohmann::json(j.summary)},
                        {"error", j.error.empty() ? nlohmann::json() : nlohmann::json(j.error)}};
  out["options"] =
      db::ParseStoredJson(j.options_json, {QueueName(queue), "jobs", j.id, "options_json"});
  out["result"] =
      db::ParseStoredJson(j.result_json, {QueueName(queue), "jobs", j.id, "result_json"});
  return out;
}

int RunSchedule(ScheduleCommand c, const GlobalOptions& global) {
  c.options.store_db = global.DbPath();
  if (c.options.queue.empty()) c.options.queue = c.options.store_db;
  const auto scheduled = nightly::Schedule(c.options);
  if (scheduled.empty()) {
    std::cout << fmt::format("no robots in {}: nothing scheduled\n",
                             Printable(QueueName(c.options.store_db)));
    return kOk;
  }
  for (const auto& s : scheduled) {
    if (s.job.created)
      std::cout << fmt::format("job {}: recalibrate {} queued\n", s.job.id, Printable(s.robot));
    else
      std::cout << fmt::format("job {}: recalibrate {} is already {}: not queued twice\n", s.job.id,
                               Printable(s.robot), db::ToString(s.job.state));
  }
  const auto queued = std::count_if(scheduled.begin(), scheduled.end(),
                                    [](const nightly::Scheduled& s) { return s.job.created; });
  spdlog::info("schedule: {} queued, {} already open, in {}", queued,
               static_cast<long>(scheduled.size()) - queued, QueueName(c.options.queue));
  return kOk;
}

int RunWorkerCommand(WorkerCommand c, const GlobalOptions& global) {
  c.options.store_db = global.DbPath();
  c.options.stop = &StopRequested();
  std::mutex print;
  c.options.on_finished = [&print](const db::Job& j) {
    std::lock_guard lock(print);
    std::cout << fmt::format(
                     "job {}: {}: {}{}\n", j.id, Printable(j.robot), db::ToString(j.state),
                     j.summary.empty() || j.summary == "failed" ? "" : " — " + Printable(j.summary))
              << std::flush;
  };
  const auto s = nightly::RunWorker(c.options);
  spdlog::info("worker: {} done, {} rejected, {} failed{}{}{}", s.done, s.rejected, s.failed,
               s.lost ? fmt::format(", {} lost to other workers", s.lost) : "",
               s.interrupted ? fmt::format(", {} attempts interrupted by server outages and "
                                           "queued again",
                                           s.interrupted)
                             : "",
               s.stopped ? "; stopped on request" : "");
  if (s.stopped) return kStopped;
  if (s.failed) return kFailure;
  if (s.rejected) return kQualityGate;
  return kOk;
}

int RunJobs(const JobsCommand& c, const GlobalOptions& global) {
  const std::string queue = c.queue.empty() ? global.DbPath() : c.queue;
  nightly::QueueConnection connection(queue, db::OpenMode::kReadOnly);
  const auto jobs = db::ListJobs(*connection, c.limit);
  if (c.json) {
    nlohmann::json out = nlohmann::json::array();
    for (const auto& j : jobs) out.push_back(JobJson(j, queue));
    std::cout << JsonText(out, 2) << "\n";
    return kOk;
  }
  if (jobs.empty()) {
    std::cout << fmt::format("no jobs in {}\n", Printable(QueueName(queue)));
    return kOk;
  }
  // A job a line (within 100 columns), its worker and result after it when they fit, else on
  // the next line.
  std::cout << fmt::format("{:>5}  {:<16} {:<9} {:>3}  {:<20} {:<20} {}\n", "id", "robot", "state",
                           "try", "created", "finished", "worker: result");
  for (const auto& j : jobs) {
    std::string result = j.error.empty() ? j.summary : j.error;
    if (j.state == db::JobState::kRunning && j.lease_expires_ms)
      result = "lease until " + Time(j.lease_expires_ms);
    const std::string line = fmt::format(
        "{:>5}  {:<16} {:<9} {:>3}  {:<20} {:<20}", j.id, Printable(j.robot), db::ToString(j.state),
        j.attempts, TimeToTheSecond(Time(j.created_ms)), TimeToTheSecond(Time(j.finished_ms)));
    std::string more = Printable(result);
    if (!j.worker.empty()) more = Printable(j.worker) + ": " + more;
    if (more.empty()) {
      std::cout << line << "\n";
    } else if (DisplayWidth(line) + 1 + DisplayWidth(more) <= 100) {
      std::cout << line << " " << more << "\n";
    } else {
      std::cout << line << "\n" << WrapLines("       " + more, 100, 2) << "\n";
    }
  }
  return kOk;
}

}  // namespace

void SetupFleetCommands(CLI::App& parent, const GlobalOptions& global, Runner& run) {
  {
    auto c = std::make_shared<ScheduleCommand>();
    auto& o = c->options;
    auto& r = o.recalibrate;
    auto* schedule = parent.add_subcommand("schedule", "Put work into the queue (the fleet)");
    schedule->require_subcommand(1);
    auto* sub = schedule->add_subcommand(
        "recalibrate", "Queue one recalibration job per robot (a robot already queued or "
                       "running is not queued twice)");
    auto* robot = NameOption(sub->add_option("--robot", o.robots, "Robot name (repeatable)"));
    auto* all = sub->add_flag("--all", o.all, "Every robot of the database");
    robot->excludes(all);
    AddRecalibrateOptions(*sub, r);
    OutputDirectory(sub->add_option("--report-dir", r.report_dir,
                                    "Each robot's HTML report into DIR/ROBOT (as the worker sees "
                                    "the path)"));
    StoreOption(sub->add_option("--queue", o.queue, kQueueHelp));
    sub->callback([&run, &global, c, robot, all, sub] {
      if (robot->count() == 0 && all->count() == 0)
        throw CLI::RequiredError(sub->get_name() + ": --robot NAME or --all");
      run = [&global, c] { return RunSchedule(*c, global); };
    });
  }
  {
    auto c = std::make_shared<WorkerCommand>();
    auto& o = c->options;
    auto* sub = parent.add_subcommand(
        "worker", "Take jobs from the queue and run them (any number of workers at once)");
    sub->add_option("--jobs", o.jobs, "Jobs run at once by this process")
        ->check(CLI::Range(1, 256))
        ->capture_default_str();
    sub->add_flag("--once", o.once, "Stop when the queue is empty instead of polling");
    NumberOption(sub->add_option("--lease-s", o.lease_s,
                                 "Lease of a claimed job (renewed every third of it; a job whose "
                                 "worker vanished is claimable again after it)"),
                 0.5, 7.0 * 24 * 3600)
        ->capture_default_str();
    sub->add_option("--max-attempts", o.max_attempts,
                    "Claims of a job whose workers vanished before it is failed")
        ->check(CLI::Range(1, 100))
        ->capture_default_str();
    NumberOption(sub->add_option("--poll-s", o.poll_s, "Pause between looks at an empty queue"),
                 0.01, 3600.0)
        ->capture_default_str();
    StoreOption(sub->add_option("--queue", o.queue, kQueueHelp));
    sub->callback([&run, &global, c] { run = [&global, c] { return RunWorkerCommand(*c, global); }; });
  }
  {
    auto c = std::make_shared<JobsCommand>();
    auto* sub = parent.add_subcommand("jobs", "The queue: every job, its state and result");
    sub->add_flag("--json", c->json, "Machine-readable output");
    sub->add_option("--limit", c->limit, "Only the newest N jobs")->check(CLI::Range(0, 1000000));
    StoreOption(sub->add_option("--queue", c->queue, kQueueHelp));
    OnlyReads(sub);
    sub->callback([&run, &global, c] { run = [&global, c] { return RunJobs(*c, global); }; });
  }
}

}  // namespace armsig::app
