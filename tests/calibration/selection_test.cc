#include "calibration/selection.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <random>

#include "calibration/estimation.h"
#include "calibration/synthetic.h"
#include "test_support.h"

namespace armsig::calibration {

// On simulated data, the validation error with the N selected configurations is
// lower than the average over random subsets of the same size. The candidates are a
// lab's test pool like the paper's (single-joint rotation tests, line and circle
// tests: clustered); validation is the prediction error on new poses over the whole
// workspace, against the noise-free truth.
TEST(Selection, BeatsRandomChoice) {
  const auto model = testing::Puma();
  const Eigen::VectorXd truth = PaperTable3Parameters();
  Eigen::Isometry3d base = Eigen::Isometry3d::Identity();
  base.translation() << 2000, 1000, 0;
  std::mt19937 rng(21);
  const auto candidates =
      SimulatePoses(model, base, truth, LabTestConfigurations(model, rng), 0.02, rng);
  const auto validation =
      SimulatePoses(model, base, truth, RandomConfigurations(model, 300, rng), 0.0, rng);
  std::vector<Eigen::VectorXd> joints;
  for (const auto& p : candidates) joints.push_back(p.joints_rad);
  EstimationOptions o;
  o.parameters = ParseParameterSpec(model, "all");
  const auto id = AnalyseJacobian(
      StackedJacobian(model, Eigen::Isometry3d::Identity(), Eigen::VectorXd::Zero(43), joints),
      o.parameters);
  const int n = 80;
  SelectionOptions so;
  so.count = n;
  const auto selected = SelectConfigurations(model, joints, id.identified, so);
  ASSERT_EQ(selected.selected.size(), static_cast<size_t>(n));

  auto validation_error = [&](const std::vector<int>& subset) {
    std::vector<MeasuredPose> fit;
    for (int i : subset) fit.push_back(candidates[i]);
    const auto r = Estimate(model, fit, o);
    return Summarise(Distances(Residuals(model, r.world_from_base, r.params, validation))).rms_mm;
  };
  const double selected_error = validation_error(selected.selected);
  const Eigen::VectorXd scale = ColumnScale(model, joints, id.identified);
  double random_error = 0.0, random_log_det = 0.0;
  const int trials = 20;
  std::vector<int> all(candidates.size());
  for (size_t i = 0; i < all.size(); ++i) all[i] = static_cast<int>(i);
  for (int t = 0; t < trials; ++t) {
    std::shuffle(all.begin(), all.end(), rng);
    std::vector<int> subset(all.begin(), all.begin() + n);
    random_error += validation_error(subset) / trials;
    std::vector<Eigen::VectorXd> q;
    for (int i : subset) q.push_back(joints[i]);
    random_log_det += MeasureObservability(model, q, id.identified, scale).log_det / trials;
  }
  EXPECT_LT(selected_error, random_error);
  EXPECT_GT(selected.log_det, random_log_det);
  // The figures reported for the selection are those of the selected configurations,
  // recomputed here from scratch.
  std::vector<Eigen::VectorXd> chosen;
  for (int i : selected.selected) chosen.push_back(joints[i]);
  const auto recomputed = MeasureObservability(model, chosen, id.identified, scale);
  EXPECT_NEAR(selected.log_det, recomputed.log_det, 1e-6 * std::abs(recomputed.log_det));
  EXPECT_NEAR(selected.condition_number, recomputed.condition_number,
              1e-6 * recomputed.condition_number);
}

TEST(Selection, ExchangeNeverLowersTheCriterion) {
  const auto model = testing::Puma();
  std::mt19937 rng(22);
  const auto joints = RandomConfigurations(model, 300, rng);
  std::vector<int> params;
  for (int i = 0; i < 43; ++i) params.push_back(i);
  const auto id = AnalyseJacobian(
      StackedJacobian(model, Eigen::Isometry3d::Identity(), Eigen::VectorXd::Zero(43), joints),
      params);
  SelectionOptions greedy;
  greedy.count = 40;
  greedy.exchange_passes = 0;
  SelectionOptions exchange = greedy;
  exchange.exchange_passes = 3;
  const auto a = SelectConfigurations(model, joints, id.identified, greedy);
  const auto b = SelectConfigurations(model, joints, id.identified, exchange);
  EXPECT_GE(b.log_det, a.log_det - 1e-9);
}

// A stop request (Ctrl-C, SIGTERM to the nightly job) ends the selection and the fit at their
// next step with core::Stopped; without it both run to their end.
TEST(Selection, AStopRequestEndsTheSelectionAndTheFit) {
  const auto model = testing::Puma();
  std::mt19937 rng(3);
  const auto poses = SimulatePoses(model, Eigen::Isometry3d::Identity(), PaperTable3Parameters(),
                                   RandomConfigurations(model, 120, rng), 0.02, rng);
  std::vector<Eigen::VectorXd> joints;
  for (const auto& p : poses) joints.push_back(p.joints_rad);
  std::vector<int> all(model.num_parameters());
  for (int i = 0; i < model.num_parameters(); ++i) all[i] = i;
  std::atomic<bool> stop{false};
  SelectionOptions so;
  so.count = 60;
  so.stop = core::StopToken(&stop);
  EstimationOptions eo;
  eo.stop = core::StopToken(&stop);
  EXPECT_EQ(SelectConfigurations(model, joints, all, so).selected.size(), 60u);
  EXPECT_TRUE(Estimate(model, poses, eo).status.ok());
  stop = true;
  EXPECT_THROW(SelectConfigurations(model, joints, all, so), core::Stopped);
  EXPECT_THROW(Estimate(model, poses, eo), core::Stopped);
}

TEST(Selection, RefusesImpossibleCounts) {
  const auto model = testing::Puma();
  std::mt19937 rng(23);
  const auto joints = RandomConfigurations(model, 10, rng);
  SelectionOptions o;
  o.count = 11;
  EXPECT_THROW(SelectConfigurations(model, joints, {0, 1, 2}, o), std::invalid_argument);
}

}  // namespace armsig::calibration
