#include "simulation/joint_motion.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "robots/ur_codec.h"

namespace armsig::simulation {

PhysicalClock::PhysicalClock(double time_scale)
    : scale_(std::max(time_scale, 1e-3)), start_(std::chrono::steady_clock::now()) {}

double PhysicalClock::Now() const {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count() / scale_;
}

std::chrono::steady_clock::duration PhysicalClock::Wall(double physical_s) const {
  return std::chrono::duration_cast<std::chrono::steady_clock::duration>(
      std::chrono::duration<double>(std::max(physical_s, 0.0) * scale_));
}

JointMove::JointMove(Eigen::VectorXd from, Eigen::VectorXd to, double a, double v)
    : from_(std::move(from)), to_(std::move(to)), a_(a), v_(v) {
  if (from_.size() != to_.size()) throw std::invalid_argument("JointMove: joint counts differ");
  if (!(a > 0.0) || !(v > 0.0)) throw std::invalid_argument("JointMove: a and v must be > 0");
  const Eigen::VectorXd delta = to_ - from_;
  distance_ = delta.cwiseAbs().maxCoeff();
  direction_ = distance_ > 0.0 ? Eigen::VectorXd(delta / distance_) : Eigen::VectorXd(delta * 0.0);
  duration_ = robots::ur::MoveJDuration(distance_, a_, v_);
  // The profile's ramp time and top speed: v reached, or the triangle's peak.
  peak_ = std::min(v_, std::sqrt(a_ * distance_));
  ramp_ = peak_ / a_;
}

JointMove::PathPoint JointMove::Path(double t) const {
  if (t <= 0.0) return {0.0, 0.0};
  if (t >= duration_) return {distance_, 0.0};
  if (t < ramp_) return {0.5 * a_ * t * t, a_ * t};
  const double cruise_end = duration_ - ramp_;
  if (t <= cruise_end) return {0.5 * a_ * ramp_ * ramp_ + peak_ * (t - ramp_), peak_};
  const double left = duration_ - t;
  return {distance_ - 0.5 * a_ * left * left, a_ * left};
}

Eigen::VectorXd JointMove::PositionAlong(double s) const {
  return from_ + direction_ * std::clamp(s, 0.0, distance_);
}

Eigen::VectorXd JointMove::VelocityAlong(double ds) const { return direction_ * ds; }

JointMove::PathPoint JointMove::Braked(double t_stop, double deceleration, double t) const {
  const PathPoint at = Path(t_stop);
  const double stop_after = at.ds / deceleration;
  const double tau = std::clamp(t - t_stop, 0.0, stop_after);
  return {std::min(distance_, at.s + at.ds * tau - 0.5 * deceleration * tau * tau),
          at.ds - deceleration * tau};
}

double JointMove::BrakedUntil(double t_stop, double deceleration) const {
  return t_stop + Path(t_stop).ds / deceleration;
}

}  // namespace armsig::simulation
