// Reduction speed: three-ray intersection with covariance (≥ 1,000,000
// points/s), orienting 3 stations with 200 target points (≤ 50 ms).
// Run by hand: build/bench/reduction_bench
#include <benchmark/benchmark.h>

#include <random>

#include "core/units.h"
#include "reduction/intersection.h"
#include "reduction/observation.h"
#include "reduction/orientation.h"

namespace armsig::reduction {
namespace {

constexpr double kSigma = 0.5 * kRadPerArcsec;

struct Lab {
  Eigen::Vector3d station[3] = {{3500, 0, 1500}, {-1750, 3000, 1400}, {-1750, -3000, 1600}};
  double azimuth[3] = {0.3, 2.2, 4.1};
  std::mt19937 rng{1};

  Ray RayTo(int s, const Eigen::Vector3d& x) {
    std::normal_distribution<double> noise(0.0, kSigma);
    Station st;
    st.pose.position_mm = station[s];
    st.pose.world_from_station = LevelledRotation(azimuth[s]);
    Observation o;
    o.reading = PredictReading(st.pose.position_mm, st.pose.world_from_station, x);
    o.reading.hz_rad += noise(rng);
    o.reading.v_rad += noise(rng);
    o.sigma_hz_rad = o.sigma_v_rad = kSigma;
    return RayOf(o, st, InstrumentDefaults{});
  }
  Eigen::Vector3d Target() {
    std::uniform_real_distribution<double> u(-1000, 1000);
    return {u(rng), u(rng), 1000 + u(rng)};
  }
};

void BM_IntersectThreeRays(benchmark::State& state) {
  Lab lab;
  std::vector<std::array<Ray, 3>> points(4096);
  for (auto& p : points) {
    const auto x = lab.Target();
    p = {lab.RayTo(0, x), lab.RayTo(1, x), lab.RayTo(2, x)};
  }
  IntersectionResult result;
  IntersectionOptions options;
  size_t k = 0;
  for (auto _ : state) {
    Intersect(points[k++ & 4095], options, result);
    benchmark::DoNotOptimize(result.covariance_mm2.data());
  }
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_IntersectThreeRays);

void BM_Orient3Stations200Points(benchmark::State& state) {
  Lab lab;
  OrientationProblem problem;
  problem.station_ids = {"S1", "S2", "S3"};
  auto add = [&](int s, const std::string& point, const Eigen::Vector3d& x) {
    const Ray r = lab.RayTo(s, x);
    Observation o;
    o.station = problem.station_ids[s];
    o.point = point;
    o.reading = r.reading;
    o.sigma_hz_rad = o.sigma_v_rad = kSigma;
    problem.observations.push_back(o);
  };
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j)
      if (i != j) add(i, problem.station_ids[j], lab.station[j]);
  Eigen::Vector3d bar_a = Eigen::Vector3d::Zero(), bar_b = Eigen::Vector3d::Zero();
  for (int k = 0; k < 200; ++k) {
    const auto x = lab.Target();
    if (k == 0) bar_a = x;
    if (k == 1) bar_b = x;
    for (int s = 0; s < 3; ++s) add(s, "T" + std::to_string(k), x);
  }
  problem.scale_bars.push_back({"T0", "T1", (bar_b - bar_a).norm(), 0.005});
  for (auto _ : state) {
    auto r = Orient(problem);
    if (!r.status.ok()) state.SkipWithError("orientation failed");
    benchmark::DoNotOptimize(r.sigma0);
  }
}
BENCHMARK(BM_Orient3Stations200Points)->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace armsig::reduction

BENCHMARK_MAIN();
