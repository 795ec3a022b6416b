// models/kr16_2.yaml against the KR 16-2's kinematic chain as ROS-Industrial's URDF gives it
// (kuka_experimental, kuka_kr16_support/urdf/kr16_2_macro.xacro, commit 0849a26): joint
// origins and axes in KUKA's own zero and signs, built here independently of armsig's model
// code from rotations about each joint's axis.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <numbers>
#include <random>

#include "calibration/model.h"
#include "io/model_yaml.h"

namespace armsig::calibration {
namespace {

constexpr double kKukaDeg = std::numbers::pi / 180.0;

// The URDF's chain from $ROBROOT (base_link): each joint's origin in its parent, its axis,
// then the reflector 100 mm beyond the flange along the flange's axis (tool0's z, which is
// link_6's +x).
Eigen::Vector3d UrdfReflector(const Eigen::VectorXd& q_rad) {
  const struct {
    Eigen::Vector3d origin_mm, axis;
  } joints[] = {{{0, 0, 675}, {0, 0, -1}}, {{260, 0, 0}, {0, 1, 0}},  {{680, 0, 0}, {0, 1, 0}},
                {{670, 0, -35}, {-1, 0, 0}}, {{0, 0, 0}, {0, 1, 0}}, {{0, 0, 0}, {-1, 0, 0}}};
  Eigen::Isometry3d chain = Eigen::Isometry3d::Identity();
  for (int i = 0; i < 6; ++i) {
    chain.translate(joints[i].origin_mm);
    chain.rotate(Eigen::AngleAxisd(q_rad(i), joints[i].axis));
  }
  return chain * Eigen::Vector3d(158.0 + 100.0, 0, 0);
}

// Joint 1's frame in $ROBROOT: half a turn about x (the model's joint-1 z points down).
Eigen::Isometry3d RobrootFromJoint1() {
  return Eigen::Isometry3d(Eigen::AngleAxisd(std::numbers::pi, Eigen::Vector3d::UnitX()));
}

TEST(KukaModel, Kr16FollowsKukasJointZeroAndSigns) {
  const RobotModel model = io::LoadRobotModel(std::string(ARMSIG_SOURCE_DIR) + "/models/kr16_2.yaml");
  ASSERT_EQ(model.num_joints(), 6);
  Kinematics kin(model);
  const Eigen::VectorXd nominal = Eigen::VectorXd::Zero(model.num_parameters());
  std::mt19937 rng(35);
  std::uniform_real_distribution<double> angle(-170.0 * kKukaDeg, 170.0 * kKukaDeg);
  for (int k = 0; k < 50; ++k) {
    Eigen::VectorXd q(6);
    for (int i = 0; i < 6; ++i) q(i) = angle(rng);
    const Eigen::Vector3d x = kin.Position(RobrootFromJoint1(), nominal, q.data());
    EXPECT_LT((x - UrdfReflector(q)).norm(), 1e-9) << "configuration " << k;
  }
  // KUKA's home {0, -90, 90, 0, 0, 0}: upper arm up (A3 at 675 + 680 mm), forearm forward
  // with its axis 35 mm lower: the reflector at x = 260 + 670 + 158 + 100 mm, z = 1320 mm.
  const Eigen::VectorXd home = (Eigen::VectorXd(6) << 0, -90 * kKukaDeg, 90 * kKukaDeg, 0, 0, 0).finished();
  const Eigen::Vector3d h = kin.Position(RobrootFromJoint1(), nominal, home.data());
  EXPECT_LT((h - Eigen::Vector3d(1188, 0, 1320)).norm(), 1e-9) << h.transpose();
  // A positive A1 turns the arm clockwise seen from above: towards −y.
  Eigen::VectorXd turned = home;
  turned(0) = 30 * kKukaDeg;
  EXPECT_LT(kin.Position(RobrootFromJoint1(), nominal, turned.data()).y(), -500.0);
  // Gravity points down in $ROBROOT, so up the model's joint-1 z.
  EXPECT_LT((RobrootFromJoint1().linear() * model.gravity_in_base - Eigen::Vector3d(0, 0, -1)).norm(),
            1e-12);
  ASSERT_EQ(model.joint_min_rad.size(), 6u);
  EXPECT_NEAR(model.joint_min_rad[1], -155 * kKukaDeg, 1e-12);
}

}  // namespace
}  // namespace armsig::calibration
