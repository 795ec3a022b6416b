#include "simulation/path_motion.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

namespace armsig::simulation {

namespace {

// The pose error (position mm, rotation vector rad) of the TCP at `q` from `target`.
Eigen::Matrix<double, 6, 1> PoseError(const programs::ControllerModel& controller,
                                      const Eigen::Isometry3d& tool, const Eigen::VectorXd& q,
                                      const Eigen::Isometry3d& target) {
  const Eigen::Isometry3d at = programs::TcpPose(controller, q, tool);
  Eigen::Matrix<double, 6, 1> e;
  e.head<3>() = target.translation() - at.translation();
  const Eigen::AngleAxisd turn(target.linear() * at.linear().transpose());
  e.tail<3>() = turn.angle() * turn.axis();
  return e;
}

// Newton's method from `seed` (a solution a few millimetres away: the sample before), with a
// central-difference Jacobian; nullopt when it does not settle within 10 steps.
std::optional<Eigen::VectorXd> NearInverse(const programs::ControllerModel& controller,
                                           const Eigen::Isometry3d& tool,
                                           const Eigen::Isometry3d& target,
                                           const Eigen::VectorXd& seed) {
  Eigen::VectorXd q = seed;
  const auto n = q.size();
  for (int step = 0; step < 10; ++step) {
    const Eigen::Matrix<double, 6, 1> e = PoseError(controller, tool, q, target);
    if (e.head<3>().norm() < 1e-7 && e.tail<3>().norm() < 1e-10) return q;
    Eigen::Matrix<double, 6, Eigen::Dynamic> J(6, n);
    constexpr double h = 1e-7;
    for (Eigen::Index j = 0; j < n; ++j) {
      Eigen::VectorXd plus = q, minus = q;
      plus(j) += h;
      minus(j) -= h;
      // The error's change is minus the pose's.
      J.col(j) = (PoseError(controller, tool, minus, target) - PoseError(controller, tool, plus, target)) /
                 (2.0 * h);
    }
    const Eigen::VectorXd dq = J.completeOrthogonalDecomposition().solve(e);
    if (!dq.allFinite()) return std::nullopt;
    q += dq;
  }
  const Eigen::Matrix<double, 6, 1> e = PoseError(controller, tool, q, target);
  if (e.head<3>().norm() < 1e-5 && e.tail<3>().norm() < 1e-8) return q;
  return std::nullopt;
}

}  // namespace

std::optional<std::vector<Eigen::VectorXd>> LinearPath(const programs::ControllerModel& controller,
                                                       const LinearPathRequest& r, std::string* why) {
  const Eigen::Isometry3d from = programs::TcpPose(controller, r.start_rad, r.tool);
  const Eigen::Vector3d delta = r.to_tcp.translation() - from.translation();
  const double length = delta.norm();
  const Eigen::Quaterniond q0(from.linear()), q1(r.to_tcp.linear());
  // The trapezoid on the path length (a triangle when the cruise speed is never reached).
  const double a = r.acceleration_mm_s2, v = r.speed_mm_s;
  const double ramp = std::min(v / a, std::sqrt(length / a));
  const double peak = a * ramp;
  const double duration = length > 0.0 ? 2.0 * ramp + (length - a * ramp * ramp) / peak : 0.0;
  const auto steps = std::max<size_t>(1, static_cast<size_t>(std::ceil(duration / r.dt_s)));
  std::vector<Eigen::VectorXd> joints;
  joints.reserve(steps + 1);
  joints.push_back(r.start_rad);
  for (size_t k = 1; k <= steps; ++k) {
    const double t = std::min(duration, r.dt_s * static_cast<double>(k));
    double s = 0.0;
    if (t < ramp) {
      s = 0.5 * a * t * t;
    } else if (t < duration - ramp) {
      s = 0.5 * a * ramp * ramp + peak * (t - ramp);
    } else {
      const double left = duration - t;
      s = length - 0.5 * a * left * left;
    }
    const double f = length > 0.0 ? std::clamp(s / length, 0.0, 1.0) : 1.0;
    Eigen::Isometry3d tcp = Eigen::Isometry3d::Identity();
    tcp.linear() = q0.slerp(f, q1).toRotationMatrix();
    tcp.translation() = from.translation() + f * delta;
    // From the sample before (a few millimetres back), as a controller's inverse follows a
    // path; its full search only when that does not settle.
    if (auto near = NearInverse(controller, r.tool, tcp, joints.back())) {
      joints.push_back(*near);
      continue;
    }
    programs::InverseRequest request;
    request.tcp = tcp;
    request.tool = r.tool;
    request.near_rad = joints.back();
    const programs::InverseSolution solution = programs::ControllerInverse(controller, request);
    if (!solution.joints_rad) {
      if (why) *why = fmt::format("no joints at {:.1f} mm of the line: {}", s, solution.why);
      return std::nullopt;
    }
    joints.push_back(*solution.joints_rad);
  }
  // The last sample at the exact target time: dt apart like the others (the path is sampled
  // every dt; the last step may be shorter, which MovePath's constant dt rounds up).
  return joints;
}

}  // namespace armsig::simulation
