#include "nightly/worker.h"

#include <fmt/format.h>
#include <spdlog/spdlog.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <condition_variable>
#include <exception>
#include <filesystem>
#include <limits>
#include <mutex>
#include <nlohmann/json.hpp>
#include <thread>

#include "core/error.h"
#include "core/text.h"
#include "db/database.h"
#include "db/postgres_address.h"
#include "db/robots.h"
#include "db/stored_json.h"

namespace armsig::nightly {

namespace {

constexpr char kKind[] = "recalibrate";

// A robot's name as one folder name.
std::string FolderName(const std::string& robot) {
  std::string out;
  for (unsigned char c : robot) out += std::isalnum(c) || c == '-' || c == '_' ? char(c) : '_';
  return out.empty() || out == "." || out == ".." ? "robot" : out;
}

}  // namespace

namespace {

db::OpenOptions QueueOptions(db::OpenMode mode) {
  db::OpenOptions o;
  o.mode = mode;
  o.statement_timeout_ms = 15000;
  return o;
}

}  // namespace

QueueConnection::QueueConnection(const std::string& queue, db::OpenMode mode)
    : database_(queue, QueueOptions(mode)) {}

std::string RecalibrateOptionsToJson(const RecalibrateOptions& o) {
  nlohmann::json j = {{"since", o.since},
                      {"params", o.params},
                      {"residual_model", o.residual_model},
                      {"orientation", o.orientation},
                      {"tool_rotation", o.tool_rotation},
                      {"select", o.select},
                      {"report_dir", o.report_dir},
                      {"max_iterations", o.max_iterations},
                      {"lock_wait_s", o.lock_wait_s},
                      {"force", o.force}};
  auto optional = [&](const char* key, const std::optional<double>& v) {
    if (v) j[key] = *v;
  };
  optional("max_validation_mean_mm", o.max_validation_mean_mm);
  optional("max_validation_max_mm", o.max_validation_max_mm);
  optional("tolerance_mm", o.tolerance_mm);
  optional("drift_sigma", o.drift_sigma);
  optional("drift_mm", o.drift_mm);
  if (o.window_sessions) j["window_sessions"] = *o.window_sessions;
  if (o.window_days) j["window_days"] = *o.window_days;
  return JsonText(j);
}

RecalibrateOptions RecalibrateOptionsFromJson(const std::string& text, int64_t job) {
  RecalibrateOptions o;
  const db::JsonCell cell{"the queue", "jobs", job, "options_json"};
  db::ReadStoredJson(text, cell, [&](const nlohmann::json& j) {
    if (!j.is_object()) db::RefuseStoredJson(cell, "expected the job's options (an object)");
    o.since = j.value("since", o.since);
    o.params = j.value("params", o.params);
    o.residual_model = j.value("residual_model", o.residual_model);
    o.orientation = j.value("orientation", o.orientation);
    o.tool_rotation = j.value("tool_rotation", o.tool_rotation);
    o.select = j.value("select", o.select);
    o.report_dir = j.value("report_dir", o.report_dir);
    o.max_iterations = j.value("max_iterations", o.max_iterations);
    o.lock_wait_s = j.value("lock_wait_s", o.lock_wait_s);
    o.force = j.value("force", o.force);
    auto optional = [&](const char* key, std::optional<double>& v) {
      if (j.contains(key)) v = j.at(key).get<double>();
    };
    optional("max_validation_mean_mm", o.max_validation_mean_mm);
    optional("max_validation_max_mm", o.max_validation_max_mm);
    optional("tolerance_mm", o.tolerance_mm);
    optional("drift_sigma", o.drift_sigma);
    optional("drift_mm", o.drift_mm);
    if (j.contains("window_sessions")) o.window_sessions = j.at("window_sessions").get<int>();
    if (j.contains("window_days")) o.window_days = j.at("window_days").get<int>();
    return 0;
  });
  return o;
}

std::vector<Scheduled> Schedule(const ScheduleOptions& options) {
  std::vector<std::string> robots = options.robots;
  {
    db::Database store(options.store_db, db::OpenMode::kMustExist);
    if (options.all) {
      robots.clear();
      for (const auto& r : db::ListRobots(store)) robots.push_back(r.name);
    } else {
      for (const auto& robot : robots) {
        if (!db::FindRobotInUse(store, robot))  // a removed robot: refused, named
          throw InputError({store.path(), 0, 0, "--robot"},
                           "no robot named '" + robot + "' (see `armsig robot list`)");
      }
    }
  }
  // A queue apart from the store, on a server, is made there when new; a SQLite file must
  // exist (it is an armsig file: the store, or one made by `db init`).
  const std::string where = options.queue.empty() ? options.store_db : options.queue;
  QueueConnection queue(
      where, db::IsPostgresAddress(where) ? db::OpenMode::kCreate : db::OpenMode::kMustExist);
  const std::string json = RecalibrateOptionsToJson(options.recalibrate);
  std::vector<Scheduled> out;
  for (const auto& robot : robots) out.push_back({robot, db::Enqueue(*queue, kKind, robot, json)});
  return out;
}

std::string DefaultWorkerId() {
  char host[256] = {};
  if (::gethostname(host, sizeof host - 1) != 0) std::snprintf(host, sizeof host, "localhost");
  return fmt::format("{}:{}", host, ::getpid());
}

void WorkerOptions::Check() const {
  if (jobs < 1 || jobs > 256) throw InputError({"--jobs", 0, 0, ""}, "expected 1 to 256");
  if (!(lease_s >= 0.05) || lease_s > 86400)
    throw InputError({"--lease-s", 0, 0, ""}, "expected a lease of 0.05 s to one day");
  if (max_attempts < 1) throw InputError({"--max-attempts", 0, 0, ""}, "expected at least 1");
  if (!(poll_s > 0)) throw InputError({"--poll-s", 0, 0, ""}, "expected a positive pause");
}

namespace {

// Renews a job's lease every lease/3 from its own thread and connection while the work runs.
class HeartbeatThread {
 public:
  HeartbeatThread(const std::string& queue, const db::Job& job, const std::string& worker,
                  int64_t lease_ms)
      : thread_([this, queue, id = job.id, robot = job.robot, worker, lease_ms] {
          std::unique_ptr<QueueConnection> connection;
          std::unique_lock lock(mutex_);
          while (!done_) {
            cv_.wait_for(lock, std::chrono::milliseconds(std::max<int64_t>(lease_ms / 3, 10)));
            if (done_) break;
            try {
              if (!connection) connection = std::make_unique<QueueConnection>(queue);
              if (!db::Heartbeat(**connection, id, worker, lease_ms)) {
                spdlog::warn("worker: job {} ({}): the lease was lost to another worker", id,
                             robot);
                break;
              }
            } catch (const std::exception& e) {
              connection.reset();  // try a fresh connection at the next beat
              spdlog::warn("worker: job {} ({}): heartbeat failed: {}", id, robot, e.what());
            }
          }
        }) {}
  ~HeartbeatThread() {
    {
      std::lock_guard lock(mutex_);
      done_ = true;
    }
    cv_.notify_all();
    thread_.join();
  }

 private:
  std::mutex mutex_;
  std::condition_variable cv_;
  bool done_ = false;
  std::thread thread_;  // last: started after the members it uses
};

struct Outcome {
  db::JobState state = db::JobState::kFailed;
  std::string result_json, summary, error;
  std::optional<int64_t> version;
  bool interrupted = false;  // an infrastructure fault cut the attempt short (`error` says how)
};

Outcome RunJob(const WorkerOptions& options, const db::Job& job) {
  Outcome out;
  try {
    RecalibrateOptions o = RecalibrateOptionsFromJson(job.options_json, job.id);
    o.db_path = options.store_db;
    o.robot = job.robot;
    if (!o.report_dir.empty()) {
      o.report_dir = (std::filesystem::path(o.report_dir) / FolderName(job.robot)).string();
      std::filesystem::create_directories(o.report_dir);
    }
    // Per-robot exclusion: Recalibrate's own lock, where the store is (PostgreSQL: an
    // advisory lock of the server, so workers on any machine; SQLite: a file lock beside
    // the file, which workers on one machine share).
    const auto d = Recalibrate(o);
    out.state = d.passed() ? db::JobState::kDone : db::JobState::kRejected;
    out.result_json = JsonText(d.ToJson());
    out.summary = d.Describe();
    // A drift night is done (a set was stored) or rejected (drift suspected, nothing
    // stored); either way its summary leads with the drift line a person must see.
    if (const std::string line = d.DriftLine(); !line.empty()) out.summary = line;
    if (d.outcome == RecalibrationDecision::Outcome::kFailed) {
      out.state = db::JobState::kFailed;  // not retried: the same data fails the same way
      out.error = d.failure + (d.previous_version
                                   ? fmt::format("; version {} stays active", *d.previous_version)
                                   : std::string());
      out.summary = "failed";
    }
    if (d.version > 0) out.version = d.version;
  } catch (const std::exception& e) {
    out.error = e.what();
    // The store went away (or the run lost a race): the work is not at fault, and the job
    // is handed back to the queue rather than failed.
    out.interrupted = db::IsInfrastructureFault(e);
    out.state = db::JobState::kFailed;
    out.summary = "failed";
  }
  return out;
}

// A server outage as the worker rides it out: waits 0.5 s, 1 s, 2 s … up to 15 s between
// tries; ends the worker when the outage lasts longer than its limit.
class Outage {
 public:
  Outage(const WorkerOptions& options, std::function<bool()> stopping)
      : stopping_(std::move(stopping)),
        limit_s_(options.max_outage_s >= 0 ? options.max_outage_s
                 : options.once            ? 60.0
                                           : std::numeric_limits<double>::infinity()) {}

  // Waits before the next try; false when told to stop meanwhile. Throws when the outage
  // has lasted longer than the limit.
  bool Wait(const std::string& worker, const std::string& what) {
    const auto now = std::chrono::steady_clock::now();
    if (!since_) since_ = now;
    const double lasted = std::chrono::duration<double>(now - *since_).count();
    if (lasted > limit_s_) {
      throw std::runtime_error(fmt::format(
          "worker {}: giving up after a server outage of {:.0f} s (at most {:.0f} s with "
          "--once): {}",
          worker, lasted, limit_s_, what));
    }
    const double delay = std::min(15.0, 0.5 * std::pow(2.0, tries_++));
    spdlog::warn("worker {}: {}; trying again in {:.1f} s", worker, what, delay);
    const auto until = now + std::chrono::milliseconds(static_cast<int64_t>(delay * 1000));
    while (std::chrono::steady_clock::now() < until) {
      if (stopping_()) return false;
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
    }
    return !stopping_();
  }
  void Over() {
    since_.reset();
    tries_ = 0;
  }

 private:
  std::function<bool()> stopping_;
  double limit_s_;
  std::optional<std::chrono::steady_clock::time_point> since_;
  int tries_ = 0;
};

// Records a job's outcome in the queue and counts it (throws DatabaseError when the queue's
// server is gone: the caller records it again once it is back).
void RecordOutcome(db::Connection& queue, const std::string& worker, const db::Job& job,
                   const Outcome& outcome, const WorkerOptions& options, WorkerSummary& summary,
                   std::mutex& mutex) {
  if (outcome.interrupted) {
    const bool ours = db::Requeue(
        queue, job.id, worker,
        fmt::format("attempt {} was interrupted by the infrastructure, queued again: {}",
                    job.attempts, outcome.error));
    std::lock_guard lock(mutex);
    if (ours)
      ++summary.interrupted;
    else
      ++summary.lost;
    spdlog::warn("worker {}: job {} ({}): {}: {}", worker, job.id, job.robot,
                 ours ? "interrupted by the infrastructure, handed back to the queue"
                      : "interrupted, and its lease went to another worker meanwhile",
                 outcome.error);
    return;
  }
  const bool recorded = db::Finish(queue, job.id, worker, outcome.state, outcome.result_json,
                                   outcome.summary, outcome.error, outcome.version);
  const auto finished = db::FindJob(queue, job.id);
  std::lock_guard lock(mutex);
  if (!recorded) {
    ++summary.lost;
    spdlog::warn(
        "worker {}: job {} ({}): finished after its lease went to another worker; this "
        "run's outcome ({}) is not recorded with the job",
        worker, job.id, job.robot, db::ToString(outcome.state));
    return;
  }
  if (outcome.state == db::JobState::kDone) ++summary.done;
  if (outcome.state == db::JobState::kRejected) ++summary.rejected;
  if (outcome.state == db::JobState::kFailed) {
    ++summary.failed;
    spdlog::error("worker {}: job {} ({}) failed: {}", worker, job.id, job.robot, outcome.error);
  }
  if (options.on_finished && finished) options.on_finished(*finished);
}

}  // namespace

WorkerSummary RunWorker(const WorkerOptions& options) {
  options.Check();
  const std::string queue_name = options.queue.empty() ? options.store_db : options.queue;
  const std::string base_id = options.worker_id.empty() ? DefaultWorkerId() : options.worker_id;
  const auto lease_ms = static_cast<int64_t>(options.lease_s * 1000);
  auto stopping = [&] { return options.stop && options.stop->load(); };

  WorkerSummary summary;
  std::mutex mutex;  // summary, on_finished, error
  std::exception_ptr error;
  std::atomic<bool> abort{false};

  auto record = [&](db::Connection& queue, const std::string& worker, const db::Job& job,
                    const Outcome& outcome) {
    RecordOutcome(queue, worker, job, outcome, options, summary, mutex);
  };

  auto loop = [&](int index) {
    try {
      const std::string worker =
          options.jobs == 1 ? base_id : fmt::format("{}/{}", base_id, index + 1);
      // The first connection fails at once (a wrong address, a server that is not there);
      // a connection lost later is opened again.
      auto queue = std::make_unique<QueueConnection>(queue_name);
      Outage outage(options, [&] { return stopping() || abort; });
      std::optional<std::pair<db::Job, Outcome>> unrecorded;  // finished, not yet recorded
      while (!abort) {
        try {
          if (!queue) {
            queue = std::make_unique<QueueConnection>(queue_name);
            spdlog::info("worker {}: the queue {} answers again", worker,
                         db::StoreName(queue_name));
            std::lock_guard lock(mutex);
            ++summary.reconnects;
          }
          if (unrecorded) {
            record(**queue, worker, unrecorded->first, unrecorded->second);
            unrecorded.reset();
          }
          if (stopping()) break;
          std::optional<db::Job> job;
          try {
            // A lapsed-looking lease is watched before it is taken; a stop cuts the watch short.
            job = db::Claim(**queue, worker, lease_ms, options.max_attempts,
                            [&](std::chrono::milliseconds wait) {
                              const auto until = std::chrono::steady_clock::now() + wait;
                              while (!stopping() && !abort &&
                                     std::chrono::steady_clock::now() < until)
                                std::this_thread::sleep_for(std::chrono::milliseconds(20));
                              return !stopping() && !abort;
                            });
          } catch (const db::DatabaseError& e) {
            if (!e.transient()) throw;
            spdlog::debug("worker {}: claim lost a race, again: {}", worker, e.what());
            continue;
          }
          if (!job) {
            outage.Over();
            if (options.once) break;
            const auto until =
                std::chrono::steady_clock::now() +
                std::chrono::milliseconds(static_cast<int64_t>(options.poll_s * 1000));
            while (!stopping() && !abort && std::chrono::steady_clock::now() < until)
              std::this_thread::sleep_for(std::chrono::milliseconds(50));
            continue;
          }
          if (stopping()) {  // told to stop between the claim and the work: hand it back
            db::Release(**queue, job->id, worker);
            spdlog::info("worker {}: job {} ({}) handed back to the queue", worker, job->id,
                         job->robot);
            break;
          }
          spdlog::info("worker {}: job {}: recalibrate {} (attempt {})", worker, job->id,
                       job->robot, job->attempts);
          Outcome outcome;
          {
            HeartbeatThread heartbeat(queue_name, *job, worker, lease_ms);
            outcome = RunJob(options, *job);
          }
          unrecorded.emplace(*job, outcome);
          record(**queue, worker, *job, outcome);
          unrecorded.reset();
          if (!outcome.interrupted) {
            outage.Over();
          } else if (!outage.Wait(worker,
                                  "the store of job " + std::to_string(job->id) + " went away")) {
            break;
          }
        } catch (const db::DatabaseError& e) {
          if (!e.connection_lost()) throw;
          queue.reset();
          if (!outage.Wait(worker, std::string("the queue's server went away: ") + e.what())) {
            if (unrecorded) {
              spdlog::warn(
                  "worker {}: stopped before job {}'s outcome could be recorded; the "
                  "job is claimable again once its lease expires",
                  worker, unrecorded->first.id);
            }
            break;
          }
        }
      }
    } catch (...) {
      std::lock_guard lock(mutex);
      if (!error) error = std::current_exception();
      abort = true;
    }
  };

  std::vector<std::thread> threads;
  for (int k = 1; k < options.jobs; ++k) threads.emplace_back(loop, k);
  loop(0);
  for (auto& t : threads) t.join();
  if (error) std::rethrow_exception(error);
  summary.stopped = stopping();
  return summary;
}

}  // namespace armsig::nightly
