// Calibration speed (issue #3): full 43-parameter fit on 80 and 10,000 poses, and
// selecting 80 of 10,000 candidates. Run by hand: build/bench/calibration_bench
#include <benchmark/benchmark.h>

#include <random>

#include "calibration/estimation.h"
#include "calibration/selection.h"
#include "calibration/simulation.h"

namespace armsig::calibration {
namespace {

RobotModel Puma() {
  RobotModel m;
  m.name = "puma760";
  auto link = [](std::initializer_list<double> v) {
    Eigen::Matrix4d t;
    auto it = v.begin();
    for (int r = 0; r < 4; ++r)
      for (int c = 0; c < 4; ++c) t(r, c) = *it++;
    Eigen::Isometry3d iso;
    iso.matrix() = t;
    return iso;
  };
  m.links = {link({1, 0, 0, 0, 0, 0, -1, 164, 0, 1, 0, 0, 0, 0, 0, 1}),
             link({1, 0, 0, 650, 0, 1, 0, 0, 0, 0, 1, 50, 0, 0, 0, 1}),
             link({0, 0, 1, 550, 0, 1, 0, 0, -1, 0, 0, 0, 0, 0, 0, 1}),
             link({0, 0, -1, 0, 0, 1, 0, 0, 1, 0, 0, 50, 0, 0, 0, 1}),
             link({0, 0, 1, 125, 0, 1, 0, 0, -1, 0, 0, 0, 0, 0, 0, 1})};
  using B = NongeometricTerm::Basis;
  m.nongeometric = {{"h1", 1, B::kCos, {1, 2}},
                    {"h2", 1, B::kCos, {1}},
                    {"h3", 2, B::kCos, {1, 2}},
                    {"h4", 2, B::kSignCos, {1, 2}}};
  return m;
}

std::vector<MeasuredPose> Poses(const RobotModel& model, int count) {
  std::mt19937 rng(1);
  Eigen::Isometry3d base = Eigen::Isometry3d::Identity();
  base.translation() << 2000, -1000, 300;
  return SimulatePoses(model, base, PaperTable3Parameters(),
                       RandomConfigurations(model, count, rng), 0.02, rng);
}

void BM_Fit43(benchmark::State& state) {
  const RobotModel model = Puma();
  const auto poses = Poses(model, static_cast<int>(state.range(0)));
  EstimationOptions options;
  for (auto _ : state) {
    auto r = Estimate(model, poses, options);
    benchmark::DoNotOptimize(r.params.data());
  }
  state.SetItemsProcessed(state.iterations() * state.range(0));
}
BENCHMARK(BM_Fit43)->Arg(80)->Arg(10000)->Unit(benchmark::kMillisecond);

void BM_Select80Of(benchmark::State& state) {
  const RobotModel model = Puma();
  std::mt19937 rng(2);
  const auto joints = RandomConfigurations(model, static_cast<int>(state.range(0)), rng);
  std::vector<int> all(43);
  for (int i = 0; i < 43; ++i) all[i] = i;
  const auto id = AnalyseJacobian(
      StackedJacobian(model, Eigen::Isometry3d::Identity(), Eigen::VectorXd::Zero(43),
                      std::vector<Eigen::VectorXd>(joints.begin(), joints.begin() + 200)),
      all);
  SelectionOptions options;
  options.count = 80;
  for (auto _ : state) {
    auto r = SelectConfigurations(model, joints, id.identified, options);
    benchmark::DoNotOptimize(r.log_det);
  }
}
BENCHMARK(BM_Select80Of)->Arg(10000)->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace armsig::calibration

BENCHMARK_MAIN();
