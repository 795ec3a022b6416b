// The nightly job as a queue through the binary, as a plant runs it: schedule, workers,
// the queue listed; a worker killed with SIGKILL mid-job and its job retried by another.
#include <fcntl.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <nlohmann/json.hpp>
#include <thread>

#include "calibration/synthetic.h"
#include "db/database.h"
#include "db/jobs.h"
#include "support/postgres_server.h"
#include "support/simulated_sessions.h"
#include "support/stores.h"
#include "test_support.h"
#include "nightly/worker.h"

namespace armsig::testing {
namespace {

using namespace std::chrono_literals;

nlohmann::json Jobs(const std::string& args) {
  const auto r = RunArmsig(args + " jobs --json");
  EXPECT_EQ(r.exit_code, 0) << r.err;
  return nlohmann::json::parse(r.out);
}

// The store (and the queue in it) on either backend: a SQLite file, or a PostgreSQL
// database that workers on any machine share.
class FleetCommands : public ::testing::TestWithParam<db::Backend> {
 protected:
  std::string NewStore() { return testing::NewStore(GetParam(), dir_, "lab"); }
  TempDir dir_;
};

TEST_P(FleetCommands, ScheduleAllThenTwoWorkersStoreEveryRobotOnce) {
  [[maybe_unused]] TempDir& dir = dir_;
  const std::string path = NewStore();
  {
    db::Database database(path);
    for (int k = 0; k < 3; ++k)
      AddSession(database, calibration::PaperTable3Parameters(), 120, 10 + k, 0.0, "",
                 "cell" + std::to_string(k + 1));
  }
  const std::string db = "--db '" + path + "'";
  auto r = RunArmsig(db + " schedule recalibrate --all --residual-model off --report-dir '" +
                     dir.path().string() + "'");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("recalibrate cell3 queued"), std::string::npos) << r.out;
  r = RunArmsig(db + " schedule recalibrate --robot cell2");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("already queued: not queued twice"), std::string::npos) << r.out;
  auto jobs = Jobs(db);
  ASSERT_EQ(jobs.size(), 3u);

  r = RunArmsig(db + " worker --jobs 2 --once");
  ASSERT_EQ(r.exit_code, 0) << r.err << r.out;
  EXPECT_EQ(Versions(path), 3);
  jobs = Jobs(db);
  ASSERT_EQ(jobs.size(), 3u);
  for (const auto& j : jobs) {
    EXPECT_EQ(j["state"], "done") << j.dump();
    EXPECT_EQ(j["attempts"], 1);
    EXPECT_EQ(j["version"], 1);
    EXPECT_EQ(j["result"]["robot"], j["robot"]);
    EXPECT_EQ(j["options"]["residual_model"], "off");
    EXPECT_TRUE(std::filesystem::exists(dir.path() / j["robot"].get<std::string>()))
        << "per-robot report folder";
  }
  // Nothing left: another worker has nothing to do; scheduling again queues anew.
  EXPECT_EQ(RunArmsig(db + " worker --once").exit_code, 0);
  EXPECT_EQ(RunArmsig(db + " schedule recalibrate --robot cell1 --residual-model off").exit_code,
            0);
  r = RunArmsig(db + " worker --once");
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("up to date"), std::string::npos) << r.out;
  EXPECT_EQ(Versions(path), 3);
  const auto text = RunArmsig(db + " jobs");
  EXPECT_NE(text.out.find("cell1"), std::string::npos) << text.out;
}

TEST_P(FleetCommands, UnknownRobotIsAnInputErrorAndNothingIsQueued) {
  const std::string path = NewStore();
  {
    db::Database database(path);
    AddSession(database, calibration::PaperTable3Parameters(), 60, 1);
  }
  const auto r = RunArmsig("--db '" + path + "' schedule recalibrate --robot puma --robot nope");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("nope"), std::string::npos) << r.err;
  EXPECT_EQ(Jobs("--db '" + path + "'").size(), 0u);
  EXPECT_EQ(RunArmsig("--db '" + path + "' schedule recalibrate").exit_code, 2);
}

// A worker killed with SIGKILL in the middle of a job: after the lease another worker
// claims it again (attempt 2), runs it, and the parameter set is stored once.
TEST_P(FleetCommands, AWorkerKilledMidJobIsRetriedByAnotherAndStoredOnce) {
  const std::string path = NewStore();
  {
    db::Database database(path);
    AddSession(database, calibration::PaperTable3Parameters(), 200, 5);
  }
  const std::string db = "--db '" + path + "'";
  ASSERT_EQ(RunArmsig(db + " schedule recalibrate --robot puma").exit_code, 0);

  const pid_t pid = ::fork();
  ASSERT_GE(pid, 0);
  if (pid == 0) {
    const int null = ::open("/dev/null", O_WRONLY);
    ::dup2(null, 1);
    ::dup2(null, 2);
    ::execl(ARMSIG_BINARY, ARMSIG_BINARY, "--db", path.c_str(), "worker", "--once", "--lease-s",
            "1", static_cast<char*>(nullptr));
    ::_exit(127);
  }
  // Kill it as soon as it holds the job.
  int ended = 0;
  const bool running = WaitForChildOr(pid, &ended, [&] {
    db::Database database(path, db::OpenMode::kMustExist);
    return database.connection().QueryInt(
               "SELECT count(*) FROM jobs WHERE state = 'running'") == 1;
  });
  ASSERT_TRUE(running);
  ::kill(pid, SIGKILL);
  int status = 0;
  ::waitpid(pid, &status, 0);
  ASSERT_TRUE(WIFSIGNALED(status));
  EXPECT_EQ(Versions(path), 0) << "killed before it stored anything";

  // Before the lease has expired there is nothing to take; after it, the job is retried.
  auto r = RunArmsig(db + " worker --once --lease-s 1");
  EXPECT_EQ(r.exit_code, 0) << r.err;
  std::this_thread::sleep_for(1200ms);
  r = RunArmsig(db + " worker --once --lease-s 1");
  ASSERT_EQ(r.exit_code, 0) << r.err << r.out;
  EXPECT_EQ(Versions(path), 1);
  const auto jobs = Jobs(db);
  ASSERT_EQ(jobs.size(), 1u);
  EXPECT_EQ(jobs[0]["state"], "done");
  EXPECT_EQ(jobs[0]["attempts"], 2);
  EXPECT_EQ(jobs[0]["version"], 1);
}

// SIGTERM (systemctl stop) while a polling worker runs a job: the job is finished and
// recorded, nothing more is claimed, exit 130.
TEST_P(FleetCommands, SigtermFinishesTheCurrentJobThenStops) {
  [[maybe_unused]] TempDir& dir = dir_;
  const std::string path = NewStore();
  {
    db::Database database(path);
    AddSession(database, calibration::PaperTable3Parameters(), 200, 9);
  }
  const std::string db = "--db '" + path + "'";
  ASSERT_EQ(RunArmsig(db + " schedule recalibrate --robot puma").exit_code, 0);
  // The worker's log tells when the job is under way: its "recalibrate" line comes after
  // the last point where a stop hands a claimed job back to the queue.
  const std::string log = dir.File("worker.log");
  const pid_t pid = ::fork();
  ASSERT_GE(pid, 0);
  if (pid == 0) {
    const int null = ::open("/dev/null", O_WRONLY);
    const int err = ::open(log.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    ::dup2(null, 1);
    ::dup2(err, 2);
    ::execl(ARMSIG_BINARY, ARMSIG_BINARY, "--db", path.c_str(), "worker", "--poll-s", "0.2",
            static_cast<char*>(nullptr));
    ::_exit(127);
  }
  int ended = 0;
  const bool started = WaitForChildOr(pid, &ended, [&] {
    return ReadText(log).find(": recalibrate puma (attempt 1)") != std::string::npos;
  });
  if (!started) ::kill(pid, SIGKILL);
  ASSERT_TRUE(started) << ReadText(log);
  ::kill(pid, SIGTERM);
  int status = 0;
  ::waitpid(pid, &status, 0);
  ASSERT_TRUE(WIFEXITED(status)) << status;
  EXPECT_EQ(WEXITSTATUS(status), 130);
  const auto jobs = Jobs(db);
  ASSERT_EQ(jobs.size(), 1u);
  EXPECT_EQ(jobs[0]["state"], "done");
  EXPECT_EQ(jobs[0]["attempts"], 1);
  EXPECT_EQ(Versions(path), 1);
}

ARMSIG_BOTH_BACKENDS(FleetCommands);

// The queue apart from the store, on the server (a cell's SQLite store, a plant's queue):
// claims with SKIP LOCKED; `jobs` reads it from --db too.
TEST(FleetQueueApart, TheQueueOnPostgresDrainsLikeTheSqliteOne) {
  TempDir dir;
  const std::string path = dir.File("lab.db");
  {
    db::Database database(path);
    AddSession(database, calibration::PaperTable3Parameters(), 100, 7, 0.0, "", "a");
    AddSession(database, calibration::PaperTable3Parameters(), 100, 8, 0.0, "", "b");
  }
  const std::string uri = PostgresServer::Shared().NewDatabase("fleet_queue");
  const std::string args = "--db '" + path + "' --queue '" + uri + "'";
  auto r = RunArmsig("--db '" + path +
                     "' schedule recalibrate --all --residual-model off --queue '" + uri + "'");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  r = RunArmsig("--db '" + path + "' worker --jobs 2 --once --queue '" + uri + "'");
  ASSERT_EQ(r.exit_code, 0) << r.err << r.out;
  EXPECT_EQ(Versions(path), 2);
  // `jobs` reads the queue from --db when it is the server's URI.
  const auto jobs = Jobs("--db '" + uri + "'");
  ASSERT_EQ(jobs.size(), 2u);
  for (const auto& j : jobs) EXPECT_EQ(j["state"], "done") << j.dump();
  // The server's database is an armsig store of its own (only its queue is used).
  r = RunArmsig("--db '" + uri + "' robot list");
  EXPECT_EQ(r.exit_code, 0) << r.err;
}

}  // namespace
}  // namespace armsig::testing

namespace armsig::testing {

// A cell's demo database (three theodolites: observations, station set-ups, points) pushed
// to a central file twice: the same observations there, once; a robot of another model
// of the same name on the target is exit 2 naming it.
class DbPushCommand : public ::testing::TestWithParam<db::Backend> {};

TEST_P(DbPushCommand, PushesADemoCellOnceAndRefusesAnotherModel) {
  TempDir dir;
  const std::string cell = dir.File("cell.db"), central = NewStore(GetParam(), dir, "central");
  ASSERT_EQ(RunArmsig("--db '" + cell + "' demo --configurations 30 --time-scale 0").exit_code, 0);
  const std::string push = "--db '" + cell + "' db push --to '" + central + "'";
  auto r = RunArmsig(push);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("pushed 1 session (30 poses, 90 observations, 30 points)"),
            std::string::npos)
      << r.out;
  r = RunArmsig(push);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("pushed 0 sessions"), std::string::npos) << r.out;
  // Every reading, with its station's code, the same on both sides (ids differ).
  const std::string readings =
      "SELECT s.code, o.point, o.hz_rad, o.v_rad, o.face, p.seq FROM observations o JOIN "
      "stations s ON s.id = o.station_id JOIN poses p ON p.id = o.pose_id ORDER BY p.seq, "
      "s.code, o.face, o.hz_rad";
  auto rows = [&](const std::string& path) {
    db::Database database(path, db::OpenMode::kMustExist);
    auto q = database.connection().Prepare(readings);
    std::vector<std::string> out;
    while (q->Step()) {
      out.push_back(q->Text(0) + " " + q->Text(1) + " " + std::to_string(q->Double(2)) + " " +
                    std::to_string(q->Double(3)) + " " + std::to_string(q->Int(4)) + " " +
                    std::to_string(q->Int(5)));
    }
    return out;
  };
  const auto there = rows(central);
  EXPECT_EQ(there.size(), 90u);
  EXPECT_EQ(there, rows(cell));

  const std::string other = NewStore(GetParam(), dir, "other");
  {
    db::Database database(other);
    database.connection().Exec(
        "INSERT INTO robots(name, model_name, model_yaml) VALUES ('puma760-demo', 'x', 'x')");
  }
  r = RunArmsig("--db '" + cell + "' db push --to '" + other + "'");
  EXPECT_EQ(r.exit_code, 2) << r.err;
  EXPECT_NE(r.err.find("robot puma760-demo has another model"), std::string::npos) << r.err;
}

ARMSIG_BOTH_BACKENDS(DbPushCommand);

}  // namespace armsig::testing
