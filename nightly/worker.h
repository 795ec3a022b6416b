// The nightly job as a queue: `schedule` enqueues one recalibration job per robot,
// any number of workers (threads, processes, machines) drain the queue, each job running
// nightly::Recalibrate with its gates, the outcome stored with the job (db/jobs.h).
//
// Where things live: the store (robots, sessions, parameter sets) is a SQLite file (workers
// on one machine) or a PostgreSQL database (workers on any number of machines); the queue is
// in the store by default, or in another armsig store (`queue`). On PostgreSQL the claims
// use row locks with SKIP LOCKED, and each run holds the robot's advisory lock.
//
// A server that goes away (restarted, stopped, cut off: db::IsInfrastructureFault) fails no
// job and ends no polling worker: a job whose store went away during its run is handed back
// to the queue (db::Requeue: the attempt not counted, the reason in its error column) and
// retried; a lost queue connection is opened again, waiting 0.5 s, 1 s, 2 s … up to 15 s
// between tries, and the outcome of a job that finished meanwhile is recorded then. A
// polling worker waits out any outage; with `once` it gives up after max_outage_s.
#pragma once

#include <atomic>
#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "db/connection.h"
#include "db/database.h"
#include "db/jobs.h"
#include "nightly/recalibrate.h"

namespace armsig::nightly {

// The queue of `queue`: an armsig store (a SQLite file or a postgresql:// URI), opened
// with `mode`.
class QueueConnection {
 public:
  // A queue's statements are short: on a server each has 15 s (db::OpenOptions).
  explicit QueueConnection(const std::string& queue,
                           db::OpenMode mode = db::OpenMode::kMustExist);
  db::Connection& operator*() { return database_.connection(); }
  db::Connection* operator->() { return &database_.connection(); }

 private:
  db::Database database_;
};

// The job's options as stored with it (options_json) and back. db_path, json_path and the
// report directory's per-robot subfolder are the worker's business, not stored.
std::string RecalibrateOptionsToJson(const RecalibrateOptions& options);
// Throws InputError naming `job` (its row of the jobs table) when the stored text is not
// such options (db/stored_json.h).
RecalibrateOptions RecalibrateOptionsFromJson(const std::string& json, int64_t job = 0);

struct ScheduleOptions {
  std::string store_db;        // the store of the robots (a file or a postgresql:// URI)
  std::string queue;           // "" = store_db
  std::vector<std::string> robots;  // or every robot of the store when `all`
  bool all = false;
  RecalibrateOptions recalibrate;  // passed through to every job
};
struct Scheduled {
  std::string robot;
  db::EnqueueResult job;
};
// Throws InputError for an unknown robot (nothing enqueued then).
std::vector<Scheduled> Schedule(const ScheduleOptions& options);

struct WorkerOptions {
  std::string store_db;  // the store of the robots and their data (file or URI)
  std::string queue;     // "" = store_db
  int jobs = 1;          // jobs run at once (threads, each with its own connections)
  bool once = false;     // stop when no job is claimable instead of polling
  double lease_s = 300;  // a claim's lease; heartbeats renew it every lease/3
  int max_attempts = 3;  // claims of a job whose workers vanished before it is failed
  double poll_s = 5;     // pause between looks at an empty queue (without `once`)
  // An outage of the queue's or the store's server longer than this ends the worker
  // (exit 1); < 0: never without `once`, 60 s with it.
  double max_outage_s = -1;
  const std::atomic<bool>* stop = nullptr;  // set: finish the current job, claim no more
  // Called after each job (from the worker's threads, serialised).
  std::function<void(const db::Job&)> on_finished;
  std::string worker_id;  // "" = host:pid
  void Check() const;     // throws InputError
};

struct WorkerSummary {
  int done = 0, rejected = 0, failed = 0;
  int lost = 0;  // finished after the lease was lost to another worker (not recorded)
  int interrupted = 0;  // attempts cut short by a server outage, the job queued again
  int reconnects = 0;   // queue connections opened again after a server outage
  bool stopped = false;
};
WorkerSummary RunWorker(const WorkerOptions& options);

// "host:pid".
std::string DefaultWorkerId();

}  // namespace armsig::nightly
