// The fleet's figures, run by hand on a PostgreSQL server of the bench's own
// (the tests' support/postgres_server: initdb into a temporary directory, Unix socket,
// fsync off — an upper bound for a real server) and on SQLite files:
//   build/bench/fleet_bench --benchmark_filter=Nightly   1,000 robots × 200 configurations
//                                                        recalibrated by 1, 2 and 4 workers
//   build/bench/fleet_bench --benchmark_filter=Writers   20 capture writers at once
//   build/bench/fleet_bench --benchmark_filter=Push      db push of 100,000 observations
// Every figure is checked where it is made: the jobs all done, every written row stored
// once, the pushed store holding every observation.
#include <benchmark/benchmark.h>
#include <spdlog/spdlog.h>
#include <unistd.h>

#include <atomic>
#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>
#include <thread>

#include "calibration/synthetic.h"
#include "db/push.h"
#include "db/store.h"
#include "io/model_yaml.h"
#include "support/postgres_server.h"
#include "nightly/worker.h"

namespace armsig {
namespace {

std::string TempPath(const std::string& name) {
  return (std::filesystem::temp_directory_path() /
          ("armsig-fleet-bench-" + std::to_string(::getpid()) + "-" + name))
      .string();
}

// A new store: a database on the bench's PostgreSQL server, or a new SQLite file.
std::string NewStore(bool postgres, const std::string& name) {
  if (postgres) return testing::PostgresServer::Shared().NewDatabase(name);
  const std::string path = TempPath(name + ".db");
  for (const char* suffix : {"", "-wal", "-shm"}) std::filesystem::remove(path + suffix);
  return path;
}

std::string ReadText(const std::string& path) {
  std::ifstream in(path);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

const std::string& PumaYaml() {
  static const std::string yaml = ReadText(std::string(ARMSIG_SOURCE_DIR) + "/models/puma760.yaml");
  return yaml;
}

// One configuration as a capture stores it: the pose, three theodolite readings, the
// reduced point; one transaction.
void StoreConfiguration(db::Database& db, int64_t session, int seq, const MeasuredPose& pose) {
  db::WriteTransaction tx(db);
  const int64_t id = db::InsertPose(db, session, seq, pose.id, pose.joints_rad, "measured", 1);
  std::vector<db::ObservationRow> rows;
  for (const char* station : {"S1", "S2", "S3"}) {
    db::ObservationRow o;
    o.pose_id = id;
    o.point = "target";
    o.station = station;
    o.reading.hz_rad = 0.1 * seq;
    o.reading.v_rad = 1.5;
    o.reading.face = 1;
    rows.push_back(o);
  }
  db::InsertObservations(db, session, rows);
  db::PointRow p;
  p.pose_id = id;
  p.point = "target";
  p.position_mm = pose.target_in_world;
  p.covariance_mm2 = Eigen::Matrix3d::Identity() * 1e-4;
  p.rays = 3;
  db::InsertPoint(db, session, p);
  tx.commit();
}

// `robots` simulated PUMA 760s with one finished session of `configurations` each.
void AddRobots(db::Database& db, int robots, int configurations) {
  const auto model = io::ParseRobotModel(PumaYaml(), "puma760.yaml");
  const auto truth = calibration::PaperTable3Parameters();
  {
    db::WriteTransaction tx(db);
    for (const char* station : {"S1", "S2", "S3"}) db::EnsureStation(db, station);
    tx.commit();
  }
  for (int r = 0; r < robots; ++r) {
    std::mt19937 rng(100 + r);
    auto poses = calibration::SimulatePoses(model, Eigen::Isometry3d::Identity(), truth,
                                            calibration::LabTestConfigurations(model, rng), 0.01,
                                            rng);
    while (static_cast<int>(poses.size()) < configurations) {  // more of the same spread
      auto more = calibration::SimulatePoses(model, Eigen::Isometry3d::Identity(), truth,
                                             calibration::LabTestConfigurations(model, rng), 0.01,
                                             rng);
      poses.insert(poses.end(), more.begin(), more.end());
    }
    db::WriteTransaction tx(db);
    const int64_t robot = db::EnsureRobot(db, "r" + std::to_string(r), "puma760", PumaYaml());
    const int64_t session = db::CreateSession(db, robot, "", "", db::SessionState::kCompleted, "bench");
    for (int i = 0; i < configurations; ++i) {
      const int64_t pose =
          db::InsertPose(db, session, i, poses[i].id, poses[i].joints_rad, "measured", 1);
      db::PointRow p;
      p.pose_id = pose;
      p.point = "target";
      p.position_mm = poses[i].target_in_world;
      p.covariance_mm2 = Eigen::Matrix3d::Identity() * 1e-4;
      p.rays = 3;
      db::InsertPoint(db, session, p);
    }
    tx.commit();
  }
}

// The nightly job of a plant: 1,000 robots of 200 configurations, recalibrated (refitted:
// --force, the residual map off) by a worker with range(0) threads, store and queue on
// the server. The fleet is stored once; each worker count drains a full queue.
void BM_NightlyFleet(benchmark::State& state) {
  const int workers = static_cast<int>(state.range(0));
  const bool postgres = state.range(1) != 0;
  constexpr int kRobots = 1000, kConfigurations = 200;
  spdlog::set_level(spdlog::level::warn);
  static std::string store[2];
  if (store[postgres].empty()) {
    store[postgres] = NewStore(postgres, "nightly");
    db::Database db(store[postgres]);
    const auto t = std::chrono::steady_clock::now();
    AddRobots(db, kRobots, kConfigurations);
    spdlog::warn("fleet of {} robots stored in {:.1f} s", kRobots,
                 std::chrono::duration<double>(std::chrono::steady_clock::now() - t).count());
  }
  int64_t done = 0, other = 0;
  for (auto _ : state) {
    state.PauseTiming();
    nightly::ScheduleOptions schedule;
    schedule.store_db = store[postgres];
    schedule.all = true;
    schedule.recalibrate.residual_model = "off";
    schedule.recalibrate.force = true;
    nightly::Schedule(schedule);
    state.ResumeTiming();
    nightly::WorkerOptions worker;
    worker.store_db = store[postgres];
    worker.jobs = workers;
    worker.once = true;
    const auto s = nightly::RunWorker(worker);
    done += s.done;
    other += s.rejected + s.failed;
  }
  state.counters["jobs_done"] = static_cast<double>(done);
  state.counters["jobs_not_done"] = static_cast<double>(other);
  state.counters["jobs_per_min"] =
      benchmark::Counter(60.0 * static_cast<double>(done), benchmark::Counter::kIsRate);
}
BENCHMARK(BM_NightlyFleet)
    ->ArgsProduct({{1, 2, 4}, {0, 1}})
    ->ArgNames({"workers", "postgres"})
    ->Unit(benchmark::kSecond)
    ->UseRealTime()
    ->Iterations(1);

// range(0) capture processes' worth of writers (threads, each its own connection and
// session) storing configurations at once, one transaction each; afterwards every row is
// counted: none lost, none twice.
void BM_ConcurrentWriters(benchmark::State& state) {
  const int writers = static_cast<int>(state.range(0));
  const bool postgres = state.range(1) != 0;
  constexpr int kConfigurations = 200;  // per writer and iteration
  spdlog::set_level(spdlog::level::warn);
  static int n = 0;
  const std::string store = NewStore(postgres, "writers_" + std::to_string(++n));
  std::vector<int64_t> sessions;
  {
    db::Database db(store);
    db::WriteTransaction tx(db);
    for (const char* station : {"S1", "S2", "S3"}) db::EnsureStation(db, station);
    const int64_t robot = db::EnsureRobot(db, "puma", "puma760", PumaYaml());
    for (int w = 0; w < writers; ++w)
      sessions.push_back(db::CreateSession(db, robot, "", "", db::SessionState::kRunning, "writer"));
    tx.commit();
  }
  int next_seq = 0;
  int64_t stored = 0;
  for (auto _ : state) {
    std::vector<std::thread> pool;
    std::atomic<int64_t> count{0};
    for (int w = 0; w < writers; ++w) {
      pool.emplace_back([&, w] {
        MeasuredPose pose;
        pose.id = "c";
        pose.joints_rad = Eigen::VectorXd::Constant(6, 0.1);
        pose.target_in_world = Eigen::Vector3d(100, 200, 300);
        db::Database db(store, db::OpenMode::kMustExist);
        for (int i = 0; i < kConfigurations; ++i) {
          for (;;) {
            try {
              StoreConfiguration(db, sessions[w], next_seq + i, pose);
              break;
            } catch (const db::DatabaseError& e) {
              if (!e.transient()) throw;  // lost a race (SQLite busy): the capture retries
            }
          }
          ++count;
        }
      });
    }
    for (auto& t : pool) t.join();
    next_seq += kConfigurations;
    stored += count;
  }
  db::Database db(store, db::OpenMode::kMustExist);
  const int64_t poses = db.connection().QueryInt("SELECT count(*) FROM poses");
  const int64_t observations = db.connection().QueryInt("SELECT count(*) FROM observations");
  const int64_t distinct =
      db.connection().QueryInt("SELECT count(*) FROM (SELECT DISTINCT session_id, seq FROM poses) d");
  state.counters["lost_rows"] = static_cast<double>(stored - poses) +
                                static_cast<double>(3 * stored - observations);
  state.counters["duplicate_rows"] = static_cast<double>(poses - distinct);
  state.counters["configurations_per_s"] =
      benchmark::Counter(static_cast<double>(stored), benchmark::Counter::kIsRate);
}
BENCHMARK(BM_ConcurrentWriters)
    ->ArgsProduct({{20}, {0, 1}})
    ->ArgNames({"writers", "postgres"})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime()
    ->Iterations(1);

// db push of a cell's SQLite file with 100,000 observations (50 sessions of 667
// configurations, three readings each) into an empty store.
void BM_Push(benchmark::State& state) {
  const bool postgres = state.range(0) != 0;
  spdlog::set_level(spdlog::level::warn);
  const std::string cell = NewStore(false, "cell");
  constexpr int kSessions = 50, kConfigurations = 667;
  {
    db::Database db(cell);
    {
      db::WriteTransaction tx(db);
      for (const char* station : {"S1", "S2", "S3"}) db::EnsureStation(db, station);
      tx.commit();
    }
    const int64_t robot = [&] {
      db::WriteTransaction tx(db);
      const int64_t id = db::EnsureRobot(db, "puma", "puma760", PumaYaml());
      tx.commit();
      return id;
    }();
    MeasuredPose pose;
    pose.id = "c";
    pose.joints_rad = Eigen::VectorXd::Constant(6, 0.1);
    pose.target_in_world = Eigen::Vector3d(100, 200, 300);
    for (int s = 0; s < kSessions; ++s) {
      int64_t session = 0;
      {
        db::WriteTransaction tx(db);
        session = db::CreateSession(db, robot, "", "", db::SessionState::kRunning, "cell");
        tx.commit();
      }
      for (int i = 0; i < kConfigurations; ++i) StoreConfiguration(db, session, i, pose);
      db::WriteTransaction tx(db);
      db::SetSessionState(db, session, db::SessionState::kCompleted);
      tx.commit();
    }
  }
  int64_t observations = 0;
  double pushed = 0.0;
  static int n = 0;
  for (auto _ : state) {
    state.PauseTiming();
    const std::string target = NewStore(postgres, "push_" + std::to_string(++n));
    db::Database into(target);
    db::Database from(cell, db::OpenMode::kMustExist);
    state.ResumeTiming();
    const auto s = db::Push(from.connection(), into.connection(), {cell, nullptr});
    observations += s.observations;
    pushed = static_cast<double>(
        into.connection().QueryInt("SELECT count(*) FROM observations"));
  }
  state.counters["observations"] = pushed;
  state.counters["observations_per_s"] =
      benchmark::Counter(static_cast<double>(observations), benchmark::Counter::kIsRate);
}
BENCHMARK(BM_Push)->Arg(0)->Arg(1)->ArgName("postgres")->Unit(benchmark::kSecond)->UseRealTime()->Iterations(1);

}  // namespace
}  // namespace armsig

BENCHMARK_MAIN();
