// Compensation: the joint angles that make the calibrated model reach a target, and the
// corrected nominal model. Truth is the forward kinematics of the calibrated model.
#include "calibration/compensation.h"

#include <gtest/gtest.h>

#include <random>

#include "calibration/synthetic.h"
#include "core/units.h"
#include "test_support.h"

namespace armsig::calibration {
namespace {

Eigen::Isometry3d Base() {
  Eigen::Isometry3d base = Eigen::Isometry3d::Identity();
  base.translate(Eigen::Vector3d(120.0, -80.0, 30.0));
  base.rotate(Eigen::AngleAxisd(0.35, Eigen::Vector3d::UnitZ()));
  return base;
}

// Targets the calibrated robot reaches at known joints: the solution from the nominal
// neighbourhood lands on each within the tolerance, near the seed (minimum-norm steps).
TEST(SolveJoints, ReachesWhatTheCalibratedModelReachesNearTheSeed) {
  const auto model = testing::Puma();
  const Eigen::VectorXd params = PaperTable3Parameters();
  std::mt19937 rng(4);
  Kinematics kin(model);
  for (const auto& truth : RandomConfigurations(model, 20, rng)) {
    const Eigen::Vector3d target = kin.Position(Base(), params, truth.data());
    const Eigen::VectorXd seed = truth + Eigen::VectorXd::Constant(6, 0.01);
    const auto s = SolveJoints(model, Base(), params, target, seed);
    ASSERT_TRUE(s.status.ok()) << s.status.message;
    EXPECT_LT((kin.Position(Base(), params, s.joints_rad.data()) - target).norm(), 1e-5);
    EXPECT_LT((s.joints_rad - seed).norm(), 0.05);  // a small correction, not another branch
  }
}

TEST(SolveJoints, OutOfReachIsNotConvergedWithTheClosestDistance) {
  const auto model = testing::Puma();
  const auto s = SolveJoints(model, Base(), Eigen::VectorXd::Zero(43),
                             Eigen::Vector3d(5000.0, 0.0, 0.0), Eigen::VectorXd::Zero(6));
  EXPECT_EQ(s.status.code, SolveCode::kNotConverged);
  EXPECT_NE(s.status.message.find("no joint angles reach the target"), std::string::npos);
  EXPECT_GT(s.residual_mm, 3000.0);
}

// A NaN seed once came back as NaN joints with status ok.
TEST(SolveJoints, NonFiniteSeedOrTargetIsNeverOk) {
  const auto model = testing::Puma();
  Eigen::VectorXd seed = Eigen::VectorXd::Zero(6);
  seed(0) = std::numeric_limits<double>::quiet_NaN();
  const auto s = SolveJoints(model, Base(), Eigen::VectorXd::Zero(43),
                             Eigen::Vector3d(500.0, 500.0, 500.0), seed);
  EXPECT_EQ(s.status.code, SolveCode::kNonFinite);
  const auto t = SolveJoints(model, Base(), Eigen::VectorXd::Zero(43),
                             Eigen::Vector3d(INFINITY, 0.0, 0.0), Eigen::VectorXd::Zero(6));
  EXPECT_FALSE(t.status.ok());
}

TEST(SolveJoints, SolutionOutsideTheJointLimitsIsOutOfRange) {
  auto model = testing::Puma();
  model.joint_min_rad.assign(6, -0.1);
  model.joint_max_rad.assign(6, 0.1);
  Eigen::VectorXd q = Eigen::VectorXd::Zero(6);
  q(1) = 1.0;  // reachable, but beyond joint 2's limit
  Kinematics kin(model);
  const Eigen::Vector3d target = kin.Position(Base(), Eigen::VectorXd::Zero(43), q.data());
  const auto s = SolveJoints(model, Base(), Eigen::VectorXd::Zero(43), target, q);
  EXPECT_EQ(s.status.code, SolveCode::kOutOfRange);
  EXPECT_NE(s.status.message.find("joint 2"), std::string::npos) << s.status.message;
}

// The corrected model's nominal positions are the calibrated model's positions (the
// h-terms carried as fixed values).
TEST(CorrectedModel, NominalOfTheCorrectedModelIsTheCalibratedRobot) {
  const auto model = testing::Puma();
  const Eigen::VectorXd params = PaperTable3Parameters();
  const RobotModel corrected = CorrectedModel(model, params, Base());
  ASSERT_TRUE(corrected.base);  // base · H1
  Kinematics calibrated(model), folded(corrected);
  std::mt19937 rng(9);
  for (const auto& q : RandomConfigurations(model, 30, rng)) {
    const Eigen::Vector3d a = calibrated.Position(Base(), params, q.data());
    const Eigen::Vector3d b = folded.Position(
        *corrected.base, Eigen::VectorXd::Zero(corrected.num_parameters()), q.data());
    EXPECT_LT((a - b).norm(), 1e-9);
  }
}

// With a known tool mounting the corrected model carries the flange's turn in its target
// point and its flange: the same positions, and the same flange orientation.
TEST(CorrectedModel, AKnownMountingsFlangeTurnIsCarriedByTheTargetAndTheFlange) {
  RobotModel model = testing::Puma();
  model.tool_mm = Eigen::Vector3d(40.0, 0.0, 235.0);
  model.flange.translation() = Eigen::Vector3d(0.0, 0.0, 135.0);
  model.tool_mounting = ToolMounting::kKnown;
  Eigen::VectorXd params = Eigen::VectorXd::Zero(model.num_parameters());
  params.head(39) = PaperTable3Parameters().head(39);
  for (int k : model.HeldParameters()) params(k) = 0.0;
  params(model.flange_turn_index()) = 0.8e-3;
  params(model.flange_turn_index() + 1) = -0.6e-3;
  const RobotModel corrected = CorrectedModel(model, params, Base());
  Kinematics calibrated(model), folded(corrected);
  std::mt19937 rng(9);
  for (const auto& q : RandomConfigurations(model, 30, rng)) {
    const Eigen::Vector3d a = calibrated.Position(Base(), params, q.data());
    const Eigen::Vector3d b = folded.Position(
        *corrected.base, Eigen::VectorXd::Zero(corrected.num_parameters()), q.data());
    EXPECT_LT((a - b).norm(), 1e-9);
    const Eigen::Matrix3d flange_a = calibrated.LastRotation() * model.flange.linear();
    const Eigen::Matrix3d flange_b = folded.LastRotation() * corrected.flange.linear();
    EXPECT_LT((flange_a - flange_b).norm(), 1e-12);
  }
}

}  // namespace
}  // namespace armsig::calibration
