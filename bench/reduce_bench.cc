// reduce of 1,000,000 stored observations end to end (the target: ≤ 10 s): SQLite read,
// grouping, intersection, one write transaction. Run by hand: build/bench/reduce_bench
#include <benchmark/benchmark.h>
#include <unistd.h>

#include <filesystem>
#include <random>

#include "core/units.h"
#include "db/store.h"
#include "reduction/intersection.h"
#include "reduction/observation.h"
#include "workflows/reduce.h"

namespace armsig {
namespace {

std::string MakeDatabase(int64_t observations) {
  const std::string path = (std::filesystem::temp_directory_path() /
                            ("armsig-reduce-bench-" + std::to_string(::getpid()) + ".db"))
                               .string();
  std::filesystem::remove(path);
  db::Database database(path);
  db::WriteTransaction tx(database);
  const int64_t robot = db::EnsureRobot(database, "bench", "", "");
  const int64_t session = db::CreateSession(database, robot, "", "", db::SessionState::kCompleted, "bench");
  const Eigen::Vector3d positions[3] = {{3500, 0, 1500}, {-1750, 3000, 1400}, {-1750, -3000, 1600}};
  const double azimuths[3] = {0.3, 2.2, 4.1};
  for (int s = 0; s < 3; ++s) {
    db::StationSetupRow row;
    row.station = "S" + std::to_string(s + 1);
    row.pose.position_mm = positions[s];
    row.pose.azimuth_rad = azimuths[s];
    row.pose.world_from_station = reduction::LevelledRotation(azimuths[s]);
    row.sigma_hz_rad = row.sigma_v_rad = 0.5 * kRadPerArcsec;
    row.method = "bench";
    db::InsertStationSetup(database, session, row);
  }
  std::mt19937 rng(1);
  std::uniform_real_distribution<double> u(-1000, 1000);
  std::normal_distribution<double> noise(0, 0.5 * kRadPerArcsec);
  std::vector<db::ObservationRow> rows;
  const int64_t points = observations / 3;
  for (int64_t p = 0; p < points; ++p) {
    const Eigen::Vector3d x(u(rng), u(rng), 1000 + u(rng));
    for (int s = 0; s < 3; ++s) {
      db::ObservationRow r;
      r.point = "P" + std::to_string(p);
      r.station = "S" + std::to_string(s + 1);
      r.reading =
          reduction::PredictReading(positions[s], reduction::LevelledRotation(azimuths[s]), x);
      r.reading.hz_rad += noise(rng);
      r.reading.v_rad += noise(rng);
      rows.push_back(r);
    }
  }
  db::InsertObservations(database, session, rows);
  tx.commit();
  return path;
}

void BM_Reduce1MObservations(benchmark::State& state) {
  const std::string path = MakeDatabase(state.range(0));
  for (auto _ : state) {
    db::Database database(path);
    const auto summary = workflows::ReduceSession(database, 1, reduction::PointOptions{});
    benchmark::DoNotOptimize(summary.reduced);
    state.counters["points"] = static_cast<double>(summary.reduced);
  }
  std::filesystem::remove(path);
  std::filesystem::remove(path + "-wal");
  std::filesystem::remove(path + "-shm");
}
BENCHMARK(BM_Reduce1MObservations)->Arg(1000000)->Iterations(1)->Unit(benchmark::kSecond);

}  // namespace
}  // namespace armsig

BENCHMARK_MAIN();
