// The job queue of the nightly work: one row per job in a `jobs` table, written
// only through db::Connection so that the same statements run on SQLite (one machine) and
// PostgreSQL (any number of machines draining one server).
//
// Life of a job: Enqueue → queued; Claim → running, attempts + 1, a worker id (host:pid) and
// a lease; Heartbeat extends the lease while the work runs; Finish → done | rejected | failed
// with the result. A worker that vanishes (killed, machine gone) stops heartbeating: once its
// lease has expired the job is claimable again and the next claim counts another attempt;
// after `max_attempts` claims the job is failed instead of claimed. Release hands a claimed
// job back (a worker told to stop before it began the work) without counting the attempt;
// Requeue likewise when the attempt was cut short by the infrastructure (its store went
// away), with the reason.
//
// Claimers never take the same job: on PostgreSQL the candidate row is locked with
// `SELECT … FOR UPDATE SKIP LOCKED` inside the write transaction (concurrent claimers skip
// it and take the next); on SQLite the write transaction (BEGIN IMMEDIATE) serialises them.
//
// Times: integer milliseconds since the Unix epoch from the DATABASE SERVER's clock, written
// by SQL (`NowMsSql`), never by the client: leases are compared across machines, and one
// clock (the server's) makes them immune to the workers' clock skew. With SQLite the
// "server" is the local machine.
#pragma once

#include <chrono>
#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "db/connection.h"

namespace armsig::db {

enum class JobState { kQueued, kRunning, kDone, kFailed, kRejected };
std::string_view ToString(JobState state);
JobState ParseJobState(std::string_view text);  // throws DatabaseError for an unknown state

struct Job {
  int64_t id = 0;
  std::string kind;  // "recalibrate"
  std::string robot;
  std::string options_json;
  JobState state = JobState::kQueued;
  int attempts = 0;
  int64_t created_ms = 0;
  std::optional<int64_t> started_ms, finished_ms, lease_expires_ms;
  std::string worker;  // host:pid of the last claimer ("" when never claimed)
  std::string result_json, summary, error;
  std::optional<int64_t> version;  // the parameter set stored (or found up to date)
};

// The jobs table's DDL for `backend` (one text, the id column's type the only difference):
// schema migration v7 on both backends (db/schema.cc, kJobsMigration).
std::string JobsSchemaSql(Backend backend);

// The server clock in ms since the epoch, as SQL for `backend`.
std::string_view NowMsSql(Backend backend);
int64_t NowMs(Connection& connection);
// "2026-03-01T02:00:00.123Z" for a time in ms since the epoch (UTC).
std::string IsoUtcFromMs(int64_t ms);

struct EnqueueResult {
  int64_t id = 0;
  bool created = false;  // false: the robot already had a job queued or running (that one)
  JobState state = JobState::kQueued;
};
// One open (queued or running) job per kind and robot: a second Enqueue while one is open
// returns the open one (a partial unique index enforces it, also against concurrent callers).
EnqueueResult Enqueue(Connection& connection, const std::string& kind, const std::string& robot,
                      const std::string& options_json);

// How a claimer waits while it watches a lease (a test passes its own; the worker one that a
// stop request cuts short). Returns false when the claim is to be given up (stopping).
using LeaseWait = std::function<bool(std::chrono::milliseconds)>;
bool SleepFor(std::chrono::milliseconds wait);  // the default: sleeps, true

// The oldest claimable job, now running for `worker` with a lease of `lease_ms`; nullopt when
// there is none. Claimable: queued, or running with a lease that has lapsed — its worker's
// heartbeat count did not move while this claimer watched it for half the lease the worker
// asked for, on this process's monotonic clock (`wait`). Only a lease that looks expired by
// the server's clock (or lies impossibly far ahead of it: the clock stepped back) is watched,
// so a running job costs a claimer no wait; a step of the clock either way is survived: a
// live worker's count moves (it heartbeats every third of its lease), a vanished one's not.
// A job whose lease lapsed after `max_attempts` claims is marked failed instead (and the
// next one is looked at).
std::optional<Job> Claim(Connection& connection, const std::string& worker, int64_t lease_ms,
                         int max_attempts, const LeaseWait& wait = SleepFor);
// Extends the lease and counts the heartbeat; false when the job is no longer this worker's
// (its lease lapsed and another worker claimed it, or it was finished).
bool Heartbeat(Connection& connection, int64_t id, const std::string& worker, int64_t lease_ms);
// Records the outcome (state done, rejected or failed); false when the job is no longer this
// worker's (then nothing is written).
bool Finish(Connection& connection, int64_t id, const std::string& worker, JobState state,
            const std::string& result_json, const std::string& summary, const std::string& error,
            std::optional<int64_t> version);
// Hands a claimed job back to the queue without counting the attempt; false when not ours.
bool Release(Connection& connection, int64_t id, const std::string& worker);
// Hands a claimed job back after an infrastructure fault interrupted its attempt (its store
// went away; nightly/worker.h): queued again, the attempt not counted, `why` in the error
// column until the next claim. False when not ours.
bool Requeue(Connection& connection, int64_t id, const std::string& worker, const std::string& why);

// Every job, oldest first (at most `limit`, the newest of them, when limit > 0).
std::vector<Job> ListJobs(Connection& connection, int limit = 0);
std::optional<Job> FindJob(Connection& connection, int64_t id);

// Per-robot exclusion by the database: on PostgreSQL a session advisory lock
// (pg_advisory_lock on a 64-bit hash of the kind and robot) held for the object's life,
// so that two runs never work on the same robot at once whatever machine they are on
// (nightly::Recalibrate holds it on a PostgreSQL store); on SQLite nothing (Recalibrate
// takes its file lock beside the database file).
class RobotLock {
 public:
  // Waits up to `wait_s`; throws std::runtime_error when another holder keeps it longer.
  RobotLock(Connection& connection, const std::string& kind, const std::string& robot,
            int wait_s);
  ~RobotLock();
  RobotLock(const RobotLock&) = delete;
  RobotLock& operator=(const RobotLock&) = delete;
  static int64_t Key(const std::string& kind, const std::string& robot);

 private:
  Connection& connection_;
  int64_t key_ = 0;
  bool held_ = false;
};

}  // namespace armsig::db
