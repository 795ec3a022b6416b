// The two inputs issue 38 found super-linear, measured for their growth (run by hand:
// build/bench/inputs_bench): loading a session of N poses from SQLite (the points joined to
// their poses; 40k poses took 232 s before the index) and a CSV header of N columns (every
// name compared with every earlier one: 200,000 columns took 556 s). Both should fit O(N).
#include <benchmark/benchmark.h>
#include <unistd.h>

#include <filesystem>
#include <random>
#include <string>

#include "db/store.h"
#include "io/csv.h"

namespace armsig {
namespace {

// A store with one session of `poses` poses of a 6-joint robot, each with its point.
std::string SessionStore(int64_t poses, int64_t& session) {
  const std::string path = (std::filesystem::temp_directory_path() /
                            ("armsig-inputs-bench-" + std::to_string(::getpid()) + "-" +
                             std::to_string(poses) + ".db"))
                               .string();
  std::filesystem::remove(path);
  db::Database database(path);
  db::WriteTransaction tx(database);
  const int64_t robot = db::EnsureRobot(database, "bench", "", "");
  session = db::CreateSession(database, robot, "", "", db::SessionState::kCompleted, "bench");
  std::mt19937 rng(1);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (int64_t k = 0; k < poses; ++k) {
    Eigen::VectorXd q(6);
    for (int i = 0; i < 6; ++i) q(i) = u(rng);
    const int64_t pose = db::InsertPose(database, session, static_cast<int>(k),
                                        "p" + std::to_string(k), q, "measured", 1);
    db::PointRow point;
    point.pose_id = pose;
    point.point = "target";
    point.position_mm = Eigen::Vector3d(1000 * u(rng), 1000 * u(rng), 1000 * u(rng));
    db::InsertPoint(database, session, point);
  }
  tx.commit();
  return path;
}

void BM_LoadSessionPoses(benchmark::State& state) {
  int64_t session = 0;
  const std::string path = SessionStore(state.range(0), session);
  db::Database database(path, db::OpenMode::kMustExist);
  for (auto _ : state) benchmark::DoNotOptimize(db::LoadSessionPoses(database, session));
  state.SetComplexityN(state.range(0));
  std::filesystem::remove(path);
}
BENCHMARK(BM_LoadSessionPoses)->RangeMultiplier(4)->Range(1 << 10, 1 << 16)->Complexity()
    ->Unit(benchmark::kMillisecond);

void BM_CsvHeaderCheck(benchmark::State& state) {
  std::string text = "c0";
  for (int64_t c = 1; c < state.range(0); ++c) text += ",c" + std::to_string(c);
  text += "\n";
  for (auto _ : state) benchmark::DoNotOptimize(io::ParseCsv(text, "bench.csv"));
  state.SetComplexityN(state.range(0));
}
// Up to 65,536 columns: a header of 131,072 (about 1 MiB) is at the record bound.
BENCHMARK(BM_CsvHeaderCheck)->RangeMultiplier(4)->Range(1 << 10, 1 << 16)->Complexity()
    ->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace armsig

BENCHMARK_MAIN();
