// The virtual arm's motion against closed forms: a movej's trapezoid on the leading joint
// (distance, speed, time), the other joints scaled to it, braking along the path; the arm
// moving the virtual lab's robot, joint-angle errors periodic in each joint's own angle, and
// physical time scaled.
#include "simulation/joint_motion.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <thread>

#include "calibration/model.h"
#include "core/units.h"
#include "simulation/joint_errors.h"
#include "simulation/virtual_arm.h"
#include "simulation/virtual_lab.h"
#include "test_support.h"

namespace armsig::simulation {
namespace {

Eigen::VectorXd Joints(std::initializer_list<double> v) {
  Eigen::VectorXd q(static_cast<Eigen::Index>(v.size()));
  Eigen::Index k = 0;
  for (double x : v) q(k++) = x;
  return q;
}

TEST(JointMove, TheLeadingJointFollowsATrapezoidAndTheOthersScaleToIt) {
  const double a = 1.4, v = 1.05;
  const JointMove move(Joints({0, 0, 0}), Joints({3.0, -1.0, 0.5}), a, v);
  const double ramp = v / a;  // 0.75 s to reach v
  EXPECT_NEAR(move.duration_s(), 3.0 / v + ramp, 1e-12);
  // Accelerating: s = a t²/2.
  EXPECT_NEAR(move.PositionAt(0.5)(0), 0.5 * a * 0.25, 1e-12);
  EXPECT_NEAR(move.PositionAt(ramp)(0), 0.5 * a * ramp * ramp, 1e-12);
  // Cruising at v, the others at their share of it.
  EXPECT_NEAR(move.VelocityAt(1.5)(0), v, 1e-12);
  EXPECT_NEAR(move.VelocityAt(1.5)(1), -v / 3.0, 1e-12);
  EXPECT_NEAR(move.VelocityAt(1.5)(2), v / 6.0, 1e-12);
  // Symmetric: half way at half the time.
  EXPECT_NEAR(move.PositionAt(move.duration_s() / 2)(0), 1.5, 1e-12);
  // Arrived exactly, standing.
  EXPECT_EQ(move.PositionAt(move.duration_s() + 1.0), Joints({3.0, -1.0, 0.5}));
  EXPECT_EQ(move.VelocityAt(move.duration_s()).norm(), 0.0);
  // The speed is the position's derivative (central differences) throughout.
  for (double t = 0.05; t < move.duration_s(); t += 0.1) {
    const Eigen::VectorXd numeric = (move.PositionAt(t + 1e-6) - move.PositionAt(t - 1e-6)) / 2e-6;
    EXPECT_LT((numeric - move.VelocityAt(t)).cwiseAbs().maxCoeff(), 1e-5) << "t = " << t;
  }
}

TEST(JointMove, AShortTurnNeverReachesTheSpeed) {
  const double a = 1.4, v = 1.05, d = 0.1;  // v²/a = 0.7875 > d: a triangle
  const JointMove move(Joints({0}), Joints({d}), a, v);
  EXPECT_NEAR(move.duration_s(), 2.0 * std::sqrt(d / a), 1e-12);
  const double peak = move.VelocityAt(move.duration_s() / 2)(0);
  EXPECT_NEAR(peak, std::sqrt(a * d), 1e-9);
  EXPECT_LT(peak, v);
}

TEST(JointMove, AStopBrakesAlongThePath) {
  const double a = 1.4, v = 1.05, b = 3.0;
  const JointMove move(Joints({0, 0}), Joints({4.0, 2.0}), a, v);
  const double t_stop = 2.0;  // cruising: speed v, at s = v²/(2a) + v (t − v/a)
  const double s_stop = v * v / (2 * a) + v * (t_stop - v / a);
  EXPECT_NEAR(move.BrakedUntil(t_stop, b), t_stop + v / b, 1e-12);
  const auto end = move.Braked(t_stop, b, 10.0);
  EXPECT_NEAR(end.s, s_stop + v * v / (2 * b), 1e-12);
  EXPECT_NEAR(end.ds, 0.0, 1e-12);
  EXPECT_NEAR(move.PositionAlong(end.s)(1), end.s / 2.0, 1e-12);  // on the path
}

TEST(PhysicalClock, ScaledTimeRunsFasterThanTheWallClock) {
  const PhysicalClock clock(0.01);
  EXPECT_EQ(std::chrono::duration_cast<std::chrono::milliseconds>(clock.Wall(1.0)).count(), 10);
  const double before = clock.Now();
  std::this_thread::sleep_for(std::chrono::milliseconds(20));
  EXPECT_GE(clock.Now() - before, 2.0);  // at least 20 ms of wall: 2 s of physical time
}

TEST(JointAngleErrors, TheTrueAngleIsTheEncodersPlusItsHarmonics) {
  JointAngleErrors e;
  e.harmonics = {{{2e-5, 0.0}, {0.0, -1e-5}}, {}};
  EXPECT_NEAR(e.At(0, 0.3), 2e-5 * std::sin(0.3) - 1e-5 * std::cos(0.6), 1e-18);
  EXPECT_EQ(e.At(1, 0.3), 0.0);
  EXPECT_EQ(e.At(5, 0.3), 0.0);
  EXPECT_NEAR(e.TrueAngles(Joints({0.3, 1.0}))(0), 0.3 + e.At(0, 0.3), 1e-18);
  EXPECT_NEAR(e.MaxRad(), 3e-5, 1e-18);
  std::mt19937 rng(4);
  const auto random = JointAngleErrors::Random(6, 3, 4.0 * kRadPerArcsec, rng);
  ASSERT_EQ(random.harmonics.size(), 6u);
  EXPECT_EQ(random.harmonics[0].size(), 3u);
  EXPECT_GT(random.MaxRad(), 0.5 * kRadPerArcsec);
  EXPECT_LT(random.MaxRad(), 40.0 * kRadPerArcsec);  // a few arc-seconds, not minutes
}

TEST(VirtualArm, AMoveTakesItsPhysicalTimeAndLeavesTheLabsRobotWhereTheArmIs) {
  const calibration::RobotModel model = testing::Puma();
  VirtualLab lab(model, Eigen::VectorXd::Zero(model.num_parameters()), Eigen::Isometry3d::Identity());
  JointAngleErrors errors;
  errors.harmonics.assign(6, {{5e-5, 0.0}});
  lab.SetJointErrors(errors);
  VirtualArm arm(lab, PhysicalClock(0.01), Eigen::VectorXd::Zero(6));
  const Eigen::VectorXd target = Joints({0.2, -0.1, 0.3, 0, 0.1, 0});
  ASSERT_TRUE(arm.MoveJ(target, 1.4, 1.05));
  const double duration = JointMove(Eigen::VectorXd::Zero(6), target, 1.4, 1.05).duration_s();
  auto s = arm.Now();
  EXPECT_TRUE(s.moving);
  while (arm.Now().moving) std::this_thread::sleep_for(std::chrono::milliseconds(1));
  s = arm.Now();
  EXPECT_GE(s.t, duration);
  EXPECT_EQ(s.q, target);
  EXPECT_EQ(lab.Joints(), target);
  // The lab's robot stands at the true angles: the encoders' plus the joint errors.
  calibration::Kinematics kin(model);
  const Eigen::VectorXd truth = errors.TrueAngles(target);
  EXPECT_LT((lab.TruePosition("robot") -
             kin.Position(Eigen::Isometry3d::Identity(), Eigen::VectorXd::Zero(model.num_parameters()),
                          truth.data()))
                .norm(),
            1e-9);
}

TEST(VirtualArm, AProtectiveStopHaltsTheArmShortOfItsTargetUntilCleared) {
  const calibration::RobotModel model = testing::Puma();
  VirtualLab lab(model, Eigen::VectorXd::Zero(model.num_parameters()), Eigen::Isometry3d::Identity());
  VirtualArm arm(lab, PhysicalClock(0.01), Eigen::VectorXd::Zero(6));
  arm.ProtectiveStopDuringNextMove(0.5);
  const Eigen::VectorXd target = Joints({2.0, 0, 0, 0, 0, 0});
  ASSERT_TRUE(arm.MoveJ(target, 1.4, 1.05));
  const JointMove move(Eigen::VectorXd::Zero(6), target, 1.4, 1.05);
  std::this_thread::sleep_for(std::chrono::milliseconds(60));  // 6 s: stopped and standing
  const auto s = arm.Now();
  EXPECT_EQ(s.stop, VirtualArm::Stop::kProtective);
  EXPECT_FALSE(s.moving);
  const double t_stop = 0.5 * move.duration_s();
  EXPECT_NEAR(s.q(0), move.Braked(t_stop, 2.0, 1e9).s, 1e-12);  // braked at max(a, 2 rad/s²)
  EXPECT_LT(s.q(0), target(0));
  EXPECT_FALSE(arm.MoveJ(target, 1.4, 1.05));  // no move while stopped
  EXPECT_GT(arm.ClearProtectiveStop(), 2.0);   // seconds since the stop
  EXPECT_TRUE(arm.MoveJ(target, 1.4, 1.05));
}

TEST(VirtualArm, AnEmergencyStopPowersTheArmOffUntilReleasedAndPoweredOn) {
  const calibration::RobotModel model = testing::Puma();
  VirtualLab lab(model, Eigen::VectorXd::Zero(model.num_parameters()), Eigen::Isometry3d::Identity());
  VirtualArm arm(lab, PhysicalClock(0.01), Eigen::VectorXd::Zero(6));
  arm.EmergencyStop();
  EXPECT_FALSE(arm.Now().powered);
  EXPECT_FALSE(arm.PowerOn());  // the button is still pressed
  arm.ReleaseEmergencyStop();
  EXPECT_EQ(arm.Now().stop, VirtualArm::Stop::kNone);
  EXPECT_FALSE(arm.MoveJ(Joints({1, 0, 0, 0, 0, 0}), 1.4, 1.05));  // powered off
  EXPECT_TRUE(arm.PowerOn());
  EXPECT_TRUE(arm.MoveJ(Joints({1, 0, 0, 0, 0, 0}), 1.4, 1.05));
}

TEST(VirtualArm, SomethingElseTurningAJointKeepsItMovingUntilItStops) {
  const calibration::RobotModel model = testing::Puma();
  VirtualLab lab(model, Eigen::VectorXd::Zero(model.num_parameters()), Eigen::Isometry3d::Identity());
  VirtualArm arm(lab, PhysicalClock(0.01), Eigen::VectorXd::Zero(6));
  arm.Drift(5, 0.1);
  std::this_thread::sleep_for(std::chrono::milliseconds(10));
  auto s = arm.Now();
  EXPECT_DOUBLE_EQ(s.qd(5), 0.1);
  EXPECT_GT(s.q(5), 0.05);
  arm.StopDrifting();
  const double where = arm.Now().q(5);
  std::this_thread::sleep_for(std::chrono::milliseconds(5));
  s = arm.Now();
  EXPECT_EQ(s.q(5), where);  // it stays where the drift took it
  EXPECT_EQ(s.qd(5), 0.0);
}

}  // namespace
}  // namespace armsig::simulation
