// The fit with measured orientations (a 6-DoF target): the derivative it linearises with,
// synthetic truth recovered within its sigmas, variance components that find the two
// groups' noise, a probe remounted between set-ups, and position-only data unchanged.
#include <gtest/gtest.h>

#include <random>

#include "calibration/estimation.h"
#include "calibration/orientation.h"
#include "calibration/synthetic.h"
#include "test_support.h"

namespace armsig::calibration {
namespace {

Eigen::Isometry3d SomeBase() {
  Eigen::Isometry3d base = Eigen::Isometry3d::Identity();
  base.rotate(Eigen::AngleAxisd(2.1, Eigen::Vector3d(0.3, -0.5, 0.8).normalized()));
  base.translation() << 400.0, -3200.0, 200.0;
  return base;
}

// The IPA probe's rotation on the UR10 flange: a quarter turn about the flange axis and a
// tenth of a degree of tilt.
Eigen::Matrix3d ProbeRotation() {
  return (Eigen::AngleAxisd(-M_PI / 2, Eigen::Vector3d::UnitZ()) *
          Eigen::AngleAxisd(1.7e-3, Eigen::Vector3d(1, 2, 0).normalized()))
      .toRotationMatrix();
}

// Two sessions as one fit sees them: `first` in frame 1, `second` in frame 2 with ids of
// their own (S0, S1, …); with `every_other_without_orientation`, the odd ones of the second
// session lose their measured orientation.
std::vector<MeasuredPose> TwoSessions(std::vector<MeasuredPose> first,
                                      std::vector<MeasuredPose> second,
                                      bool every_other_without_orientation = false) {
  std::vector<MeasuredPose> poses;
  for (auto& p : first) {
    p.frame = 1;
    poses.push_back(p);
  }
  for (size_t i = 0; i < second.size(); ++i) {
    second[i].frame = 2;
    second[i].id = "S" + std::to_string(i);
    if (every_other_without_orientation && i % 2) second[i].orientation.reset();
    poses.push_back(second[i]);
  }
  return poses;
}

TEST(LineariseOrientation, MatchesCentralDifferencesByEveryParameterAndTheToolTurn) {
  // The residual ε(p) = log(R_measᵀ·R_last(p)·R_tool) against its linearisation
  // by_world_turn · (rotation rows of PoseAndJacobian), and ε(δ) with R_tool·exp([δ]×)
  // against by_tool_turn; at a residual of a few mrad, as real data leave.
  std::mt19937 rng(5);
  const auto model = testing::Ur10();
  for (int trial = 0; trial < 5; ++trial) {
    const Eigen::VectorXd params = RandomParameters(model, 1.0, 2e-3, 1e-3, rng);
    const Eigen::VectorXd q = RandomConfigurations(model, 1, rng, 3.0)[0];
    Kinematics kin(model);
    Eigen::Matrix<double, 6, Eigen::Dynamic> j(6, model.num_parameters());
    kin.PoseAndJacobian(SomeBase(), params, q.data(), j);
    const Eigen::Matrix3d measured =
        kin.LastRotation() * ProbeRotation() * RotationFromVector({2e-3, -3e-3, 1e-3});
    const auto l = LineariseOrientation(measured, kin.LastRotation(), ProbeRotation());
    const double h = 1e-7;
    for (int k = 0; k < model.num_parameters(); ++k) {
      Eigen::VectorXd plus = params, minus = params;
      plus(k) += h;
      minus(k) -= h;
      kin.Position(SomeBase(), plus, q.data());
      const Eigen::Vector3d up = OrientationResidual(measured, kin.LastRotation() * ProbeRotation());
      kin.Position(SomeBase(), minus, q.data());
      const Eigen::Vector3d down =
          OrientationResidual(measured, kin.LastRotation() * ProbeRotation());
      EXPECT_LT(((up - down) / (2 * h) - l.by_world_turn * j.col(k).tail<3>()).norm(), 1e-6)
          << model.ParameterNames()[k];
    }
    kin.Position(SomeBase(), params, q.data());
    for (int k = 0; k < 3; ++k) {
      Eigen::Vector3d d = Eigen::Vector3d::Zero();
      d(k) = h;
      const Eigen::Vector3d up = OrientationResidual(
          measured, kin.LastRotation() * ProbeRotation() * RotationFromVector(d));
      const Eigen::Vector3d down = OrientationResidual(
          measured, kin.LastRotation() * ProbeRotation() * RotationFromVector(-d));
      EXPECT_LT(((up - down) / (2 * h) - l.by_tool_turn.col(k)).norm(), 1e-6) << "tool " << k;
    }
  }
}

// A UR10 whose true errors are confined to the parameters 6-DoF data identify (the others
// stay at zero in the fit, so a truth outside them could not be compared parameter by
// parameter), measured with a known base and probe rotation.
struct SixDofLab {
  RobotModel model;
  Eigen::VectorXd truth;
  std::vector<MeasuredPose> fit, check;
};

SixDofLab MakeLab(double noise_mm, double noise_rad, unsigned seed) {
  SixDofLab lab;
  lab.model = testing::Ur10();
  lab.model.base = SomeBase();  // given: the first joint's parameters are then the truth's
  std::mt19937 rng(seed);
  const auto configurations = RandomConfigurations(lab.model, 300, rng, 3.0);
  const Eigen::VectorXd zero = Eigen::VectorXd::Zero(lab.model.num_parameters());
  auto probe = SimulateSixDofPoses(lab.model, SomeBase(), zero, ProbeRotation(), configurations,
                                   0.0, 0.0, rng);
  EstimationOptions o;
  o.parameters = ParseParameterSpec(lab.model, "geometric");
  const auto identified = Estimate(lab.model, probe, o).identifiability.identified;
  lab.truth = zero;
  const Eigen::VectorXd random = RandomParameters(lab.model, 1.0, 1e-3, 0.0, rng);
  for (int k : identified) lab.truth(k) = random(k);
  lab.fit = SimulateSixDofPoses(lab.model, SomeBase(), lab.truth, ProbeRotation(), configurations,
                                noise_mm, noise_rad, rng);
  lab.check = SimulateSixDofPoses(lab.model, SomeBase(), lab.truth, ProbeRotation(),
                                  RandomConfigurations(lab.model, 100, rng, 3.0), 0.0, 0.0, rng);
  return lab;
}

TEST(SixDofFit, OrientationsIdentifyMoreOfTheWristAndTheTruthIsRecoveredWithinItsSigmas) {
  const SixDofLab lab = MakeLab(0.02, 1e-5, 21);
  EstimationOptions o;
  o.parameters = ParseParameterSpec(lab.model, "geometric");
  const auto r = Estimate(lab.model, lab.fit, o);
  ASSERT_TRUE(r.status.ok()) << r.status.message;
  EstimationOptions positions = o;
  positions.use_orientation = false;
  const auto p = Estimate(lab.model, lab.fit, positions);
  ASSERT_TRUE(p.status.ok()) << p.status.message;
  // With the probe on the joint-6 axis, positions leave the wrist's turns about it and the
  // tool's rotation unseen: orientations add what only they see.
  EXPECT_GT(r.identifiability.rank, p.identifiability.rank);
  EXPECT_EQ(r.orientation_poses, 300);
  // Every identified parameter within 4σ of the truth, and their normalised errors as
  // scattered as σ says (Σz²/k near 1).
  double z2 = 0.0;
  for (int k : r.identifiability.identified) {
    const double z = (r.params(k) - lab.truth(k)) / r.sigmas(k);
    EXPECT_LT(std::abs(z), 4.0) << lab.model.ParameterNames()[k];
    z2 += z * z / r.identifiability.identified.size();
  }
  EXPECT_GT(z2, 0.3);
  EXPECT_LT(z2, 2.0);
  // Variance components find the two groups' noise and weigh them by its ratio.
  EXPECT_NEAR(r.sigma0_mm, 0.02, 0.002);
  EXPECT_NEAR(r.sigma0_rad, 1e-5, 1e-6);
  EXPECT_NEAR(r.orientation_weight_mm_per_rad, 2000.0, 200.0);
  // The probe's rotation and the pose of new configurations, position and orientation.
  ASSERT_NE(r.tool_rotation_of(r.reference_frame), nullptr);
  EXPECT_LT(RotationVector(ProbeRotation().transpose() * *r.tool_rotation_of(0)).norm(), 1e-5);
  const auto position_errors = Residuals(lab.model, r.bases, r.params, lab.check);
  EXPECT_LT(Summarise(Distances(position_errors)).max_mm, 0.02);
  const auto angles =
      Angles(OrientationResiduals(lab.model, r.bases, r.tool_rotations, r.params, lab.check));
  ASSERT_EQ(angles.size(), lab.check.size());
  EXPECT_LT(SummariseAngles(angles).max_rad, 1e-5);
  EXPECT_LT(r.fit_angle.mean_rad, 3e-5);
  EXPECT_GT(r.nominal_angle.mean_rad, 1e-3);  // the errors turn the probe by mrad
}

TEST(SixDofFit, AFixedWeightIsUsedAsGivenAndPositionOnlyDataFitAsBefore) {
  const SixDofLab lab = MakeLab(0.02, 1e-5, 22);
  EstimationOptions o;
  o.parameters = ParseParameterSpec(lab.model, "geometric");
  o.orientation_weight_mm_per_rad = 500.0;
  const auto fixed = Estimate(lab.model, lab.fit, o);
  ASSERT_TRUE(fixed.status.ok()) << fixed.status.message;
  EXPECT_EQ(fixed.orientation_weight_mm_per_rad, 500.0);
  // Orientations ignored, or absent: the same fit, to the last bit, with nothing of them.
  EstimationOptions positions = o;
  positions.use_orientation = false;
  std::vector<MeasuredPose> stripped = lab.fit;
  for (auto& pose : stripped) pose.orientation.reset();
  const auto ignored = Estimate(lab.model, lab.fit, positions);
  const auto absent = Estimate(lab.model, stripped, o);
  EXPECT_EQ(ignored.params, absent.params);
  EXPECT_EQ(ignored.sigmas.array().isNaN().count(), absent.sigmas.array().isNaN().count());
  EXPECT_EQ(ignored.sigma0_mm, absent.sigma0_mm);
  EXPECT_EQ(ignored.iterations, absent.iterations);
  EXPECT_TRUE(absent.tool_rotations.empty());
  EXPECT_EQ(absent.orientation_weight_mm_per_rad, 0.0);
  EXPECT_TRUE(std::isnan(absent.sigma0_rad));
  EXPECT_EQ(absent.redundancy, 3 * 300 - absent.identifiability.rank);
  EXPECT_EQ(fixed.redundancy, 6 * 300 - fixed.identifiability.rank - 3);
}

TEST(SixDofFit, APerSetUpToolRotationFollowsAProbeRemountedBetweenSessions) {
  // Two sessions, each with its own base (the tracker moved) and its own probe rotation (the
  // probe taken off and screwed on again, 0.2° off), half of the second without
  // orientations: one signature, two bases, two tool rotations.
  RobotModel model = testing::Ur10();
  std::mt19937 rng(31);
  const Eigen::VectorXd truth = RandomParameters(model, 0.5, 5e-4, 0.0, rng);
  Eigen::Isometry3d moved = SomeBase();
  moved.prerotate(Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitZ()));
  moved.pretranslate(Eigen::Vector3d(800.0, 150.0, -20.0));
  const Eigen::Matrix3d remounted =
      ProbeRotation() * Eigen::AngleAxisd(3.5e-3, Eigen::Vector3d(0.2, 0.1, 1).normalized()).toRotationMatrix();
  auto first = SimulateSixDofPoses(model, SomeBase(), truth, ProbeRotation(),
                                   RandomConfigurations(model, 150, rng, 3.0), 0.02, 1e-5, rng);
  auto second = SimulateSixDofPoses(model, moved, truth, remounted,
                                    RandomConfigurations(model, 150, rng, 3.0), 0.02, 1e-5, rng);
  const std::vector<MeasuredPose> poses = TwoSessions(first, second, true);
  EstimationOptions o;
  o.parameters = ParseParameterSpec(model, "geometric");
  const auto r = Estimate(model, poses, o);
  ASSERT_TRUE(r.status.ok()) << r.status.message;
  EXPECT_EQ(r.orientation_poses, 225);
  ASSERT_EQ(r.tool_rotations.size(), 2u);
  // Each session's probe rotation relative to its own base: the tool rotations are defined
  // up to what the last link's parameters absorb, the same in both sessions, so their
  // difference is the remount.
  const Eigen::Matrix3d difference =
      r.tool_rotations.at(1).transpose() * r.tool_rotations.at(2);
  EXPECT_LT(RotationVector((ProbeRotation().transpose() * remounted).transpose() * difference).norm(),
            2e-5);
  // Both sessions' poses land within the noise.
  EXPECT_LT(r.fit.mean_mm, 0.05);
  EXPECT_LT(r.fit_angle.mean_rad, 3e-5);
  EXPECT_EQ(r.fit_orientation_residuals.size(), poses.size());
  EXPECT_FALSE(r.fit_orientation_residuals.back().has_value());
}

// The probe stayed on between the sessions: --tool-rotation shared makes its rotation one
// unknown for both (three fewer), which then holds the same value for each; on data where it
// was remounted the shared rotation cannot follow and the orientation residuals show it.
TEST(SixDofFit, ASharedToolRotationIsOneUnknownForSessionsWhoseProbeStayedOn) {
  RobotModel model = testing::Ur10();
  std::mt19937 rng(32);
  const Eigen::VectorXd truth = RandomParameters(model, 0.5, 5e-4, 0.0, rng);
  Eigen::Isometry3d moved = SomeBase();
  moved.prerotate(Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitZ()));
  moved.pretranslate(Eigen::Vector3d(800.0, 150.0, -20.0));
  const auto sessions = [&](const Eigen::Matrix3d& second_probe) {
    std::mt19937 draw(33);
    auto first = SimulateSixDofPoses(model, SomeBase(), truth, ProbeRotation(),
                                     RandomConfigurations(model, 150, draw, 3.0), 0.02, 1e-5, draw);
    auto second = SimulateSixDofPoses(model, moved, truth, second_probe,
                                      RandomConfigurations(model, 60, draw, 3.0), 0.02, 1e-5, draw);
    return TwoSessions(first, second);
  };
  EstimationOptions own;
  own.parameters = ParseParameterSpec(model, "geometric");
  EstimationOptions shared = own;
  shared.shared_tool_rotation = true;

  const auto stayed = sessions(ProbeRotation());
  const auto a = Estimate(model, stayed, own), b = Estimate(model, stayed, shared);
  ASSERT_TRUE(a.status.ok()) << a.status.message;
  ASSERT_TRUE(b.status.ok()) << b.status.message;
  EXPECT_FALSE(a.tool_rotation_shared);
  EXPECT_TRUE(b.tool_rotation_shared);
  EXPECT_EQ(b.identifiability.rank, a.identifiability.rank);
  EXPECT_EQ(b.redundancy, a.redundancy + 3);
  ASSERT_EQ(b.tool_rotations.size(), 2u);
  EXPECT_EQ(b.tool_rotations.at(1), b.tool_rotations.at(2));
  // Within the noise, as the own-rotation fit; new configurations of the second session
  // (noise-free truth) predicted in position and orientation within it.
  EXPECT_LT(b.fit.mean_mm, 0.05);
  EXPECT_LT(b.fit_angle.mean_rad, 3e-5);
  auto check = SimulateSixDofPoses(model, moved, truth, ProbeRotation(),
                                   RandomConfigurations(model, 50, rng, 3.0), 0.0, 0.0, rng);
  for (auto& p : check) p.frame = 2;
  EXPECT_LT(Summarise(Distances(Residuals(model, b.bases, b.params, check))).max_mm, 0.03);
  const auto angles =
      Angles(OrientationResiduals(model, b.bases, b.tool_rotations, b.params, check));
  ASSERT_EQ(angles.size(), check.size());
  EXPECT_LT(SummariseAngles(angles).max_rad, 2e-5);

  const Eigen::Matrix3d remounted =
      ProbeRotation() *
      Eigen::AngleAxisd(3.5e-3, Eigen::Vector3d(0.2, 0.1, 1).normalized()).toRotationMatrix();
  const auto moved_probe = sessions(remounted);
  const auto c = Estimate(model, moved_probe, own), d = Estimate(model, moved_probe, shared);
  ASSERT_TRUE(c.status.ok()) << c.status.message;
  ASSERT_TRUE(d.status.ok()) << d.status.message;
  EXPECT_LT(c.fit_angle.mean_rad, 3e-5);
  EXPECT_GT(d.fit_angle.mean_rad, 3.0 * c.fit_angle.mean_rad);
}

}  // namespace
}  // namespace armsig::calibration
