#include "workflows/worker.h"

#include <fmt/format.h>
#include <spdlog/spdlog.h>
#include <unistd.h>

#include <chrono>
#include <condition_variable>
#include <exception>
#include <filesystem>
#include <mutex>
#include <nlohmann/json.hpp>
#include <thread>

#include "core/text.h"
#include "core/error.h"
#include "db/database.h"
#include "db/postgres_connection.h"
#include "db/robots.h"
#include "db/stored_json.h"

namespace armsig::workflows {

namespace {

constexpr char kKind[] = "recalibrate";

// A robot's name as one folder name.
std::string FolderName(const std::string& robot) {
  std::string out;
  for (unsigned char c : robot) out += std::isalnum(c) || c == '-' || c == '_' ? char(c) : '_';
  return out.empty() || out == "." || out == ".." ? "robot" : out;
}

}  // namespace

QueueConnection::QueueConnection(const std::string& queue, db::OpenMode mode)
    : database_(queue, mode) {}

std::string RecalibrateOptionsToJson(const RecalibrateOptions& o) {
  nlohmann::json j = {{"since", o.since},
                      {"params", o.params},
                      {"residual_model", o.residual_model},
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
        if (!db::FindRobot(store, robot))
          throw InputError({options.store_db, 0, 0, "--robot"},
                           "no robot named '" + robot + "' (see `armsig robot list`)");
      }
    }
  }
  // A queue apart from the store, on a server, is made there when new; a SQLite file must
  // exist (it is an armsig file: the store, or one made by `db init`).
  const std::string where = options.queue.empty() ? options.store_db : options.queue;
  QueueConnection queue(where, db::IsPostgresUri(where) ? db::OpenMode::kCreate
                                                        : db::OpenMode::kMustExist);
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
    out.state = db::JobState::kFailed;
    out.error = e.what();
    out.summary = "failed";
  }
  return out;
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

  auto loop = [&](int index) {
    try {
      const std::string worker =
          options.jobs == 1 ? base_id : fmt::format("{}/{}", base_id, index + 1);
      QueueConnection queue(queue_name);
      while (!stopping() && !abort) {
        std::optional<db::Job> job;
        try {
          job = db::Claim(*queue, worker, lease_ms, options.max_attempts);
        } catch (const db::DatabaseError& e) {
          if (!e.transient()) throw;
          spdlog::debug("worker {}: claim lost a race, again: {}", worker, e.what());
          continue;
        }
        if (!job) {
          if (options.once) break;
          const auto until = std::chrono::steady_clock::now() +
                             std::chrono::milliseconds(static_cast<int64_t>(options.poll_s * 1000));
          while (!stopping() && !abort && std::chrono::steady_clock::now() < until)
            std::this_thread::sleep_for(std::chrono::milliseconds(50));
          continue;
        }
        if (stopping()) {  // told to stop between the claim and the work: hand it back
          db::Release(*queue, job->id, worker);
          spdlog::info("worker {}: job {} ({}) handed back to the queue", worker, job->id,
                       job->robot);
          break;
        }
        spdlog::info("worker {}: job {}: recalibrate {} (attempt {})", worker, job->id, job->robot,
                     job->attempts);
        Outcome outcome;
        {
          HeartbeatThread heartbeat(queue_name, *job, worker, lease_ms);
          outcome = RunJob(options, *job);
        }
        const bool recorded = db::Finish(*queue, job->id, worker, outcome.state,
                                         outcome.result_json, outcome.summary, outcome.error,
                                         outcome.version);
        const auto finished = db::FindJob(*queue, job->id);
        std::lock_guard lock(mutex);
        if (!recorded) {
          ++summary.lost;
          spdlog::warn(
              "worker {}: job {} ({}): finished after its lease went to another worker; this "
              "run's outcome ({}) is not recorded with the job",
              worker, job->id, job->robot, db::ToString(outcome.state));
          continue;
        }
        if (outcome.state == db::JobState::kDone) ++summary.done;
        if (outcome.state == db::JobState::kRejected) ++summary.rejected;
        if (outcome.state == db::JobState::kFailed) {
          ++summary.failed;
          spdlog::error("worker {}: job {} ({}) failed: {}", worker, job->id, job->robot,
                        outcome.error);
        }
        if (options.on_finished && finished) options.on_finished(*finished);
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

}  // namespace armsig::workflows
