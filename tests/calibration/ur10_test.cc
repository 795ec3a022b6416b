// The real UR10 laser-tracker data (tests/data/ur10-ipa, MIT): calibrate on part of
// series C and validate on the held-out poses; the issue-13 figures on its fixed split;
// series D's goals as ISO 9283 accuracy points before and after the series C signature.
#include <fmt/format.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <iostream>

#include "calibration/estimation.h"
#include "calibration/iso9283_figures.h"
#include "calibration/residual_map.h"
#include "calibration/selection.h"
#include "io/poses_csv.h"
#include "test_support.h"

namespace armsig::calibration {

TEST(Ur10RealData, GeometricModelValidatesBelowHalfAMillimetre) {
  const auto model = testing::Ur10();
  auto poses =
      io::ImportPoses(testing::DataPath("ur10-ipa/series_C-measurements_random_poses.csv"),
                      io::PoseImportOptions::UrIpa());
  for (auto& p : poses) p.orientation.reset();  // the paper's kind of data: positions
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

// `orientation`: keep the T-Mac's measured orientations (a 6-DoF fit); without, the poses
// are position-only, as every figure before orientations were read.
Split UrSplit(int fit_count, bool orientation = false) {
  auto poses =
      io::ImportPoses(testing::DataPath("ur10-ipa/series_C-measurements_random_poses.csv"),
                      io::PoseImportOptions::UrIpa());
  if (!orientation) {
    for (auto& p : poses) p.orientation.reset();
  }
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
  // The issue's goal: ≤ 0.37 mm with terms and map (0.294 with the kernel alone). Each
  // joint's angle error as a curve of its own angle takes it to 0.08 mm: the joint curves
  // alone beat the parametric model's cross-validation four to one.
  ASSERT_FALSE(f.map.map.curves.empty()) << f.map.decision;
  EXPECT_LT(f.map.cv_mean_mm_curves, 0.3 * f.map.cv_mean_mm_parametric);
  EXPECT_LE(f.final_mean, 0.10);
  // Cross-validation on the fit poses predicted the held-out figure.
  EXPECT_NEAR(f.final_mean, f.map.cv_mean_mm_with_map, 0.1 * f.map.cv_mean_mm_with_map);
  EXPECT_LE(f.extrapolated, 20) << "of 1000 held-out poses drawn like the fit poses";
}

// The same split with the probe's measured orientations: the wrist's turns become
// identifiable and the held-out orientation error is small, but the held-out positions
// gain nothing (the study in docs/explanation/transfer.md: the model's position floor is
// not where orientations look).
TEST(Ur10Split, SixDofDataIdentifyMoreAndReportTheHeldOutOrientationError) {
  const Split positions = UrSplit(1773), six = UrSplit(1773, true);
  const RobotModel model = testing::Ur10();
  EstimationOptions o;
  o.parameters = ParseParameterSpec(model, "geometric");
  const auto p = Estimate(model, positions.fit, o);
  const auto r = Estimate(model, six.fit, o);
  ASSERT_TRUE(r.status.ok()) << r.status.message;
  EXPECT_EQ(p.identifiability.rank, 25);
  EXPECT_EQ(r.identifiability.rank, 27);
  EXPECT_EQ(r.orientation_poses, 1773);
  // Variance components: about 0.28 mm per coordinate and 0.03° per component.
  EXPECT_NEAR(r.sigma0_mm, 0.28, 0.02);
  EXPECT_NEAR(r.sigma0_rad * 180 / M_PI, 0.033, 0.005);
  const auto angles = Angles(OrientationResiduals(model, r.bases, r.tool_rotations, r.params,
                                                  six.held_out));
  ASSERT_EQ(angles.size(), 1000u);
  const double held_out_deg = SummariseAngles(angles).mean_rad * 180 / M_PI;
  EXPECT_GT(held_out_deg, 0.03);
  EXPECT_LT(held_out_deg, 0.07);
  // Positions: the same to a hundredth of a millimetre, not better.
  EXPECT_NEAR(HeldOutMean(model, r, nullptr, six.held_out),
              HeldOutMean(model, p, nullptr, positions.held_out), 0.01);
  std::cout << fmt::format(
      "UR10 series C split, geometric: position-only rank {} held out {:.4f} mm; 6-DoF rank {} "
      "held out {:.4f} mm, {:.4f} deg (sigma0 {:.4f} mm, {:.4f} deg, weight {:.0f} mm/rad)\n",
      p.identifiability.rank, HeldOutMean(model, p, nullptr, positions.held_out),
      r.identifiability.rank, HeldOutMean(model, r, nullptr, six.held_out), held_out_deg,
      r.sigma0_mm, r.sigma0_rad * 180 / M_PI, r.orientation_weight_mm_per_rad);
}

TEST(Ur10Split, With150FitPosesNothingGetsWorseThanGeometric) {
  const Figures f = RunIssue13Procedure(UrSplit(150));
  EXPECT_NEAR(f.geometric, 0.458, 0.005);  // the issue's figure
  // The kernel alone found nothing to gain from 150 poses; the joint curves do, and the
  // held-out thousand agree with the cross-validation.
  ASSERT_TRUE(f.map.used) << f.map.decision;
  EXPECT_LT(f.final_mean, 0.9 * f.geometric);
  EXPECT_NEAR(f.final_mean, f.map.cv_mean_mm_with_map, 0.15 * f.map.cv_mean_mm_with_map);
  std::cout << "UR10 split, 150 fit poses: geometric " << f.geometric << " mm, with the map "
            << f.final_mean << " mm held out (" << f.map.decision << ")\n";
}

}  // namespace armsig::calibration

namespace armsig::calibration {
namespace {

// The per-goal AP of series D as accuracy points (one cycle each): the attained positions
// (tracker frame) put into the frame of the commanded ones by a rigid best fit, as
// `iso9283 evaluate --align` does, and their distances.
struct ApSummary {
  double mean = 0, median = 0, p95 = 0, max = 0;
};
ApSummary AccuracyPoints(const std::vector<Eigen::Vector3d>& commanded,
                         const std::vector<Eigen::Vector3d>& attained) {
  const auto fit = iso9283::AlignRigidly(attained, commanded);
  EXPECT_TRUE(fit);
  std::vector<double> ap;
  for (size_t i = 0; i < attained.size(); ++i) {
    iso9283::PointData p{
        std::to_string(i + 1), commanded[i], std::nullopt, {{1, 0, attained[i], std::nullopt}}};
    iso9283::TransformSamples(p, fit->commanded_from_attained);
    ap.push_back(iso9283::EvaluatePoint(p).ap_mm);
  }
  std::sort(ap.begin(), ap.end());
  ApSummary s;
  for (double v : ap) s.mean += v / ap.size();
  s.median = ap[(ap.size() - 1) / 2];
  s.p95 = ap[static_cast<size_t>(std::ceil(0.95 * ap.size())) - 1];
  s.max = ap.back();
  return s;
}

TEST(RealUr10SeriesD, AccuracyPointsBeforeAndAfterTheSeriesCSignature) {
  const auto model = testing::Ur10();
  auto c = io::ImportPoses(testing::DataPath("ur10-ipa/series_C-measurements_random_poses.csv"),
                           io::PoseImportOptions::UrIpa());
  for (auto& p : c) p.orientation.reset();  // the position-only signature
  EstimationOptions o;
  o.parameters = ParseParameterSpec(model, "geometric");
  const auto signature = Estimate(model, c, o);
  ASSERT_TRUE(signature.status.ok()) << signature.status.message;
  // Series D: 632 goals (630 the centres and corners of 70 cubes of 100, 250 or 400 mm), each once.
  const std::string d = testing::DataPath("ur10-ipa/series_D-measurements_iso_cubes.csv");
  const auto measured = io::ImportPoses(d, io::PoseImportOptions::UrIpa());
  auto goals_options = io::PoseImportOptions::UrIpa();
  goals_options.xyz_columns = {"Goal x", "Goal y", "Goal z"};  // the commanded TCP, in m
  goals_options.length_scale_to_mm = 1000.0;
  const auto goals = io::ImportPoses(d, goals_options);
  ASSERT_EQ(measured.size(), 632u);
  std::vector<Eigen::Vector3d> commanded, attained, predicted;
  Kinematics kin(model);
  for (size_t i = 0; i < measured.size(); ++i) {
    commanded.push_back(goals[i].target_in_world);
    attained.push_back(measured[i].target_in_world);
    predicted.push_back(kin.Position(Eigen::Isometry3d::Identity(), signature.params,
                                     measured[i].joints_rad.data()));
  }
  // Before: where the robot went against where it was sent. After: against where the
  // series C signature puts it, which is what a program compensated with it would be sent
  // to (so what remains is the signature's own error on these goals).
  const ApSummary before = AccuracyPoints(commanded, attained);
  const ApSummary after = AccuracyPoints(predicted, attained);
  std::cout << fmt::format(
      "series D, 632 goals: AP before mean {:.3f} median {:.3f} 95 % {:.3f} max "
      "{:.3f} mm; after mean {:.3f} median {:.3f} 95 % {:.3f} max {:.3f} mm\n",
      before.mean, before.median, before.p95, before.max, after.mean, after.median, after.p95,
      after.max);
  // The goals are the robot's own inverse of the nominal model (the goal and the nominal
  // position of the recorded joints agree to 0.1 mm), so before is the nominal error left
  // after the best rigid frame: about a millimetre over this compact volume.
  EXPECT_GT(before.mean, 0.8);
  EXPECT_LT(before.mean, 1.4);
  // The series C signature takes a third of it off; series D is another set-up, and its
  // own in-sample floor is 0.35 mm, so it does not reach C's held-out 0.45 mm.
  EXPECT_LT(after.mean, 0.75 * before.mean);
  EXPECT_LT(after.median, 0.7 * before.median);
  EXPECT_GT(after.mean, 0.35);
}

}  // namespace
}  // namespace armsig::calibration
