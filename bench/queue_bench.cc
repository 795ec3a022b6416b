// Throughput of the job queue (db/jobs.h), run by hand:
//   build/bench/queue_bench                      claims/s on SQLite and PostgreSQL
//   build/bench/queue_bench --benchmark_filter=Worker   end to end on simulated robots
// Claims: every claim is a write transaction (claim + finish, as a worker does), by 1 or 4
// threads with their own connections. PostgreSQL: a server of the bench's own (the tests'
// support/postgres_server, initdb into a temporary directory, Unix socket).
// Worker: nightly::RunWorker on 24 simulated PUMA 760 robots (120 configurations each),
// 1 vs 2 worker threads (force: every iteration refits; the residual map off).
#include <benchmark/benchmark.h>
#include <unistd.h>

#include <atomic>
#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>
#include <thread>

#include "calibration/synthetic.h"
#include <spdlog/spdlog.h>

#include "db/jobs.h"
#include "db/postgres_connection.h"
#include "db/store.h"
#include "io/model_yaml.h"
#include "support/postgres_server.h"
#include "nightly/worker.h"

namespace armsig {
namespace {

std::string TempPath(const std::string& name) {
  return (std::filesystem::temp_directory_path() /
          ("armsig-queue-bench-" + std::to_string(::getpid()) + "-" + name))
      .string();
}

std::string Queue(bool postgres, const std::string& name) {
  if (postgres) return testing::PostgresServer::Shared().NewDatabase(name);
  const std::string path = TempPath(name + ".db");
  std::filesystem::remove(path);
  db::Database create(path);
  return path;
}

// Claims per second: `threads` claimers drain jobs (claim + finish each).
void Claims(benchmark::State& state, bool postgres) {
  const int threads = static_cast<int>(state.range(0));
  static int n = 0;
  const std::string queue = Queue(postgres, "claims_" + std::to_string(++n));
  constexpr int kBatch = 1000;
  int64_t claimed = 0;
  for (auto _ : state) {
    state.PauseTiming();
    {
      nightly::QueueConnection q(queue);
      for (int k = 0; k < kBatch; ++k)
        db::Enqueue(*q, "recalibrate", "r" + std::to_string(claimed + k), "{}");
    }
    std::vector<std::unique_ptr<nightly::QueueConnection>> connections;
    for (int t = 0; t < threads; ++t)
      connections.push_back(std::make_unique<nightly::QueueConnection>(queue));
    std::atomic<int64_t> count{0};
    state.ResumeTiming();
    std::vector<std::thread> pool;
    for (int t = 0; t < threads; ++t) {
      pool.emplace_back([&, t] {
        auto& q = *connections[t];
        const std::string worker = "bench:" + std::to_string(t);
        while (auto job = db::Claim(*q, worker, 60000, 3)) {
          db::Finish(*q, job->id, worker, db::JobState::kDone, "{}", "ok", "", 1);
          ++count;
        }
      });
    }
    for (auto& t : pool) t.join();
    claimed += count;
  }
  state.SetItemsProcessed(claimed);
  state.counters["claims_per_s"] =
      benchmark::Counter(static_cast<double>(claimed), benchmark::Counter::kIsRate);
}

void BM_ClaimsSqlite(benchmark::State& state) { Claims(state, false); }
void BM_ClaimsPostgres(benchmark::State& state) { Claims(state, true); }
BENCHMARK(BM_ClaimsSqlite)->Arg(1)->Arg(4)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_ClaimsPostgres)->Arg(1)->Arg(4)->Unit(benchmark::kMillisecond)->UseRealTime();

std::string ReadText(const std::string& path) {
  std::ifstream in(path);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

// A robot with one simulated session of `count` configurations (as the tests' AddSession).
void AddRobot(db::Database& db, const std::string& name, int count, unsigned seed) {
  const std::string yaml = ReadText(std::string(ARMSIG_SOURCE_DIR) + "/models/puma760.yaml");
  const auto model = io::ParseRobotModel(yaml, "puma760.yaml");
  std::mt19937 rng(seed);
  const auto truth = calibration::PaperTable3Parameters();
  const auto poses =
      calibration::SimulatePoses(model, Eigen::Isometry3d::Identity(), truth,
                                 calibration::LabTestConfigurations(model, rng), 0.01, rng);
  db::WriteTransaction tx(db);
  const int64_t robot = db::EnsureRobot(db, name, "puma760", yaml);
  const int64_t session = db::CreateSession(db, robot, "", "", db::SessionState::kCompleted, "bench");
  for (int i = 0; i < count && i < static_cast<int>(poses.size()); ++i) {
    const int64_t pose =
        db::InsertPose(db, session, i, poses[i].id, poses[i].joints_rad, "measured", 1);
    db::PointRow point;
    point.pose_id = pose;
    point.point = "target";
    point.position_mm = poses[i].target_in_world;
    point.covariance_mm2 = Eigen::Matrix3d::Constant(NAN);  // not known
    point.rays = 3;
    db::InsertPoint(db, session, point);
  }
  tx.commit();
}

// End to end: `robots` simulated robots recalibrated by a worker with range(0) threads.
void BM_Worker(benchmark::State& state) {
  const int threads = static_cast<int>(state.range(0));
  constexpr int kRobots = 24;
  spdlog::set_level(spdlog::level::warn);
  const std::string path = TempPath("worker-" + std::to_string(threads) + ".db");
  for (const char* suffix : {"", "-wal", "-shm"}) std::filesystem::remove(path + suffix);
  {
    db::Database db(path);
    for (int k = 0; k < kRobots; ++k) AddRobot(db, "r" + std::to_string(k), 120, 100 + k);
  }
  int64_t jobs = 0, failed = 0;
  for (auto _ : state) {
    state.PauseTiming();
    nightly::ScheduleOptions schedule;
    schedule.store_db = path;
    schedule.all = true;
    schedule.recalibrate.residual_model = "off";
    schedule.recalibrate.force = true;  // refit every time: the same work each iteration
    nightly::Schedule(schedule);
    state.ResumeTiming();
    nightly::WorkerOptions worker;
    worker.store_db = path;
    worker.jobs = threads;
    worker.once = true;
    const auto s = nightly::RunWorker(worker);
    jobs += s.done + s.rejected + s.failed;
    failed += s.failed;
  }
  state.counters["failed"] = static_cast<double>(failed);
  state.counters["jobs"] = static_cast<double>(jobs);
  state.counters["jobs_per_s"] =
      benchmark::Counter(static_cast<double>(jobs), benchmark::Counter::kIsRate);
}
BENCHMARK(BM_Worker)->Arg(1)->Arg(2)->Unit(benchmark::kSecond)->UseRealTime()->Iterations(1);

}  // namespace
}  // namespace armsig

BENCHMARK_MAIN();
