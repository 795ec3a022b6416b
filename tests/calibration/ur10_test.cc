// The real UR10 laser-tracker data (tests/data/ur10-ipa, MIT): calibrate on part of
// series C and validate on the held-out poses; the issue-13 figures on its fixed split.
#include <gtest/gtest.h>

#include <fstream>

#include "calibration/estimation.h"
#include "calibration/residual_map.h"
#include "calibration/selection.h"
#include "io/poses_csv.h"
#include "test_support.h"

namespace armsig::calibration {

TEST(Ur10RealData, GeometricModelValidatesBelowHalfAMillimetre) {
  const auto model = testing::Ur10();
  const auto poses =
      io::ImportPoses(testing::DataPath("ur10-ipa/series_C-measurements_random_poses.csv"),
                      io::PoseImportOptions::UrIpa());
  // Fit on every second pose, validate on the others (independent of the selection code).
  std::vector<MeasuredPose> fit, validation;
  for (size_t i = 0; i < poses.size(); ++i) (i % 2 ? validation : fit).push_back(poses[i]);
  EstimationOptions o;
  o.parameters = ParseParameterSpec(model, "geometric");
  const auto r = Estimate(model, fit, o);
  ASSERT_TRUE(r.status.ok()) << r.status.message;
  const auto nominal = Summarise(Distances(Residuals(
      model, r.world_from_base, Eigen::VectorXd::Zero(model.num_parameters()), validation)));
  const auto calibrated =
      Summarise(Distances(Residuals(model, r.world_from_base, r.params, validation)));
  // Reference figures: about 5.2 mm nominal, about 0.44 mm after a 39-parameter fit.
  EXPECT_GT(nominal.mean_mm, 3.0);
  EXPECT_LT(nominal.mean_mm, 8.0);
  // Even the in-sample fit on all 2,773 poses leaves 0.430 mm: this is the model's floor
  // on this robot, so held-out poses land at the reference's 0.44 mm, not below it.
  EXPECT_LT(calibrated.mean_mm, 0.45);
  EXPECT_LT(calibrated.mean_mm, 0.15 * nominal.mean_mm);
}

}  // namespace armsig::calibration

namespace armsig::calibration {
namespace {

// The issue's split of series C: numpy default_rng(0).permutation(2773)
// (tests/data/ur10-ipa-split); fit on the first `fit_count` positions, hold out the last
// 1,000. The held-out poses are used for nothing but the figures checked here.
struct Split {
  std::vector<MeasuredPose> fit, held_out;
};

Split UrSplit(int fit_count) {
  const auto poses =
      io::ImportPoses(testing::DataPath("ur10-ipa/series_C-measurements_random_poses.csv"),
                      io::PoseImportOptions::UrIpa());
  std::ifstream file(testing::DataPath("ur10-ipa-split/series_C-permutation.txt"));
  std::vector<int> permutation;
  for (int i; file >> i;) permutation.push_back(i);
  EXPECT_EQ(permutation.size(), poses.size());
  Split split;
  for (int k = 0; k < fit_count; ++k) split.fit.push_back(poses.at(permutation.at(k)));
  for (size_t k = poses.size() - 1000; k < poses.size(); ++k) {
    split.held_out.push_back(poses.at(permutation.at(k)));
  }
  return split;
}

double HeldOutMean(const RobotModel& model, const EstimationResult& r, const ResidualMap* map,
                   const std::vector<MeasuredPose>& held_out, int* extrapolated = nullptr) {
  std::vector<Eigen::VectorXd> q;
  for (const auto& p : held_out) q.push_back(p.joints_rad);
  const auto predicted = PredictPositions(model, r.world_from_base, r.params, map, q);
  double sum = 0.0;
  if (extrapolated) *extrapolated = 0;
  for (size_t i = 0; i < q.size(); ++i) {
    sum += (predicted[i].position_mm - held_out[i].target_in_world).norm();
    if (extrapolated) *extrapolated += predicted[i].extrapolated;
  }
  return sum / static_cast<double>(q.size());
}

struct Figures {
  double geometric = 0.0, terms = 0.0, final_mean = 0.0;
  ResidualMapFit map;
  int extrapolated = 0;
  std::vector<std::string> added;
};

// The whole procedure on the fit poses: geometric, --params auto over h1…h4 and the
// generated terms, then the residual map where its cross-validation says so.
Figures RunIssue13Procedure(const Split& split) {
  const RobotModel model = testing::Ur10();  // with generated_terms: [compliance, harmonics]
  Figures f;
  EstimationOptions geometric;
  geometric.parameters = ParseParameterSpec(model, "geometric");
  const auto g = Estimate(model, split.fit, geometric);
  EXPECT_TRUE(g.status.ok()) << g.status.message;
  f.geometric = HeldOutMean(model, g, nullptr, split.held_out);
  EstimationOptions all;
  all.parameters = ParseParameterSpec(model, "all");
  const auto selection = SelectTerms(model, split.fit, all);
  for (int k : selection.parameters) {
    if (k >= model.num_geometric()) f.added.push_back(model.ParameterNames()[k]);
  }
  EstimationOptions chosen;
  chosen.parameters = selection.parameters;
  const auto t = Estimate(model, split.fit, chosen);
  EXPECT_TRUE(t.status.ok()) << t.status.message;
  f.terms = HeldOutMean(model, t, nullptr, split.held_out);
  f.map = FitResidualMap(model, t, split.fit);
  const ResidualMap map(f.map.map);
  f.final_mean =
      f.map.used ? HeldOutMean(model, t, &map, split.held_out, &f.extrapolated) : f.terms;
  return f;
}

}  // namespace

TEST(Ur10Split, TermsAndTheMapBeatTheGeometricModelOnTheHeldOutThousand) {
  const Figures f = RunIssue13Procedure(UrSplit(1773));
  // The issue's reference: 0.449 mm for the paper's geometric model on this split.
  EXPECT_NEAR(f.geometric, 0.449, 0.005);
  EXPECT_FALSE(f.added.empty());
  EXPECT_LT(f.terms, f.geometric);
  ASSERT_TRUE(f.map.used) << f.map.decision;
  EXPECT_LT(f.map.cv_mean_mm_with_map, 0.9 * f.map.cv_mean_mm_parametric);
  // The issue's goal: ≤ 0.37 mm with terms and map (measured: 0.294).
  EXPECT_LE(f.final_mean, 0.37);
  // Cross-validation on the fit poses predicted the held-out figure.
  EXPECT_NEAR(f.final_mean, f.map.cv_mean_mm_with_map, 0.1 * f.map.cv_mean_mm_with_map);
  EXPECT_LE(f.extrapolated, 20) << "of 1000 held-out poses drawn like the fit poses";
}

TEST(Ur10Split, With150FitPosesNothingGetsWorseThanGeometric) {
  const Figures f = RunIssue13Procedure(UrSplit(150));
  EXPECT_NEAR(f.geometric, 0.458, 0.005);  // the issue's figure
  // The map's cross-validation finds nothing to gain from 150 poses: it stays off.
  EXPECT_FALSE(f.map.used) << f.map.decision;
  EXPECT_LE(f.final_mean, 1.01 * f.geometric);
}

}  // namespace armsig::calibration
