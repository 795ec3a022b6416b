// A signature that never makes the robot worse: folds that hold out what a fit did not see,
// terms held to the joint arcs they were fitted on, limits on what a parameter may say,
// data checks at the door, and a predicted σ whose coverage is measured.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <random>
#include <set>

#include "calibration/data_checks.h"
#include "calibration/estimation.h"
#include "calibration/signature_limits.h"
#include "calibration/synthetic.h"
#include "calibration/terms.h"
#include "calibration/transfer_folds.h"
#include "calibration/validity.h"
#include "test_support.h"

namespace armsig::calibration {
namespace {

constexpr double kPi = std::numbers::pi;
constexpr double kDeg = kPi / 180.0;

Eigen::Isometry3d LabBase() {
  Eigen::Isometry3d base = Eigen::Isometry3d::Identity();
  base.translate(Eigen::Vector3d(1500.0, -800.0, 300.0));
  base.rotate(Eigen::AngleAxisd(0.7, Eigen::Vector3d::UnitZ()));
  return base;
}

std::vector<MeasuredPose> PumaPoses(int count, unsigned seed, double noise_mm = 0.02) {
  const RobotModel model = testing::Puma();
  std::mt19937 rng(seed);
  return SimulatePoses(model, LabBase(), PaperTable3Parameters(),
                       RandomConfigurations(model, count, rng), noise_mm, rng);
}

// --- Joint arcs ---------------------------------------------------------------------------

TEST(JointArc, ClampKeepsAnglesInsideAndTakesTheNearerEndOutside) {
  const JointArc arc{10.0 * kDeg, 100.0 * kDeg};  // 10°…110°
  EXPECT_EQ(arc.Clamp(50.0 * kDeg), 50.0 * kDeg);
  EXPECT_TRUE(arc.Contains(50.0 * kDeg));
  EXPECT_NEAR(arc.Clamp(130.0 * kDeg), 110.0 * kDeg, 1e-12);  // 20° past the end
  EXPECT_NEAR(arc.Clamp(-20.0 * kDeg), 10.0 * kDeg, 1e-12);   // 30° before the start
  // 250° is 140° past the end and 120° before the start (going round): the start, as the
  // representative nearest the angle (370°).
  EXPECT_NEAR(arc.Clamp(250.0 * kDeg), 370.0 * kDeg, 1e-12);
  // A turn later is the same joint angle for every (periodic) basis.
  EXPECT_TRUE(arc.Contains(410.0 * kDeg));
  EXPECT_TRUE(JointArc{}.Contains(1234.5));  // the whole turn
}

TEST(JointArc, ArcsCoveringIsTheComplementOfTheLargestGap) {
  // Angles at 350°, 10°, 40° and 100° (−260° is 100° again): the largest gap runs from 100°
  // to 350° (250°), so the arc starts at 350° and wraps through zero over 110° to 100°.
  std::vector<Eigen::VectorXd> q;
  for (double a : {350.0, 10.0, 40.0, 100.0, -260.0}) q.push_back(Eigen::VectorXd::Constant(1, a * kDeg));
  const auto arcs = ArcsCovering(q, 1);
  ASSERT_EQ(arcs.size(), 1u);
  EXPECT_NEAR(std::fmod(arcs[0].start_rad + 2 * kPi, 2 * kPi), 350.0 * kDeg, 1e-6);
  EXPECT_NEAR(arcs[0].length_rad, 110.0 * kDeg, 1e-6);
  for (const auto& v : q) EXPECT_TRUE(arcs[0].Contains(v(0))) << v(0) / kDeg;
  EXPECT_FALSE(arcs[0].Contains(270.0 * kDeg));
  EXPECT_FALSE(arcs[0].Contains(200.0 * kDeg));
  EXPECT_TRUE(arcs[0].Contains(0.0));
}

TEST(TermSupport, TermsOutsideTheirArcsKeepTheirEdgeValueAndAreNamed) {
  RobotModel model = testing::Puma();  // h1…h4 on joints 2 and 3
  std::vector<Eigen::VectorXd> q;
  for (int k = 0; k < 20; ++k) {
    Eigen::VectorXd c = Eigen::VectorXd::Zero(6);
    c(1) = (-40.0 + 4.0 * k) * kDeg;  // joint 2: −40°…36°
    c(2) = (10.0 + 2.0 * k) * kDeg;   // joint 3: 10°…48°
    q.push_back(c);
  }
  model.term_support = ArcsCovering(q, 6);
  Eigen::VectorXd inside = Eigen::VectorXd::Zero(6), outside = inside, edge = inside;
  inside << 0.3, -10 * kDeg, 20 * kDeg, 0, 0, 0;
  outside << 0.3, 80 * kDeg, 20 * kDeg, 0, 0, 0;
  edge << 0.3, 36 * kDeg, 20 * kDeg, 0, 0, 0;
  EXPECT_TRUE(TermsHeldAtSupport(model, inside.data()).terms.empty());
  const HeldTerms held = TermsHeldAtSupport(model, outside.data());
  // Joint 1 (0.3 rad) lies outside its arc too (the fit never turned it), but no term
  // depends on it: only joint 2 is named.
  EXPECT_EQ(held.joints, std::vector<int>{1});
  // Every PUMA term depends on joint 2 (cos θ2, cos(θ2+θ3), its sign).
  EXPECT_EQ(held.terms.size(), 4u);
  std::vector<double> clamped(4), at_edge(4);
  EvaluateTerms(model, outside.data(), clamped.data());
  RobotModel free = model;
  free.term_support.clear();
  EvaluateTerms(free, edge.data(), at_edge.data());
  // The arcs reach a nanoradian past the outermost fit angle.
  for (int k = 0; k < 4; ++k) EXPECT_NEAR(clamped[k], at_edge[k], 1e-8) << k;
}

// --- Transfer folds -----------------------------------------------------------------------

TEST(TransferFolds, TwoLargeSessionsAreHeldOutWholeAndSmallOnesSpreadOverThem) {
  std::vector<MeasuredPose> poses = PumaPoses(120, 3);
  for (int i = 0; i < 120; ++i) poses[i].frame = i < 60 ? 1 : i < 110 ? 2 : 3;  // 60, 50, 10
  const TransferFolds f = AssignTransferFolds(testing::Puma(), poses, 5, 1);
  EXPECT_EQ(f.kind, TransferFolds::Kind::kSessions);
  ASSERT_EQ(f.folds, 2);
  for (int i = 0; i < 110; ++i) EXPECT_EQ(f.fold_of_pose[i], f.fold_of_pose[i < 60 ? 0 : 60]);
  EXPECT_NE(f.fold_of_pose[0], f.fold_of_pose[60]);
}

TEST(TransferFolds, OneSessionIsCutIntoCompactJointSpaceRegions) {
  const std::vector<MeasuredPose> poses = PumaPoses(400, 5);
  const TransferFolds f = AssignTransferFolds(testing::Puma(), poses, 5, 1);
  EXPECT_EQ(f.kind, TransferFolds::Kind::kJointBlocks);
  ASSERT_EQ(f.folds, 5);
  // Compact: a pose's nearest neighbour (in joint space) is in its own block far more often
  // than a random dealing of the same block sizes would put it there (about 1/5).
  int same = 0;
  for (size_t i = 0; i < poses.size(); ++i) {
    double best = 1e300;
    size_t nearest = i;
    for (size_t j = 0; j < poses.size(); ++j) {
      if (j == i) continue;
      const double d = (poses[i].joints_rad - poses[j].joints_rad).squaredNorm();
      if (d < best) best = d, nearest = j;
    }
    same += f.fold_of_pose[i] == f.fold_of_pose[nearest];
  }
  EXPECT_GT(same, 0.6 * poses.size());
  // The same seed, the same blocks.
  EXPECT_EQ(AssignTransferFolds(testing::Puma(), poses, 5, 1).fold_of_pose, f.fold_of_pose);
}

// --- Term selection on data the fit did not see -------------------------------------------

// A term that only fits noise in one region of joint space is not kept; one the robot has is.
TEST(TransferFolds, SelectionKeepsARealTermAndNotAModelOfTheNoise) {
  RobotModel model = WithGeneratedTerms(testing::Puma(), {TermFamily::kHarmonics});
  model.nongeometric.erase(model.nongeometric.begin(), model.nongeometric.begin() + 4);
  std::mt19937 rng(11);
  const auto joints = RandomConfigurations(model, 300, rng);
  Eigen::VectorXd truth = Eigen::VectorXd::Zero(model.num_parameters());
  const int e2_s1 = model.IndexOf("e2_s1");
  ASSERT_GE(e2_s1, 0);
  truth(e2_s1) = 0.5e-3;  // 0.5 mrad once per turn of joint 2: ~0.6 mm at the tool
  const auto poses = SimulatePoses(model, LabBase(), truth, joints, 0.02, rng);
  EstimationOptions options;
  const AutoSelection s = SelectTerms(model, poses, options);
  EXPECT_NE(s.folds.find("joint-space blocks"), std::string::npos) << s.folds;
  const bool kept = std::find(s.parameters.begin(), s.parameters.end(), e2_s1) != s.parameters.end();
  EXPECT_TRUE(kept);
  // Nothing else: the other harmonics have no truth behind them.
  EXPECT_EQ(static_cast<int>(s.parameters.size()), model.num_geometric() + 1);
}

// --- What a parameter may say ---------------------------------------------------------------

TEST(SignatureLimits, ThePapersPumaIsPlausibleAnotherRobotsLinkIsNot) {
  const RobotModel model = testing::Puma();
  std::vector<int> all(model.num_parameters());
  for (int k = 0; k < model.num_parameters(); ++k) all[k] = k;
  EXPECT_TRUE(ImplausibleParameters(model, PaperTable3Parameters(), all).empty());
  Eigen::VectorXd p = PaperTable3Parameters();
  p(model.IndexOf("a3")) = -330.0;     // "link 2 length changed by −330 mm"
  p(model.IndexOf("beta2")) = 1.84;    // 105° of axis tilt
  const auto bad = ImplausibleParameters(model, p, all);
  ASSERT_EQ(bad.size(), 2u);
  EXPECT_EQ(bad[0].name, "beta2");  // 37 × its limit before 33 ×
  EXPECT_NEAR(bad[0].value, 1840.0, 1e-9);
  EXPECT_NE(bad[0].Describe().find("+1840 mrad"), std::string::npos) << bad[0].Describe();
  EXPECT_EQ(bad[1].name, "a3");
  EXPECT_EQ(bad[1].unit, "mm");
  // An unidentified parameter says nothing.
  EXPECT_TRUE(ImplausibleParameters(model, p, {0, 1, 2}).empty());
  EXPECT_FALSE(PlausibleCauseSize(1.84, true, false));
  EXPECT_TRUE(PlausibleCauseSize(0.5e-3, true, false));
  EXPECT_FALSE(PlausibleCauseSize(-0.486, false, true));  // −4.86e5 ppm
}

// --- Data at the door ----------------------------------------------------------------------

TEST(DataChecks, TheRobotsOwnPosesFit) {
  const auto check = CheckPosesAgainstModel(testing::Puma(), PumaPoses(60, 7));
  EXPECT_TRUE(check.checked);
  EXPECT_TRUE(check.fits);
  EXPECT_LT(check.rms_mm, 15.0);  // the paper's nominal error, about 6 mm
}

TEST(DataChecks, RadiansReadAsDegreesAreNamed) {
  auto poses = PumaPoses(60, 8);
  for (auto& p : poses) p.joints_rad *= kDeg;  // the file's radians taken for degrees
  const auto check = CheckPosesAgainstModel(testing::Puma(), poses);
  EXPECT_FALSE(check.fits);
  EXPECT_GT(check.rms_mm, 100.0);
  EXPECT_EQ(check.reading, "the joint values are radians, not degrees");
  EXPECT_LT(check.reading_rms_mm, 15.0);
}

TEST(DataChecks, MetresReadAsMillimetresAreNamed) {
  auto poses = PumaPoses(60, 9);
  for (auto& p : poses) p.target_in_world /= 1000.0;
  const auto check = CheckPosesAgainstModel(testing::Puma(), poses);
  EXPECT_FALSE(check.fits);
  EXPECT_EQ(check.reading, "the positions are metres, not millimetres");
}

TEST(DataChecks, AnotherRobotsPosesFitNoReading) {
  // The UR10's poses offered to the PUMA's model.
  const RobotModel ur10 = testing::Ur10();
  std::mt19937 rng(10);
  const auto poses = SimulatePoses(ur10, LabBase(), Eigen::VectorXd::Zero(ur10.num_parameters()),
                                   RandomConfigurations(ur10, 60, rng), 0.02, rng);
  const auto check = CheckPosesAgainstModel(testing::Puma(), poses);
  EXPECT_FALSE(check.fits);
  EXPECT_GT(check.rms_mm, 100.0);
  EXPECT_TRUE(check.reading.empty()) << check.reading;
}

TEST(DataChecks, ThreeReadingsOfAnUnmovedRobotAreOneConfiguration) {
  auto poses = PumaPoses(3, 12);
  poses[1].joints_rad = poses[0].joints_rad;
  poses[2].joints_rad = poses[0].joints_rad + Eigen::VectorXd::Constant(6, 1e-8);
  EXPECT_EQ(DistinctConfigurations(poses), 1);
  poses[2].joints_rad(3) += 0.01;
  EXPECT_EQ(DistinctConfigurations(poses), 2);
}

// --- The predicted σ -----------------------------------------------------------------------

// A robot with an error the model cannot represent (a harmonic of joint 1 the model lacks):
// the parameters' own σ says microns, the held-out σ says what the model leaves, and a
// prediction's σ covers new configurations about 95 % of the time.
TEST(Validity, HeldOutSigmaCoversNewConfigurations) {
  RobotModel truth_model = WithGeneratedTerms(testing::Puma(), {TermFamily::kHarmonics});
  const int e1 = truth_model.IndexOf("e1_s2");
  ASSERT_GE(e1, 0);
  Eigen::VectorXd truth = Eigen::VectorXd::Zero(truth_model.num_parameters());
  truth.head(43) = PaperTable3Parameters();
  truth(e1) = 0.3e-3;
  std::mt19937 rng(21);
  const auto fit_poses = SimulatePoses(truth_model, LabBase(), truth,
                                       RandomConfigurations(truth_model, 300, rng), 0.02, rng);
  const auto new_poses = SimulatePoses(truth_model, LabBase(), truth,
                                       RandomConfigurations(truth_model, 300, rng), 0.02, rng);
  const RobotModel model = testing::Puma();  // without the harmonic
  EstimationOptions options;
  const EstimationResult fit = Estimate(model, fit_poses, options);
  ASSERT_TRUE(fit.status.ok());
  const SetValidity v = EstimateValidity(model, fit, fit_poses, nullptr);
  ASSERT_EQ(v.term_arcs.size(), 6u);
  EXPECT_GT(v.sigma_inside_mm, 0.05);  // the harmonic's ~0.2 mm, not the 0.02 mm noise
  EXPECT_GE(v.sigma_outside_mm, v.sigma_inside_mm);
  EXPECT_NEAR(v.coverage_inside, 0.95, 0.05);
  int within = 0;
  const auto residuals = Residuals(model, fit.world_from_base, fit.params, new_poses);
  for (size_t i = 0; i < new_poses.size(); ++i) {
    const double sp = ParametricSigmaMm(model, fit.params, fit.identifiability.identified,
                                        fit.covariance, new_poses[i].joints_rad);
    within += residuals[i].norm() <= kCoverageRadius * PredictionSigmaMm(sp, v, true);
  }
  EXPECT_NEAR(within / 300.0, 0.95, 0.05);
}

}  // namespace
}  // namespace armsig::calibration
