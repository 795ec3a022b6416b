#include "calibration/clock_sync.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

namespace armsig::calibration {

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// The target's position in the base frame and its velocity (mm, mm/s) for joints q turning
// at qd.
struct Moving {
  Eigen::Vector3d x, v;
};
Moving TargetMotion(Kinematics& kin, const Eigen::VectorXd& params, const Eigen::VectorXd& q,
                    const Eigen::VectorXd& qd) {
  Moving m;
  m.x = kin.Position(Eigen::Isometry3d::Identity(), params, q.data());
  m.v = kin.JointJacobian() * qd;
  return m;
}

// A profile sampled on a regular grid from `start`, NaN where unknown.
struct Profile {
  double start = 0.0, step = 0.0;
  std::vector<double> value;
  double At(double t) const {
    const double k = (t - start) / step;
    if (!(k >= 0.0) || k > static_cast<double>(value.size() - 1)) return kNaN;
    const auto i = static_cast<size_t>(k);
    if (i + 1 >= value.size()) return value.back();
    const double f = k - static_cast<double>(i);
    return value[i] * (1.0 - f) + value[i + 1] * f;  // NaN beside a gap stays NaN
  }
};

// Linear resampling of (t, v) pairs in time order; NaN across gaps longer than `max_gap`.
Profile Resample(const std::vector<double>& t, const std::vector<double>& v, double step,
                 double max_gap) {
  Profile p;
  p.step = step;
  if (t.size() < 2) return p;
  p.start = t.front();
  const auto n = static_cast<size_t>((t.back() - t.front()) / step) + 1;
  p.value.assign(n, kNaN);
  size_t j = 0;
  for (size_t k = 0; k < n; ++k) {
    const double tk = p.start + step * static_cast<double>(k);
    while (j + 2 < t.size() && t[j + 1] < tk) ++j;
    const double h = t[j + 1] - t[j];
    if (!(h > 0.0) || h > max_gap || tk < t[j] || tk > t[j + 1]) continue;
    const double f = (tk - t[j]) / h;
    p.value[k] = v[j] * (1.0 - f) + v[j + 1] * f;
  }
  return p;
}

// Mean squared difference of the tracker's speed and the controller's at lag `offset`
// (tracker time = offset + controller time) over the tracker grid; NaN when less than half
// of the tracker's profile overlaps.
double Mismatch(const Profile& tracker, const Profile& controller, double offset, size_t stride) {
  double sum = 0.0;
  size_t used = 0, known = 0;
  for (size_t k = 0; k < tracker.value.size(); k += stride) {
    const double a = tracker.value[k];
    if (std::isnan(a)) continue;
    ++known;
    const double b = controller.At(tracker.start + tracker.step * static_cast<double>(k) - offset);
    if (std::isnan(b)) continue;
    sum += (a - b) * (a - b);
    ++used;
  }
  if (used < 10 || 2 * used < known) return kNaN;
  return sum / static_cast<double>(used);
}

// The best lag on [lo, hi] in steps of `step`, refined by a parabola through its neighbours.
std::optional<double> BestLag(const Profile& tracker, const Profile& controller, double lo,
                              double hi, double step, size_t stride) {
  std::vector<double> lags, cost;
  for (double lag = lo; lag <= hi + 1e-12; lag += step) {
    lags.push_back(lag);
    cost.push_back(Mismatch(tracker, controller, lag, stride));
  }
  size_t best = lags.size();
  for (size_t i = 0; i < lags.size(); ++i) {
    if (std::isnan(cost[i])) continue;
    if (best == lags.size() || cost[i] < cost[best]) best = i;
  }
  if (best == lags.size()) return std::nullopt;
  double lag = lags[best];
  if (best > 0 && best + 1 < lags.size() && !std::isnan(cost[best - 1]) &&
      !std::isnan(cost[best + 1])) {
    const double den = cost[best - 1] - 2.0 * cost[best] + cost[best + 1];
    if (den > 0.0) lag += 0.5 * step * (cost[best - 1] - cost[best + 1]) / den;
  }
  return lag;
}

}  // namespace

double ClockMap::SigmaAt(double tracker_s) const {
  const Eigen::Vector2d g(1.0, tracker_s - reference_s);
  return std::sqrt(std::max(0.0, g.dot(covariance * g)));
}

std::optional<JointState> JointsAt(const JointStream& joints, double t, double max_gap_s) {
  const auto& ts = joints.t_s;
  if (ts.size() < 2 || !(t >= ts.front()) || !(t <= ts.back())) return std::nullopt;
  auto it = std::upper_bound(ts.begin(), ts.end(), t);
  if (it == ts.end()) --it;  // t at the last package
  const auto i1 = static_cast<size_t>(it - ts.begin());
  const size_t i0 = i1 - 1;
  const double h = ts[i1] - ts[i0];
  if (!(h > 0.0) || h > max_gap_s) return std::nullopt;
  const double s = (t - ts[i0]) / h;
  const double s2 = s * s, s3 = s2 * s;
  const Eigen::VectorXd &q0 = joints.q_rad[i0], &q1 = joints.q_rad[i1];
  const Eigen::VectorXd &v0 = joints.qd_rad_s[i0], &v1 = joints.qd_rad_s[i1];
  JointState out;
  out.q_rad = (2 * s3 - 3 * s2 + 1) * q0 + (s3 - 2 * s2 + s) * h * v0 + (-2 * s3 + 3 * s2) * q1 +
              (s3 - s2) * h * v1;
  out.qd_rad_s = ((6 * s2 - 6 * s) * q0 + (3 * s2 - 4 * s + 1) * h * v0 + (-6 * s2 + 6 * s) * q1 +
                  (3 * s2 - 2 * s) * h * v1) /
                 h;
  // The bracket's and its neighbours' (a point just before a ramp begins is interpolated
  // across the jerk: it counts as accelerating).
  out.acceleration_rad_s2 = (v1 - v0).cwiseAbs().maxCoeff() / h;
  if (i0 > 0 && ts[i0] > ts[i0 - 1]) {
    out.acceleration_rad_s2 =
        std::max(out.acceleration_rad_s2,
                 (v0 - joints.qd_rad_s[i0 - 1]).cwiseAbs().maxCoeff() / (ts[i0] - ts[i0 - 1]));
  }
  if (i1 + 1 < ts.size() && ts[i1 + 1] > ts[i1]) {
    out.acceleration_rad_s2 =
        std::max(out.acceleration_rad_s2,
                 (joints.qd_rad_s[i1 + 1] - v1).cwiseAbs().maxCoeff() / (ts[i1 + 1] - ts[i1]));
  }
  return out;
}

std::optional<ClockMap> CoarseClock(const RobotModel& model, const Eigen::VectorXd& params,
                                    const JointStream& joints, const PointStream& points,
                                    const ClockMap& guess, const ClockOptions& options) {
  if (joints.size() < 2 || points.size() < 3) return std::nullopt;
  // The controller's speed profile by the model.
  Kinematics kin(model);
  std::vector<double> speed_c(joints.size());
  for (size_t i = 0; i < joints.size(); ++i)
    speed_c[i] = TargetMotion(kin, params, joints.q_rad[i], joints.qd_rad_s[i]).v.norm();
  // The tracker's, from successive points (at their mid-times).
  std::vector<double> t_mid, speed_t;
  for (size_t i = 1; i < points.size(); ++i) {
    const double dt = points.t_s[i] - points.t_s[i - 1];
    if (!(dt > 0.0)) continue;
    t_mid.push_back(0.5 * (points.t_s[i] + points.t_s[i - 1]));
    speed_t.push_back((points.point_mm[i] - points.point_mm[i - 1]).norm() / dt);
  }
  const double step = options.grid_s;
  // The speed profile is smooth: a lag to a grid step survives gaps the pairing would not
  // interpolate across (a stream that lost packages now and then).
  const Profile controller = Resample(joints.t_s, speed_c, step, std::max(options.max_gap_s, 0.25));
  const Profile tracker = Resample(t_mid, speed_t, step, std::max(0.1, 20 * step));
  if (tracker.value.size() * step < 2.0 || controller.value.size() * step < 2.0) return std::nullopt;
  // Wide and coarse (every 10th grid step, every 4th sample), then narrow and fine.
  const double wide = 10.0 * step;
  const auto coarse = BestLag(tracker, controller, guess.offset_s - options.max_lag_s,
                              guess.offset_s + options.max_lag_s, wide, 4);
  if (!coarse) return std::nullopt;
  const auto fine = BestLag(tracker, controller, *coarse - 2.0 * wide, *coarse + 2.0 * wide, step, 1);
  if (!fine) return std::nullopt;
  ClockMap out;
  out.offset_s = *fine;
  out.drift = 0.0;
  out.reference_s = 0.5 * (points.t_s.front() + points.t_s.back());
  return out;
}

ClockMap RefineClock(const RobotModel& model, const Eigen::VectorXd& params,
                     const JointStream& joints, const PointStream& points, const ClockMap& start,
                     Eigen::Isometry3d& world_from_base, const ClockOptions& options) {
  if (points.size() == 0) throw std::invalid_argument("clock refinement: no tracker points");
  // Controller time at tracker time t: a + b (t − ref).
  const double ref = 0.5 * (points.t_s.front() + points.t_s.back());
  double a = start.ControllerTime(ref);
  double b = 1.0 / (1.0 + start.drift);
  // At most 4,000 points, evenly through the stream.
  const size_t stride = std::max<size_t>(1, points.size() / 4000);
  Kinematics kin(model);
  ClockMap out;
  out.reference_s = ref;
  Eigen::Matrix2d normal = Eigen::Matrix2d::Zero();
  double sum_sq = 0.0;
  int used = 0;
  for (int iteration = 0; iteration < options.max_iterations; ++iteration) {
    std::vector<Eigen::Vector3d> x, v, p;
    std::vector<double> dt;
    for (size_t i = 0; i < points.size(); i += stride) {
      const double tc = a + b * (points.t_s[i] - ref);
      const auto js = JointsAt(joints, tc, options.max_gap_s);
      if (!js || js->acceleration_rad_s2 > options.max_acceleration_rad_s2) continue;
      const Moving m = TargetMotion(kin, params, js->q_rad, js->qd_rad_s);
      x.push_back(m.x);
      v.push_back(m.v);
      p.push_back(points.point_mm[i]);
      dt.push_back(points.t_s[i] - ref);
    }
    const auto n = static_cast<Eigen::Index>(x.size());
    int moving = 0;
    for (const auto& vi : v) moving += vi.norm() >= options.min_speed_mm_s ? 1 : 0;
    if (moving < 20) {
      throw std::invalid_argument("clock refinement: " + std::to_string(moving) +
                                  " points paired while the target moved (at least 20 needed)");
    }
    // The frame for this clock (a rigid fit of the model's positions to the points).
    Eigen::Matrix3Xd src(3, n), dst(3, n);
    for (Eigen::Index i = 0; i < n; ++i) {
      src.col(i) = x[i];
      dst.col(i) = p[i];
    }
    world_from_base = Eigen::Isometry3d(Eigen::umeyama(src, dst, false));
    const Eigen::Matrix3d R = world_from_base.linear();
    // Gauss-Newton step of (a, b) on the moving points.
    normal.setZero();
    Eigen::Vector2d rhs = Eigen::Vector2d::Zero();
    sum_sq = 0.0;
    used = 0;
    for (Eigen::Index i = 0; i < n; ++i) {
      const Eigen::Vector3d r = p[i] - world_from_base * x[i];
      sum_sq += r.squaredNorm();
      if (v[i].norm() < options.min_speed_mm_s) continue;
      ++used;
      Eigen::Matrix<double, 3, 2> J;
      J.col(0) = R * v[i];
      J.col(1) = R * v[i] * dt[i];
      normal += J.transpose() * J;
      rhs += J.transpose() * r;
    }
    const Eigen::Vector2d step = normal.ldlt().solve(rhs);
    if (!step.allFinite()) throw std::invalid_argument("clock refinement: a singular step");
    a += step(0);
    b += step(1);
    out.iterations = iteration + 1;
    const double span = 0.5 * (points.t_s.back() - points.t_s.front());
    if (std::abs(step(0)) < 1e-8 && std::abs(step(1)) * span < 1e-8) break;
  }
  const int dof = std::max(1, 3 * used - 2 - 6);
  const double sigma2 = sum_sq / std::max(1, dof);
  out.sigma0_mm = std::sqrt(sigma2);
  out.covariance = sigma2 * normal.inverse();
  // a + b (t − ref) = t_c  ⇔  t = ref − a / b + t_c / b.
  out.drift = 1.0 / b - 1.0;
  out.offset_s = ref - a / b;
  return out;
}

Pairing PairStreams(const RobotModel& model, const Eigen::VectorXd& params,
                    const Eigen::Isometry3d& world_from_base, const JointStream& joints,
                    const PointStream& points, const ClockMap& clock,
                    const PairingOptions& options) {
  Pairing out;
  Kinematics kin(model);
  const Eigen::Matrix3d R = world_from_base.linear();
  for (size_t i = 0; i < points.size(); ++i) {
    const double tc = clock.ControllerTime(points.t_s[i]);
    if (joints.size() < 2 || !(tc >= joints.t_s.front()) || !(tc <= joints.t_s.back())) {
      ++out.outside;
      continue;
    }
    const auto js = JointsAt(joints, tc, options.max_gap_s);
    if (!js) {
      ++out.gaps;
      continue;
    }
    if (js->acceleration_rad_s2 > options.max_acceleration_rad_s2) {
      ++out.accelerating;
      continue;
    }
    const Moving m = TargetMotion(kin, params, js->q_rad, js->qd_rad_s);
    PairedPoint pp;
    pp.index = i;
    pp.tracker_time_s = points.t_s[i];
    pp.controller_time_s = tc;
    pp.q_rad = js->q_rad;
    pp.point_mm = points.point_mm[i];
    pp.speed_mm_s = (R * m.v).norm();
    pp.acceleration_rad_s2 = js->acceleration_rad_s2;
    // ∂t_c/∂(a, b) is what SigmaAt propagates; the point moves speed × σ_t.
    pp.sync_sigma_mm = pp.speed_mm_s * clock.SigmaAt(points.t_s[i]);
    if (pp.sync_sigma_mm > options.max_sync_sigma_mm) {
      ++out.uncertain;
      continue;
    }
    out.points.push_back(std::move(pp));
  }
  return out;
}

}  // namespace armsig::calibration
