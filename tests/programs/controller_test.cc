// The controllers' own kinematics: forward and inverse on their models, the configuration
// labels, and the UR's factory kinematics. Truth: the forward kinematics at known joints.
#include "programs/controller.h"

#include <gtest/gtest.h>

#include <random>

#include "calibration/synthetic.h"
#include "program_test_support.h"

namespace armsig::programs {
namespace {

std::vector<Eigen::VectorXd> Configurations(const calibration::RobotModel& model, int count, unsigned seed) {
  std::mt19937 rng(seed);
  std::vector<Eigen::VectorXd> out;
  for (auto q : calibration::RandomConfigurations(model, count * 3, rng)) {
    // Off the wrist singularity and inside the limits, as taught points are.
    if (std::abs(q(4)) < 0.2) continue;
    out.push_back(q);
    if (static_cast<int>(out.size()) == count) break;
  }
  return out;
}

Eigen::Isometry3d Tool() {
  Eigen::Isometry3d tool = Eigen::Isometry3d::Identity();
  tool.translate(Eigen::Vector3d(12.0, -5.0, 180.0));
  tool.rotate(Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitX()));
  return tool;
}

// A KUKA's Status and Turn name one solution: the inverse with them returns the joints the
// pose came from.
TEST(ControllerInverse, KukaStatusAndTurnPickTheTaughtSolution) {
  const ControllerModel c = NominalController(testing::Kr16_2(), ControllerKind::kKuka, "test");
  // The elbow offset's angle, below A3 = 0 in KUKA's signs (models/kr16_2.yaml).
  EXPECT_NEAR(c.stretched_q3_rad, -std::atan2(35.0, 670.0), 1e-6);
  int checked = 0;
  for (const auto& q : Configurations(c.model, 25, 3)) {
    const ArmConfiguration a = ConfigurationOf(c, q);
    InverseRequest r;
    r.tcp = TcpPose(c, q, Tool());
    r.tool = Tool();
    r.stated.kuka_status = a.kuka_status;
    r.stated.kuka_turn = a.kuka_turn;
    const InverseSolution s = ControllerInverse(c, r);
    ASSERT_TRUE(s.joints_rad) << s.why;
    EXPECT_LT((*s.joints_rad - q).cwiseAbs().maxCoeff(), 1e-7) << q.transpose();
    ++checked;
  }
  EXPECT_EQ(checked, 25);
}

TEST(ControllerInverse, AbbConfdataPicksTheTaughtSolution) {
  const ControllerModel c = NominalController(testing::Irb4600(), ControllerKind::kAbb, "test");
  // At the zero configuration the wrist centre is in front of axis 1 and of the lower arm.
  EXPECT_EQ(ConfigurationOf(c, Eigen::VectorXd::Zero(6)).abb_cf, (std::array<int, 4>{0, 0, 0, 0}));
  for (const auto& q : Configurations(c.model, 25, 5)) {
    InverseRequest r;
    r.tcp = TcpPose(c, q, Tool());
    r.tool = Tool();
    r.stated.abb_cf = ConfigurationOf(c, q).abb_cf;
    const InverseSolution s = ControllerInverse(c, r);
    ASSERT_TRUE(s.joints_rad) << s.why;
    EXPECT_LT((*s.joints_rad - q).cwiseAbs().maxCoeff(), 1e-7) << q.transpose();
  }
}

// A UR picks the solution nearest the joints it starts from.
TEST(ControllerInverse, UrNearestSolution) {
  const ControllerModel c = NominalController(testing::Ur10(), ControllerKind::kUniversalRobots, "test");
  for (const auto& q : Configurations(c.model, 20, 7)) {
    InverseRequest r;
    r.tcp = TcpPose(c, q, Tool());
    r.tool = Tool();
    r.near_rad = q + Eigen::VectorXd::Constant(6, 0.05);
    const InverseSolution s = ControllerInverse(c, r);
    ASSERT_TRUE(s.joints_rad) << s.why;
    EXPECT_LT((*s.joints_rad - q).cwiseAbs().maxCoeff(), 1e-7);
  }
  InverseRequest far;
  far.tcp.translation() = Eigen::Vector3d(4000, 0, 0);
  const InverseSolution none = ControllerInverse(c, far);
  EXPECT_FALSE(none.joints_rad);
  EXPECT_FALSE(none.reachable);
  EXPECT_NE(none.why.find("out of reach"), std::string::npos);
}

// A configuration the pose has no solution in is named with the ones it has.
TEST(ControllerInverse, StatedConfigurationWithoutSolutionIsNamed) {
  const ControllerModel c = NominalController(testing::Kr16_2(), ControllerKind::kKuka, "test");
  Eigen::VectorXd q(6);
  q << 0.3, -1.2, 1.4, 0.2, 0.8, -0.4;
  InverseRequest r;
  r.tcp = TcpPose(c, q, Tool());
  r.tool = Tool();
  r.stated.kuka_status = ConfigurationOf(c, q).kuka_status;
  r.stated.kuka_turn = 63;  // every axis negative: A1 = 0.3 rad is not
  const InverseSolution s = ControllerInverse(c, r);
  EXPECT_FALSE(s.joints_rad);
  EXPECT_TRUE(s.reachable);
  EXPECT_NE(s.why.find("no solution in the configuration it states (S"), std::string::npos) << s.why;
}

// The UR's own kinematics as KinematicsInfo gives them: the nominal DH reproduce the nominal
// model; a calibrated one moves the flange by what its deltas make.
TEST(UrController, KinematicsInfoAgreesWithTheNominalModel) {
  const ControllerModel nominal = NominalController(testing::Ur10(), ControllerKind::kUniversalRobots, "test");
  UrKinematics k;
  k.theta = {0, 0, 0, 0, 0, 0};
  k.a = {0, -0.612, -0.5723, 0, 0, 0};
  k.d = {0.1273, 0, 0, 0.163941, 0.1157, 0.0922};
  k.alpha = {kPi / 2, 0, 0, kPi / 2, -kPi / 2, 0};
  k.source = "test";
  const ControllerModel ur = UrController(k);
  for (const auto& q : Configurations(nominal.model, 10, 11))
    EXPECT_TRUE(FlangePose(ur, q).isApprox(FlangePose(nominal, q), 1e-12));
  // A joint-2 offset of 1 mrad turns everything beyond joint 2 by 1 mrad about its axis.
  k.theta[1] = 1e-3;
  const ControllerModel turned = UrController(k);
  Eigen::VectorXd q = Eigen::VectorXd::Zero(6);
  q(1) = -0.5;
  Eigen::VectorXd q_turned = q;
  q_turned(1) += 1e-3;
  EXPECT_TRUE(FlangePose(turned, q).isApprox(FlangePose(nominal, q_turned), 1e-12));
}

}  // namespace
}  // namespace armsig::programs
