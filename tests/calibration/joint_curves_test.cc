// Joint curves, the residual map's first stage: each joint's angle error as a periodic
// cubic spline of its own encoder angle (calibration/joint_curves.h).
#include "calibration/joint_curves.h"

#include <gtest/gtest.h>

#include <cmath>
#include <algorithm>
#include <numeric>
#include <random>

#include "calibration/compensation.h"
#include "calibration/residual_map.h"
#include "calibration/synthetic.h"
#include "test_support.h"

namespace armsig::calibration {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kArcsec = kPi / 180.0 / 3600.0;

// The centred cubic B-spline, written out piece by piece (independent of CurveSpanAt).
double CubicBSpline(double x) {
  x = std::abs(x);
  if (x < 1.0) return 2.0 / 3.0 - x * x + 0.5 * x * x * x;
  if (x < 2.0) return (2.0 - x) * (2.0 - x) * (2.0 - x) / 6.0;
  return 0.0;
}

// A joint error no geometric or harmonic term makes: a few tens of arcseconds with
// periods of 9 to 24 degrees, on joints 2 and 3 (the kind the UR10's encoders show).
double TrueAngleError(int joint, double angle) {
  if (joint == 1) return 40 * kArcsec * std::sin(20 * angle) + 25 * kArcsec * std::cos(37 * angle + 1);
  if (joint == 2) return 30 * kArcsec * std::sin(15 * angle + 0.4);
  return 0.0;
}

Eigen::Isometry3d CurvesLabBase() {
  Eigen::Isometry3d base = Eigen::Isometry3d::Identity();
  base.translate(Eigen::Vector3d(2500.0, -1200.0, -400.0));
  base.rotate(Eigen::AngleAxisd(0.7, Eigen::Vector3d::UnitZ()));
  return base;
}

// Poses of a UR10 (random geometric errors) whose joints 2 and 3 turn by TrueAngleError
// more than their encoders say; 0.01 mm noise. `range` bounds every joint's angle.
std::vector<MeasuredPose> Measure(const RobotModel& model, const Eigen::VectorXd& truth, int count,
                                  double range, std::mt19937& rng) {
  auto encoder = RandomConfigurations(model, count, rng, range);
  std::vector<Eigen::VectorXd> actual = encoder;
  for (auto& q : actual)
    for (int j = 0; j < q.size(); ++j) q(j) += TrueAngleError(j, q(j));
  auto poses = SimulatePoses(model, CurvesLabBase(), truth, actual, 0.01, rng);
  for (size_t i = 0; i < poses.size(); ++i) poses[i].joints_rad = encoder[i];
  return poses;
}

struct CurveLab {
  RobotModel model = testing::Ur10();
  Eigen::VectorXd truth;
  std::vector<MeasuredPose> fit, validation;
  EstimationResult estimate;
  ResidualMapFit map;
};

CurveLab MakeCurveLab(int fit_count, double range) {
  CurveLab lab;
  lab.model.nongeometric.clear();
  std::mt19937 rng(11);
  lab.truth = RandomParameters(lab.model, 0.3, 5e-4, 0.0, rng);
  lab.fit = Measure(lab.model, lab.truth, fit_count, range, rng);
  lab.validation = Measure(lab.model, lab.truth, 300, range, rng);
  EstimationOptions o;
  o.parameters = ParseParameterSpec(lab.model, "geometric");
  lab.estimate = Estimate(lab.model, lab.fit, o);
  lab.map = FitResidualMap(lab.model, lab.estimate, lab.fit);
  return lab;
}

double MeanError(const CurveLab& lab, const ResidualMap* map) {
  std::vector<Eigen::VectorXd> q;
  for (const auto& p : lab.validation) q.push_back(p.joints_rad);
  const auto predicted =
      PredictPositions(lab.model, lab.estimate.world_from_base, lab.estimate.params, map, q);
  double sum = 0.0;
  for (size_t i = 0; i < q.size(); ++i)
    sum += (predicted[i].position_mm - lab.validation[i].target_in_world).norm();
  return sum / static_cast<double>(q.size());
}

}  // namespace

TEST(JointCurves, SpanIsTheCubicBSplineAndAPartitionOfUnity) {
  const int knots = 180;
  const double spacing = 2 * kPi / knots;
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> angle(-7.0, 7.0);
  for (int trial = 0; trial < 200; ++trial) {
    const double a = angle(rng);
    const CurveSpan s = CurveSpanAt(knots, a);
    double sum = 0.0;
    for (int b = 0; b < 4; ++b) {
      const int m = (s.first + b) % knots;
      // The bump of knot m at the angle, by its distance in knots on the circle.
      const double d = std::remainder(a / spacing - m, static_cast<double>(knots));
      EXPECT_NEAR(s.weight[b], CubicBSpline(d), 1e-12) << a;
      sum += s.weight[b];
    }
    EXPECT_NEAR(sum, 1.0, 1e-12);
    // One turn later: the same bumps.
    const CurveSpan t = CurveSpanAt(knots, a + 2 * kPi);
    EXPECT_EQ(t.first, s.first);
    EXPECT_EQ(t.nearest, s.nearest);
    for (int b = 0; b < 4; ++b) EXPECT_NEAR(t.weight[b], s.weight[b], 1e-9);
  }
  // On a knot: 1/6, 2/3, 1/6.
  const CurveSpan on = CurveSpanAt(knots, 10 * spacing);
  EXPECT_EQ(on.first, 9);
  EXPECT_EQ(on.nearest, 10);
  EXPECT_NEAR(on.weight[0], 1.0 / 6, 1e-12);
  EXPECT_NEAR(on.weight[1], 2.0 / 3, 1e-12);
  EXPECT_NEAR(on.weight[2], 1.0 / 6, 1e-12);
  EXPECT_NEAR(on.weight[3], 0.0, 1e-12);
  // Negative angles wrap: −1 knot is the last one.
  EXPECT_EQ(CurveSpanAt(knots, -spacing).nearest, knots - 1);
}

TEST(JointCurves, ApplyAddsTheCurveAndSaysWhereItWasMeasured) {
  JointCurvesData c;
  c.knots = 8;
  c.joints = {1};
  c.values_rad = {{1e-4, 1e-4, 1e-4, 1e-4, 1e-4, 1e-4, 1e-4, 1e-4}};
  c.measured = {{1, 1, 1, 1, 0, 0, 0, 0}};
  CheckJointCurves(c, 3);
  const double q[3] = {0.3, 0.5, -2.0};
  double out[3];
  // A constant curve adds its constant (the bumps sum to one); other joints are copied.
  EXPECT_TRUE(ApplyJointCurves(c, 3, q, out));
  EXPECT_EQ(out[0], 0.3);
  EXPECT_NEAR(out[1], 0.5 + 1e-4, 1e-15);
  EXPECT_EQ(out[2], -2.0);
  const double far[3] = {0.3, kPi, 0.0};  // nearest knot 4: not measured
  EXPECT_FALSE(ApplyJointCurves(c, 3, far, out));
  // Inconsistent curves are refused.
  auto refused = [](auto change) {
    JointCurvesData d;
    d.knots = 8;
    d.joints = {1};
    d.values_rad = {std::vector<double>(8, 0.0)};
    d.measured = {std::vector<int>(8, 1)};
    change(d);
    EXPECT_THROW(CheckJointCurves(d, 3), std::invalid_argument);
  };
  refused([](JointCurvesData& d) { d.joints = {3}; });
  refused([](JointCurvesData& d) { d.values_rad[0].pop_back(); });
  refused([](JointCurvesData& d) { d.values_rad[0][2] = NAN; });
  refused([](JointCurvesData& d) { d.measured[0][1] = 2; });
  refused([](JointCurvesData& d) { d.knots = 3; });
  refused([](JointCurvesData& d) { d.joints.push_back(1); });
}

// Synthetic truth: periodic angle errors on joints 2 and 3 that no parameter of the model
// makes. The map's curves find them (the held-out error falls to the noise) and recover the
// errors themselves.
TEST(JointCurves, RecoverPeriodicJointErrorsTheModelCannotMake) {
  const CurveLab lab = MakeCurveLab(800, kPi);
  ASSERT_TRUE(lab.estimate.status.ok()) << lab.estimate.status.message;
  ASSERT_TRUE(lab.map.used) << lab.map.decision;
  const JointCurvesData& c = lab.map.map.curves;
  ASSERT_FALSE(c.empty()) << lab.map.decision;
  EXPECT_LT(lab.map.cv_mean_mm_curves, 0.5 * lab.map.cv_mean_mm_parametric);
  const ResidualMap map(lab.map.map);
  const double parametric = MeanError(lab, nullptr), mapped = MeanError(lab, &map);
  EXPECT_GT(parametric, 0.08);  // what the angle errors make through the arm
  EXPECT_LT(mapped, 0.35 * parametric);
  EXPECT_LT(mapped, 0.035);  // 3-D noise of 0.01 mm per coordinate: 0.016
  // The curves are the errors: on joints 2 and 3 at a hundred angles, up to a constant (a
  // zero offset the geometric γ took), within a fifth of their size.
  for (int joint : {1, 2}) {
    const int k = static_cast<int>(std::find(c.joints.begin(), c.joints.end(), joint) - c.joints.begin());
    ASSERT_LT(k, static_cast<int>(c.joints.size()));
    std::vector<double> found, truth;
    for (int i = 0; i < 100; ++i) {
      const double a = -2.5 + 5.0 * i / 99.0;
      Eigen::VectorXd q = Eigen::VectorXd::Zero(6), out(6);
      q(joint) = a;
      map.CorrectJoints(q.data(), out.data());
      found.push_back(out(joint) - a);
      truth.push_back(TrueAngleError(joint, a));
    }
    const double mf = std::accumulate(found.begin(), found.end(), 0.0) / 100;
    const double mt = std::accumulate(truth.begin(), truth.end(), 0.0) / 100;
    double diff = 0.0, size = 0.0;
    for (int i = 0; i < 100; ++i) {
      diff += std::pow((found[i] - mf) - (truth[i] - mt), 2);
      size += std::pow(truth[i] - mt, 2);
    }
    EXPECT_LT(std::sqrt(diff / size), 0.2) << "joint " << joint + 1;
  }
  // Compensation with the map lands the mapped model on the target, and the true robot
  // nearer it than without the map.
  Kinematics kin(lab.model);
  double miss_with = 0.0, miss_without = 0.0;
  for (int i = 0; i < 10; ++i) {
    const auto& pose = lab.validation[i];
    const auto with = SolveJoints(lab.model, lab.estimate.world_from_base, lab.estimate.params,
                                  pose.target_in_world, pose.joints_rad, {}, &map);
    const auto without = SolveJoints(lab.model, lab.estimate.world_from_base,
                                     lab.estimate.params, pose.target_in_world, pose.joints_rad);
    ASSERT_TRUE(with.status.ok()) << with.status.message;
    auto actual = [&](Eigen::VectorXd q) {
      for (int j = 0; j < q.size(); ++j) q(j) += TrueAngleError(j, q(j));
      return kin.Position(CurvesLabBase(), lab.truth, q.data());
    };
    miss_with += (actual(with.joints_rad) - pose.target_in_world).norm();
    miss_without += (actual(without.joints_rad) - pose.target_in_world).norm();
  }
  EXPECT_LT(miss_with, 0.4 * miss_without);
}

// Joints measured over part of their turn only: the curve is pulled to zero where no pose
// was, and a configuration there is flagged.
TEST(JointCurves, AnArcNeverMeasuredGetsNoCurveAndAFlag) {
  const CurveLab lab = MakeCurveLab(600, 1.2);  // every joint within ±69°
  ASSERT_TRUE(lab.map.used) << lab.map.decision;
  const JointCurvesData& c = lab.map.map.curves;
  ASSERT_FALSE(c.empty());
  const ResidualMap map(lab.map.map);
  Eigen::VectorXd q = lab.validation[0].joints_rad, out(6);
  q(1) = kPi;  // joint 2 half a turn from anything measured
  EXPECT_FALSE(map.CorrectJoints(q.data(), out.data()));
  EXPECT_LT(std::abs(out(1) - q(1)), 1 * kArcsec);  // the errors are 30–65″
  const auto k = std::find(c.joints.begin(), c.joints.end(), 1) - c.joints.begin();
  EXPECT_EQ(c.measured[k][c.knots / 2], 0);
  EXPECT_EQ(c.measured[k][0], 1);
  const auto p = PredictPositions(lab.model, lab.estimate.world_from_base, lab.estimate.params,
                                  &map, {q, lab.validation[1].joints_rad});
  EXPECT_TRUE(p[0].extrapolated);
  EXPECT_FALSE(p[0].map_applied);
}

}  // namespace armsig::calibration
