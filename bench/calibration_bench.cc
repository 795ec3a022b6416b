// Calibration speed: full 43-parameter fit on 80 and 10,000 poses, and
// selecting 80 of 10,000 candidates. The whole beyond-geometric fit on the
// UR10 split (1,773 poses: terms by F-test and cross-validation, the residual map's
// cross-validation on two threads) and predictions with the map.
// Run by hand: build/bench/calibration_bench
#include <benchmark/benchmark.h>

#include <fstream>
#include <random>

#include "calibration/estimation.h"
#include "calibration/residual_map.h"
#include "calibration/selection.h"
#include "calibration/synthetic.h"
#include "io/model_yaml.h"
#include "io/poses_csv.h"

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

// The UR10 model and the 1,773 fit poses of the split of series C.
struct Ur10Fit {
  RobotModel model;
  std::vector<MeasuredPose> fit;
};
const Ur10Fit& Ur10SplitFit() {
  static const Ur10Fit data = [] {
    Ur10Fit d;
    const std::string source = ARMSIG_SOURCE_DIR;
    d.model = io::LoadRobotModel(source + "/models/ur10.yaml");
    const auto poses =
        io::ImportPoses(source + "/tests/data/ur10-ipa/series_C-measurements_random_poses.csv",
                        io::PoseImportOptions::UrIpa());
    std::ifstream file(source + "/tests/data/ur10-ipa-split/series_C-permutation.txt");
    std::vector<int> permutation;
    for (int i; file >> i;) permutation.push_back(i);
    for (int k = 0; k < 1773; ++k) d.fit.push_back(poses.at(permutation.at(k)));
    return d;
  }();
  return data;
}

// Geometric fit, --params auto (F-tests and cross-validation over h1…h4 and 30 generated
// terms), the final estimate, and the residual map with its cross-validated search.
void BM_Ur10TermsAndMapFit(benchmark::State& state) {
  const Ur10Fit& d = Ur10SplitFit();
  EstimationOptions all;
  all.parameters = ParseParameterSpec(d.model, "all");
  for (auto _ : state) {
    const auto selection = SelectTerms(d.model, d.fit, all);
    EstimationOptions chosen;
    chosen.parameters = selection.parameters;
    const auto estimate = Estimate(d.model, d.fit, chosen);
    const auto map = FitResidualMap(d.model, estimate, d.fit);
    benchmark::DoNotOptimize(map.cv_mean_mm_with_map);
  }
}
BENCHMARK(BM_Ur10TermsAndMapFit)->Unit(benchmark::kSecond)->UseRealTime();

// The nightly job's default selection on the UR10: 60 % of series C's 2,773 configurations
// (1,663) D-optimal for all 73 parameters' identifiable subset; argument: exchange passes.
void BM_Ur10SelectSixtyPercent(benchmark::State& state) {
  const std::string source = ARMSIG_SOURCE_DIR;
  const RobotModel model = io::LoadRobotModel(source + "/models/ur10.yaml");
  const auto poses =
      io::ImportPoses(source + "/tests/data/ur10-ipa/series_C-measurements_random_poses.csv",
                      io::PoseImportOptions::UrIpa());
  std::vector<Eigen::VectorXd> joints;
  for (const auto& p : poses) joints.push_back(p.joints_rad);
  std::vector<int> all(model.num_parameters());
  for (int i = 0; i < model.num_parameters(); ++i) all[i] = i;
  const auto id = AnalyseJacobian(
      StackedJacobian(model, Eigen::Isometry3d::Identity(), Eigen::VectorXd::Zero(model.num_parameters()), joints),
      all);
  SelectionOptions options;
  options.count = static_cast<int>(joints.size()) * 6 / 10;
  options.exchange_passes = static_cast<int>(state.range(0));
  double log_det = 0.0;
  for (auto _ : state) {
    const auto r = SelectConfigurations(model, joints, id.identified, options);
    log_det = r.log_det;
  }
  state.counters["log_det"] = log_det;
}
BENCHMARK(BM_Ur10SelectSixtyPercent)->Arg(0)->Arg(1)->Arg(2)->Unit(benchmark::kSecond)->UseRealTime();

// Predicted positions (parametric + map) for configurations like the fit poses.
void BM_Ur10PredictWithMap(benchmark::State& state) {
  const Ur10Fit& d = Ur10SplitFit();
  EstimationOptions geometric;
  geometric.parameters = ParseParameterSpec(d.model, "geometric");
  const auto estimate = Estimate(d.model, d.fit, geometric);
  const auto fit = FitResidualMap(d.model, estimate, d.fit);
  const ResidualMap map(fit.map);
  std::mt19937 rng(3);
  std::normal_distribution<double> jitter(0.0, 0.02);
  std::vector<Eigen::VectorXd> joints(static_cast<size_t>(state.range(0)));
  for (size_t i = 0; i < joints.size(); ++i) {
    joints[i] = d.fit[i % d.fit.size()].joints_rad;
    for (int j = 0; j < joints[i].size(); ++j) joints[i](j) += jitter(rng);
  }
  const bool with_map = state.range(1) != 0;
  const int threads = static_cast<int>(state.range(2));
  for (auto _ : state) {
    const auto predicted = PredictPositions(d.model, estimate.world_from_base, estimate.params,
                                            with_map ? &map : nullptr, joints, false, threads);
    benchmark::DoNotOptimize(predicted.data());
  }
  state.SetItemsProcessed(state.iterations() * state.range(0));
}
// Arguments: configurations; 1 with the map, 0 the parametric model alone; threads.
BENCHMARK(BM_Ur10PredictWithMap)
    ->Args({100000, 1, 1})
    ->Args({100000, 1, 2})
    ->Args({100000, 0, 1})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

}  // namespace
}  // namespace armsig::calibration

BENCHMARK_MAIN();
