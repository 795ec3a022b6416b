// Measuring on the move, the pure part (calibration/clock_sync.h): a synthetic UR10 with
// hidden errors sweeps joint moves (trapezoidal profiles, as the controller moves) while a
// tracker samples it on its own clock, offset and drifting from the controller's. Every figure
// is checked against the planted truth.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "calibration/clock_sync.h"
#include "calibration/estimation.h"
#include "calibration/synthetic.h"
#include "test_support.h"

namespace armsig::calibration {
namespace {

// A joint move on a trapezoid of the leading joint: accelerate at a to v, cruise, brake.
struct SweepLeg {
  Eigen::VectorXd from, direction;
  double distance = 0, a = 1.4, v = 0.4, ramp = 0, peak = 0, duration = 0;
  SweepLeg(const Eigen::VectorXd& q0, const Eigen::VectorXd& q1, double a_, double v_) : a(a_), v(v_) {
    from = q0;
    distance = (q1 - q0).cwiseAbs().maxCoeff();
    direction = (q1 - q0) / distance;
    ramp = std::min(v / a, std::sqrt(distance / a));
    peak = a * ramp;
    duration = 2 * ramp + (distance - a * ramp * ramp) / peak;
  }
  void At(double t, Eigen::VectorXd& q, Eigen::VectorXd& qd) const {
    double s = 0, ds = 0;
    if (t < ramp) {
      s = 0.5 * a * t * t;
      ds = a * t;
    } else if (t < duration - ramp) {
      s = 0.5 * a * ramp * ramp + peak * (t - ramp);
      ds = peak;
    } else {
      const double r = std::max(0.0, duration - t);
      s = distance - 0.5 * a * r * r;
      ds = a * r;
    }
    q = from + direction * s;
    qd = direction * ds;
  }
};

// The sweep, its joint stream (the controller's clock = physical time, every 10 ms) and the
// tracker's points (every 50 ms of ITS clock: offset + (1 + drift) · t), noise σ 10 µm.
struct SyntheticSweep {
  RobotModel model = testing::Ur10();
  Eigen::VectorXd truth;
  Eigen::Isometry3d world_from_base = Eigen::Isometry3d::Identity();
  JointStream joints;
  PointStream points;
  double offset_s = 0.1234, drift = 25e-6;

  explicit SyntheticSweep(int legs = 24, unsigned seed = 11) {
    std::mt19937 rng(seed);
    truth = RandomParameters(model, 0.3, 3e-4, 0.0, rng);
    world_from_base.translate(Eigen::Vector3d(1500.0, -300.0, 200.0));
    world_from_base.rotate(Eigen::AngleAxisd(0.4, Eigen::Vector3d::UnitZ()));
    const auto waypoints = RandomConfigurations(model, legs + 1, rng, 1.6);
    std::vector<SweepLeg> path;
    std::vector<double> starts;
    double t = 0.0;
    for (int k = 0; k < legs; ++k) {
      path.emplace_back(waypoints[k], waypoints[k + 1], 1.4, 0.4);
      starts.push_back(t);
      t += path.back().duration + 0.05;  // stands a moment at each waypoint
    }
    const double end = t;
    const auto state = [&](double time, Eigen::VectorXd& q, Eigen::VectorXd& qd) {
      size_t k = 0;
      while (k + 1 < path.size() && time >= starts[k + 1]) ++k;
      if (time - starts[k] >= path[k].duration) {
        path[k].At(path[k].duration, q, qd);
        qd.setZero();
        return;
      }
      path[k].At(time - starts[k], q, qd);
    };
    Eigen::VectorXd q, qd;
    for (double tc = 0.0; tc <= end; tc += 0.01) {
      state(tc, q, qd);
      joints.t_s.push_back(tc);
      joints.q_rad.push_back(q);
      joints.qd_rad_s.push_back(qd);
    }
    Kinematics kin(model);
    std::normal_distribution<double> noise(0.0, 0.01);
    for (double tt = offset_s + 0.2; ; tt += 0.05) {
      const double tc = (tt - offset_s) / (1.0 + drift);
      if (tc > end - 0.2) break;
      state(tc, q, qd);
      points.t_s.push_back(tt);
      points.point_mm.push_back(kin.Position(world_from_base, truth, q.data()) +
                                Eigen::Vector3d(noise(rng), noise(rng), noise(rng)));
    }
  }
};

ClockMap Truth(const SyntheticSweep& s) {
  ClockMap c;
  c.offset_s = s.offset_s;
  c.drift = s.drift;
  return c;
}

// Calibrated on the pairs of every other stretch of the sweep, validated on the rest: the
// validation's mean error (mm).
double FitAndValidate(const SyntheticSweep& s, const ClockMap& clock) {
  const Eigen::VectorXd nominal = Eigen::VectorXd::Zero(s.model.num_parameters());
  PairingOptions loose;
  loose.max_sync_sigma_mm = 1e9;
  const Pairing paired = PairStreams(s.model, nominal, s.world_from_base, s.joints, s.points, clock, loose);
  std::vector<MeasuredPose> fit, validation;
  const size_t n = paired.points.size();
  for (size_t i = 0; i < n; ++i) {
    const auto& p = paired.points[i];
    MeasuredPose pose{"m" + std::to_string(i), p.q_rad, p.point_mm, 0};
    ((8 * i / n) % 2 == 0 ? fit : validation).push_back(pose);
  }
  std::vector<MeasuredPose> thin;
  for (size_t i = 0; i < fit.size(); i += 4) thin.push_back(fit[i]);
  EstimationOptions o;
  o.parameters = ParseParameterSpec(s.model, "geometric");
  const auto result = Estimate(s.model, thin, o);
  EXPECT_TRUE(result.usable());
  double mean = 0.0;
  for (double d : Distances(Residuals(s.model, result.world_from_base, result.params, validation)))
    mean += d / static_cast<double>(validation.size());
  return mean;
}

TEST(ClockSync, HermiteInterpolationIsExactForAConstantAcceleration) {
  JointStream js;
  const Eigen::Vector2d q0(0.3, -1.2), v0(0.5, 0.1), acc(1.4, -0.7);
  for (int k = 0; k <= 10; ++k) {
    const double t = 0.01 * k;
    js.t_s.push_back(t);
    js.q_rad.push_back(q0 + v0 * t + 0.5 * acc * t * t);
    js.qd_rad_s.push_back(v0 + acc * t);
  }
  const double t = 0.0437;
  const auto state = JointsAt(js, t, 0.05);
  ASSERT_TRUE(state);
  EXPECT_LT((state->q_rad - (q0 + v0 * t + 0.5 * acc * t * t)).norm(), 1e-14);
  EXPECT_LT((state->qd_rad_s - (v0 + acc * t)).norm(), 1e-12);
  EXPECT_NEAR(state->acceleration_rad_s2, 1.4, 1e-12);
  EXPECT_FALSE(JointsAt(js, 0.2, 0.05));   // after the stream
  EXPECT_FALSE(JointsAt(js, 0.045, 0.005));  // a bracket wider than the allowed gap
}

TEST(ClockSync, OffsetAndDriftComeFromTheDataThemselves) {
  const SyntheticSweep s;
  // A first guess 0.8 s off (two streams started a moment apart): the speed profiles line up.
  ClockMap guess;
  guess.offset_s = s.offset_s + 0.8;
  const auto coarse = CoarseClock(s.model, s.truth, s.joints, s.points, guess);
  ASSERT_TRUE(coarse);
  EXPECT_NEAR(coarse->offset_s, s.offset_s, 0.01);
  Eigen::Isometry3d base = Eigen::Isometry3d::Identity();
  const ClockMap fine = RefineClock(s.model, s.truth, s.joints, s.points, *coarse, base);
  EXPECT_NEAR(fine.offset_s * 1e3, s.offset_s * 1e3, 0.02);  // ms
  EXPECT_NEAR(fine.drift * 1e6, s.drift * 1e6, 1.0);          // ppm
  EXPECT_LT((base.translation() - s.world_from_base.translation()).norm(), 0.05);
  // Its stated σ covers the error it made.
  const double sigma_ms = fine.SigmaAt(fine.reference_s) * 1e3;
  EXPECT_GT(sigma_ms, 0.0);
  EXPECT_LT(sigma_ms, 0.01);
}

TEST(ClockSync, TheNominalModelBiasesTheClockAndTheFittedOneDoesNot) {
  const SyntheticSweep s;
  ClockMap guess;
  guess.offset_s = s.offset_s - 0.3;
  const Eigen::VectorXd nominal = Eigen::VectorXd::Zero(s.model.num_parameters());
  Eigen::Isometry3d base = Eigen::Isometry3d::Identity();
  ClockMap clock = RefineClock(s.model, nominal, s.joints, s.points,
                               *CoarseClock(s.model, nominal, s.joints, s.points, guess), base);
  const double nominal_error_ms = std::abs(clock.offset_s - s.offset_s) * 1e3;
  // Fit the model to the paired points, refine the clock with it, twice.
  Eigen::VectorXd params = nominal;
  for (int round = 0; round < 3; ++round) {
    const Pairing paired = PairStreams(s.model, params, base, s.joints, s.points, clock);
    std::vector<MeasuredPose> poses;
    for (size_t i = 0; i < paired.points.size(); i += 3)
      poses.push_back({"m", paired.points[i].q_rad, paired.points[i].point_mm, 0});
    EstimationOptions o;
    o.parameters = ParseParameterSpec(s.model, "geometric");
    params = Estimate(s.model, poses, o).params;
    clock = RefineClock(s.model, params, s.joints, s.points, clock, base);
  }
  const double fitted_error_ms = std::abs(clock.offset_s - s.offset_s) * 1e3;
  EXPECT_LT(fitted_error_ms, 0.1);
  EXPECT_LT(fitted_error_ms, nominal_error_ms);
  EXPECT_NEAR(clock.drift * 1e6, s.drift * 1e6, 3.0);
}

TEST(ClockSync, AnOffsetOfFiveMillisecondsLeftUncorrectedRuinsTheFit) {
  const SyntheticSweep s;
  const double right = FitAndValidate(s, Truth(s));
  ClockMap wrong = Truth(s);
  wrong.offset_s += 0.005;
  const double ruined = FitAndValidate(s, wrong);
  EXPECT_LT(right, 0.03);       // the noise (10 µm per axis) and nothing else
  EXPECT_GT(ruined, 10 * right);  // the speed × 5 ms the model cannot absorb
}

TEST(ClockSync, PairingLeavesOutGapsAndAccelerationsAndCountsThem) {
  SyntheticSweep s(8);
  // A gap of 0.3 s in the joint stream (the network dropped packages).
  JointStream holed;
  for (size_t i = 0; i < s.joints.size(); ++i) {
    if (s.joints.t_s[i] > 3.0 && s.joints.t_s[i] < 3.3) continue;
    holed.t_s.push_back(s.joints.t_s[i]);
    holed.q_rad.push_back(s.joints.q_rad[i]);
    holed.qd_rad_s.push_back(s.joints.qd_rad_s[i]);
  }
  PairingOptions o;
  o.max_acceleration_rad_s2 = 0.3;
  const Pairing paired = PairStreams(s.model, s.truth, s.world_from_base, holed, s.points, Truth(s), o);
  // Points every 50 ms: the 0.3 s hole holds 6 of them (more when its edges fall in it).
  EXPECT_GE(paired.gaps, 5);
  EXPECT_LE(paired.gaps, 8);
  EXPECT_GT(paired.accelerating, 0);
  const int total = static_cast<int>(s.points.size());
  EXPECT_EQ(static_cast<int>(paired.points.size()) + paired.gaps + paired.accelerating +
                paired.outside + paired.uncertain,
            total);
  Kinematics kin(s.model);
  for (const auto& p : paired.points) {
    EXPECT_LE(p.acceleration_rad_s2, 0.3);
    // Each pair is the truth at its joints, within the noise.
    EXPECT_LT((kin.Position(s.world_from_base, s.truth, p.q_rad.data()) - p.point_mm).norm(), 0.07);
  }
}

}  // namespace
}  // namespace armsig::calibration
