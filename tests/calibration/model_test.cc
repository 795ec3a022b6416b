#include "calibration/model.h"

#include <ceres/jet.h>
#include <gtest/gtest.h>

#include <random>

#include "calibration/synthetic.h"
#include "test_support.h"

namespace armsig::calibration {
namespace {

Eigen::Isometry3d SomeBase() {
  Eigen::Isometry3d base = Eigen::Isometry3d::Identity();
  base.rotate(Eigen::AngleAxisd(2.1, Eigen::Vector3d(0.3, -0.5, 0.8).normalized()));
  base.translation() << 2500.0, -1300.0, 800.0;
  return base;
}

// Central finite differences of the position with respect to every parameter.
Eigen::MatrixXd NumericJacobian(const RobotModel& model, const Eigen::Isometry3d& base,
                                const Eigen::VectorXd& params, const Eigen::VectorXd& q) {
  Kinematics kin(model);
  Eigen::MatrixXd j(3, model.num_parameters());
  for (int k = 0; k < model.num_parameters(); ++k) {
    // Steps balance truncation (h²) against rounding of ~3 m coordinates (ε·3000/h).
    const double h = model.UnitOf(k) == ParameterUnit::kMm ? 1e-3 : 1e-6;
    Eigen::VectorXd plus = params, minus = params;
    plus(k) += h;
    minus(k) -= h;
    j.col(k) = (kin.Position(base, plus, q.data()) - kin.Position(base, minus, q.data())) / (2 * h);
  }
  return j;
}

}  // namespace

TEST(ErrorTransform, MatchesPaperEquation2) {
  const double a = 0.3, b = -0.2, c = 0.7, al = 0.011, be = -0.023, ga = 0.037;
  const double ca = std::cos(al), sa = std::sin(al), cb = std::cos(be), sb = std::sin(be),
               cg = std::cos(ga), sg = std::sin(ga);
  Eigen::Matrix4d paper;
  paper << cb * cg, -cb * sg, sb, a,                                //
      ca * sg + sa * sb * cg, ca * cg - sa * sb * sg, -sa * cb, b,  //
      sa * sg - ca * sb * cg, sa * cg + ca * sb * sg, ca * cb, c,   //
      0, 0, 0, 1;
  EXPECT_LT((ErrorTransform(a, b, c, al, be, ga).matrix() - paper).norm(), 1e-15);
}

TEST(Kinematics, PumaNullConfigurationFollowsTheDrawings) {
  // Paper eq. (16) at θ = 0 with N1 = I, composed by hand from N2…N6: frame 2 at
  // (0, 164, 0) with z2 = −y1; N3 adds 650 along x and 50 along z2 (−y1); N4 adds 550
  // along x; N5 adds 50 along z4 = +x1; N6 adds 125 along x5 = +x1.
  // Stretched arm: x = 650 + 550 + 50 + 125 = 1375, y = 164 − 50 = 114, z = 0.
  const auto model = testing::Puma();
  Kinematics kin(model);
  const Eigen::VectorXd q = Eigen::VectorXd::Zero(6);
  const Eigen::Vector3d x =
      kin.Position(Eigen::Isometry3d::Identity(), Eigen::VectorXd::Zero(43), q.data());
  EXPECT_LT((x - Eigen::Vector3d(1375.0, 114.0, 0.0)).norm(), 1e-12) << x.transpose();
}

TEST(Kinematics, Ur10DhMatchesUniversalRobotsForwardKinematics) {
  // Standard UR forward kinematics at all joints zero: flange at (a2 + a3, −(d4 + d6),
  // d1 − d5) with its z axis along −y; the probe sits 109 mm further along it.
  const auto model = testing::Ur10();
  Kinematics kin(model);
  const Eigen::VectorXd q = Eigen::VectorXd::Zero(6);
  const Eigen::Vector3d x = kin.Position(Eigen::Isometry3d::Identity(),
                                         Eigen::VectorXd::Zero(model.num_parameters()), q.data());
  EXPECT_NEAR(x.x(), -612.0 - 572.3, 1e-9);
  EXPECT_NEAR(x.y(), -(163.941 + 92.2 + 109.0), 1e-9);
  EXPECT_NEAR(x.z(), 127.3 - 115.7, 1e-9);
  // Shoulder lift by −90°: upper arm and forearm point straight up, and the wrist
  // offset d5 (downwards at zero) turns horizontal: z = d1 + |a2| + |a3|.
  Eigen::VectorXd up = q;
  up(1) = -M_PI / 2;
  const Eigen::Vector3d y = kin.Position(Eigen::Isometry3d::Identity(),
                                         Eigen::VectorXd::Zero(model.num_parameters()), up.data());
  EXPECT_NEAR(y.z(), 127.3 + 612.0 + 572.3, 1e-9);
}

TEST(Kinematics, AnalyticJacobianMatchesCentralDifferences) {
  std::mt19937 rng(7);
  for (const auto& model : {testing::Puma(), testing::Ur10()}) {
    for (int trial = 0; trial < 20; ++trial) {
      const Eigen::VectorXd params = RandomParameters(model, 2.0, 5e-3, 3e-3, rng);
      const Eigen::VectorXd q = RandomConfigurations(model, 1, rng, 3.0)[0];
      Kinematics kin(model);
      Eigen::Matrix<double, 3, Eigen::Dynamic> analytic(3, model.num_parameters());
      kin.PositionAndJacobian(SomeBase(), params, q.data(), analytic);
      const Eigen::MatrixXd numeric = NumericJacobian(model, SomeBase(), params, q);
      for (int k = 0; k < model.num_parameters(); ++k) {
        EXPECT_LT((analytic.col(k) - numeric.col(k)).norm(),
                  1e-6 * std::max(1.0, numeric.col(k).norm()))
            << model.name << " parameter " << model.ParameterNames()[k];
      }
    }
  }
}

TEST(Kinematics, RotationJacobianMatchesCentralDifferencesOfTheLastLinkFrame) {
  // Rows 3–5 of PoseAndJacobian against (R(p + h e_k) R(p − h e_k)ᵀ) turned into a rotation
  // vector over 2h: the world-side turn of the last link frame per unit of each parameter.
  std::mt19937 rng(17);
  for (const auto& model : {testing::Puma(), testing::Ur10()}) {
    for (int trial = 0; trial < 10; ++trial) {
      const Eigen::VectorXd params = RandomParameters(model, 2.0, 5e-3, 3e-3, rng);
      const Eigen::VectorXd q = RandomConfigurations(model, 1, rng, 3.0)[0];
      Kinematics kin(model);
      Eigen::Matrix<double, 6, Eigen::Dynamic> analytic(6, model.num_parameters());
      const Eigen::Vector3d x = kin.PoseAndJacobian(SomeBase(), params, q.data(), analytic);
      EXPECT_LT((x - kin.Position(SomeBase(), params, q.data())).norm(), 1e-12);
      Eigen::Matrix<double, 3, Eigen::Dynamic> position(3, model.num_parameters());
      kin.PositionAndJacobian(SomeBase(), params, q.data(), position);
      EXPECT_EQ(analytic.topRows<3>(), position);
      for (int k = 0; k < model.num_parameters(); ++k) {
        const double h = 1e-6;
        Eigen::VectorXd plus = params, minus = params;
        plus(k) += h;
        minus(k) -= h;
        kin.Position(SomeBase(), plus, q.data());
        const Eigen::Matrix3d r_plus = kin.LastRotation();
        kin.Position(SomeBase(), minus, q.data());
        const Eigen::Matrix3d r_minus = kin.LastRotation();
        const Eigen::AngleAxisd turn(r_plus * r_minus.transpose());
        const Eigen::Vector3d numeric = turn.angle() * turn.axis() / (2 * h);
        EXPECT_LT((analytic.col(k).tail<3>() - numeric).norm(), 1e-7)
            << model.name << " parameter " << model.ParameterNames()[k];
      }
    }
  }
}

TEST(Kinematics, TemplatedModelRunsOnJetsAndAgreesWithAnalyticJacobian) {
  using Jet = ceres::Jet<double, 43>;
  const auto model = testing::Puma();
  std::mt19937 rng(11);
  const Eigen::VectorXd params = RandomParameters(model, 1.0, 2e-3, 2e-3, rng);
  const Eigen::VectorXd q = RandomConfigurations(model, 1, rng)[0];
  std::vector<Jet> p(43);
  for (int k = 0; k < 43; ++k) p[k] = Jet(params(k), k);
  const Eigen::Matrix<Jet, 3, 1> x = TargetPosition(model, SomeBase(), p.data(), q.data());
  Kinematics kin(model);
  Eigen::Matrix<double, 3, Eigen::Dynamic> analytic(3, 43);
  const Eigen::Vector3d value = kin.PositionAndJacobian(SomeBase(), params, q.data(), analytic);
  for (int r = 0; r < 3; ++r) {
    EXPECT_NEAR(x(r).a, value(r), 1e-9);
    EXPECT_LT((x(r).v.transpose() - analytic.row(r)).norm(), 1e-9);
  }
}

TEST(Kinematics, NongeometricTermsFollowPaperEquations6And7) {
  const auto model = testing::Puma();
  Kinematics kin(model);
  Eigen::VectorXd params = Eigen::VectorXd::Zero(43);
  params(39) = 1e-3;  // h1
  params(40) = 2e-3;  // h2
  params(41) = 3e-3;  // h3
  params(42) = 4e-3;  // h4
  const double q[6] = {0.1, 0.4, 1.9, 0.0, 0.0, 0.0};
  double t[6];
  kin.TrueJointAngles(params, q, t);
  const double c23 = std::cos(0.4 + 1.9);  // negative: SIGN = −1
  EXPECT_NEAR(t[1], 0.4 + 1e-3 * c23 + 2e-3 * std::cos(0.4), 1e-15);
  EXPECT_NEAR(t[2], 1.9 + 3e-3 * c23 - 4e-3, 1e-15);
  EXPECT_EQ(t[0], 0.1);
}

}  // namespace armsig::calibration

namespace armsig::calibration {
namespace {

// The model with its target at `tool_mm` on a machined adapter: tool_mounting: known.
RobotModel KnownMounting(RobotModel model, const Eigen::Vector3d& tool_mm) {
  model.tool_mm = tool_mm;
  model.tool_mounting = ToolMounting::kKnown;
  return model;
}

// The IRB 4600's nest (off the flange axis) and a target on the axis.
const Eigen::Vector3d kOffAxis(40.0, 0.0, 235.0), kOnAxis(0.0, 0.0, 235.0);

}  // namespace

TEST(ToolMounting, AxesAcrossTheLeverAreOrthonormalAndAcrossIt) {
  const Eigen::Matrix<double, 3, 2> z = AxesAcross(Eigen::Vector3d(0, 0, 5));
  EXPECT_LT((z.col(0) - Eigen::Vector3d::UnitX()).norm(), 1e-15);
  EXPECT_LT((z.col(1) - Eigen::Vector3d::UnitY()).norm(), 1e-15);
  // Along e_y, e_y × l̂ has no direction: e_z × l̂ instead.
  const Eigen::Matrix<double, 3, 2> y = AxesAcross(Eigen::Vector3d(0, -3, 0));
  for (const Eigen::Vector3d& lever : {kOffAxis, Eigen::Vector3d(0, -3, 0), Eigen::Vector3d(7, 2, -1)}) {
    const Eigen::Matrix<double, 3, 2> u = AxesAcross(lever);
    EXPECT_LT((u.transpose() * u - Eigen::Matrix2d::Identity()).norm(), 1e-14);
    EXPECT_LT(std::abs(u.col(0).dot(lever)) + std::abs(u.col(1).dot(lever)), 1e-12);
    // u1 × u2 along the lever: a right-handed triple (u1, u2, l̂).
    EXPECT_GT(u.col(0).cross(u.col(1)).dot(lever), 0.0);
  }
  EXPECT_TRUE(y.allFinite());
}

TEST(ToolMounting, KnownAddsTheFlangeTurnAfterTheTargetsOffsetAndHoldsIt) {
  const RobotModel fitted = testing::Puma();
  const RobotModel known = KnownMounting(fitted, kOffAxis);
  EXPECT_EQ(fitted.num_geometric(), 39);
  EXPECT_EQ(fitted.flange_turn_index(), -1);
  EXPECT_TRUE(fitted.HeldParameters().empty());
  EXPECT_EQ(known.num_geometric(), 41);
  EXPECT_EQ(known.num_parameters(), 45);
  const auto names = known.ParameterNames();
  EXPECT_EQ(names[38], "c7");
  EXPECT_EQ(names[39], "alpha7");
  EXPECT_EQ(names[40], "beta7");
  EXPECT_EQ(names[41], "h1");
  EXPECT_EQ(known.flange_turn_index(), 39);
  EXPECT_EQ(known.IndexOf("beta7"), 40);
  EXPECT_EQ(known.UnitOf(39), ParameterUnit::kRad);
  EXPECT_EQ(known.UnitOf(38), ParameterUnit::kMm);
  EXPECT_EQ(known.HeldParameters(), (std::vector<int>{35, 36, 37, 38}));  // gamma6, a7 b7 c7
  EXPECT_EQ(known.GeometricIndex(6, 3), 39);
  EXPECT_EQ(known.GeometricIndex(6, 5), -1);
  EXPECT_EQ(fitted.GeometricIndex(6, 3), -1);
  EXPECT_EQ(ModelDifferences(KnownMounting(fitted, Eigen::Vector3d::Zero()), fitted),
            std::vector<std::string>{"tool mounting: known against fitted"});
}

TEST(ToolMounting, KnownMountingJacobiansMatchCentralDifferences) {
  // Position rows against central differences of the position, rotation rows against those
  // of LastRotation (which carries the flange turn), off and on the flange axis.
  std::mt19937 rng(36);
  for (const Eigen::Vector3d& tool : {kOffAxis, kOnAxis}) {
    const RobotModel model = KnownMounting(testing::Ur10(), tool);
    for (int trial = 0; trial < 10; ++trial) {
      const Eigen::VectorXd params = RandomParameters(model, 2.0, 5e-3, 3e-3, rng);
      const Eigen::VectorXd q = RandomConfigurations(model, 1, rng, 3.0)[0];
      Kinematics kin(model);
      Eigen::Matrix<double, 6, Eigen::Dynamic> analytic(6, model.num_parameters());
      kin.PoseAndJacobian(SomeBase(), params, q.data(), analytic);
      const Eigen::MatrixXd numeric = NumericJacobian(model, SomeBase(), params, q);
      for (int k = 0; k < model.num_parameters(); ++k) {
        EXPECT_LT((analytic.col(k).head<3>() - numeric.col(k)).norm(),
                  1e-6 * std::max(1.0, numeric.col(k).norm()))
            << tool.transpose() << " parameter " << model.ParameterNames()[k];
        const double h = 1e-6;
        Eigen::VectorXd plus = params, minus = params;
        plus(k) += h;
        minus(k) -= h;
        kin.Position(SomeBase(), plus, q.data());
        const Eigen::Matrix3d r_plus = kin.LastRotation();
        kin.Position(SomeBase(), minus, q.data());
        const Eigen::AngleAxisd turn(r_plus * kin.LastRotation().transpose());
        EXPECT_LT((analytic.col(k).tail<3>() - turn.angle() * turn.axis() / (2 * h)).norm(), 1e-7)
            << tool.transpose() << " parameter " << model.ParameterNames()[k];
      }
    }
  }
}

TEST(ToolMounting, TemplatedModelAgreesWithKinematicsWithAKnownMounting) {
  using Jet = ceres::Jet<double, 45>;
  for (const Eigen::Vector3d& tool : {kOffAxis, kOnAxis}) {
    const RobotModel model = KnownMounting(testing::Puma(), tool);
    ASSERT_EQ(model.num_parameters(), 45);
    std::mt19937 rng(12);
    const Eigen::VectorXd params = RandomParameters(model, 1.0, 2e-3, 2e-3, rng);
    const Eigen::VectorXd q = RandomConfigurations(model, 1, rng)[0];
    std::vector<Jet> p(45);
    for (int k = 0; k < 45; ++k) p[k] = Jet(params(k), k);
    const Eigen::Matrix<Jet, 3, 1> x = TargetPosition(model, SomeBase(), p.data(), q.data());
    Kinematics kin(model);
    Eigen::Matrix<double, 3, Eigen::Dynamic> analytic(3, 45);
    const Eigen::Vector3d value = kin.PositionAndJacobian(SomeBase(), params, q.data(), analytic);
    for (int r = 0; r < 3; ++r) {
      EXPECT_NEAR(x(r).a, value(r), 1e-9);
      EXPECT_LT((x(r).v.transpose() - analytic.row(r)).norm(), 1e-9);
    }
  }
}

TEST(ToolMounting, AProductionToolTurnsWithTheFlange) {
  // The flange's turn alone (1 mrad across the lever): the target moves by it, and a TCP
  // 200 mm away (AtPoint, the same turn's axes) by the turn of its own lever, as one body.
  const RobotModel model = KnownMounting(testing::Ur10(), kOffAxis);
  Eigen::VectorXd turned = Eigen::VectorXd::Zero(model.num_parameters());
  turned(model.flange_turn_index()) = 0.8e-3;
  turned(model.flange_turn_index() + 1) = -0.6e-3;
  const Eigen::VectorXd zero = Eigen::VectorXd::Zero(model.num_parameters());
  const Eigen::Vector3d tcp_mm(0.0, 10.0, 430.0);
  const RobotModel at_tcp = AtPoint(model, tcp_mm);
  const Eigen::VectorXd q = (Eigen::VectorXd(6) << 0.3, -1.2, 1.4, -0.5, 0.9, 0.2).finished();
  Kinematics target(model), tool(at_tcp);
  const Eigen::Vector3d target_moved = target.Position(SomeBase(), turned, q.data()) -
                                       target.Position(SomeBase(), zero, q.data());
  const Eigen::Vector3d tool_turned = tool.Position(SomeBase(), turned, q.data());
  const Eigen::Matrix3d rotation = tool.LastRotation();
  const Eigen::Vector3d tool_moved = tool_turned - tool.Position(SomeBase(), zero, q.data());
  const Eigen::Matrix3d unturned = tool.LastRotation();
  EXPECT_NEAR(target_moved.norm(), 1e-3 * kOffAxis.norm(), 1e-4);  // 0.24 mm at 238 mm
  // One rigid body: target and TCP turned by the same rotation about the last link's origin.
  const Eigen::Matrix3d turn = rotation * unturned.transpose();
  EXPECT_NEAR(Eigen::AngleAxisd(turn).angle(), 1e-3, 1e-9);
  const Eigen::Vector3d pivot = target.Position(SomeBase(), zero, q.data()) - unturned * kOffAxis;
  EXPECT_LT((tool_turned - (pivot + rotation * tcp_mm)).norm(), 1e-9);
  EXPECT_GT(tool_moved.norm(), 0.3);  // the TCP's lever is longer
  EXPECT_LT((FlangeTurn(model, turned) - unturned.transpose() * rotation).norm(), 1e-12);
}

}  // namespace armsig::calibration
