#include "simulation/path_motion.h"

#include <fmt/format.h>

#include <Eigen/QR>
#include <algorithm>
#include <cmath>

#include "calibration/iso9283_path.h"

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

// The pose's Jacobian at some joints near the path's current ones, and its factorisation: a
// Jacobian changes little over a few millimetres of path, so one serves several samples (each
// Newton step then costs one forward kinematics instead of thirteen).
struct PathJacobian {
  Eigen::CompleteOrthogonalDecomposition<Eigen::MatrixXd> solver;
  bool valid = false;
  void At(const programs::ControllerModel& controller, const Eigen::Isometry3d& tool,
          const Eigen::Isometry3d& target, const Eigen::VectorXd& q) {
    const auto n = q.size();
    Eigen::MatrixXd J(6, n);
    constexpr double h = 1e-7;
    for (Eigen::Index j = 0; j < n; ++j) {
      Eigen::VectorXd plus = q, minus = q;
      plus(j) += h;
      minus(j) -= h;
      // The error's change is minus the pose's.
      J.col(j) = (PoseError(controller, tool, minus, target) - PoseError(controller, tool, plus, target)) /
                 (2.0 * h);
    }
    solver.compute(J);
    valid = true;
  }
};

// Newton's method from `seed` (a solution a few millimetres away: the sample before), with
// `jacobian` kept from the samples before while it converges (a central-difference Jacobian
// made again when there is none, and after every fourth step without convergence); nullopt
// when it does not settle within 12 steps.
std::optional<Eigen::VectorXd> NearInverse(const programs::ControllerModel& controller,
                                           const Eigen::Isometry3d& tool,
                                           const Eigen::Isometry3d& target,
                                           const Eigen::VectorXd& seed, PathJacobian& jacobian) {
  Eigen::VectorXd q = seed;
  for (int step = 0; step < 12; ++step) {
    const Eigen::Matrix<double, 6, 1> e = PoseError(controller, tool, q, target);
    if (e.head<3>().norm() < 1e-7 && e.tail<3>().norm() < 1e-10) return q;
    if (!jacobian.valid || (step > 0 && step % 4 == 0)) jacobian.At(controller, tool, target, q);
    const Eigen::VectorXd dq = jacobian.solver.solve(Eigen::VectorXd(e));
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
  std::optional<calibration::iso9283::CircleArc> arc;
  if (r.via_mm) {
    arc = calibration::iso9283::ArcThrough(from.translation(), *r.via_mm, r.to_tcp.translation());
    if (!arc) {
      if (why) *why = "the circular move's start, via point and target lie on one line";
      return std::nullopt;
    }
  }
  const double length = arc ? arc->length_mm() : delta.norm();
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
  const auto every = static_cast<size_t>(std::max(1, r.solve_every));
  PathJacobian jacobian;
  size_t solved = 0;  // the index of the last solved sample
  for (size_t k = 1; k <= steps; ++k) {
    if (k % every != 0 && k != steps) continue;
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
    tcp.translation() = arc ? arc->At(f) : Eigen::Vector3d(from.translation() + f * delta);
    // From the sample before (a few millimetres back), as a controller's inverse follows a
    // path; its full search only when that does not settle.
    std::optional<Eigen::VectorXd> q = NearInverse(controller, r.tool, tcp, joints.back(), jacobian);
    if (!q) {
      jacobian.valid = false;  // made again at the full search's joints
      programs::InverseRequest request;
      request.tcp = tcp;
      request.tool = r.tool;
      request.near_rad = joints.back();
      const programs::InverseSolution solution = programs::ControllerInverse(controller, request);
      if (!solution.joints_rad) {
        if (why) *why = fmt::format("no joints at {:.1f} mm of the line: {}", s, solution.why);
        return std::nullopt;
      }
      q = *solution.joints_rad;
    }
    const Eigen::VectorXd from_q = joints.back();
    for (size_t i = solved + 1; i < k; ++i)
      joints.push_back(from_q + (*q - from_q) * static_cast<double>(i - solved) / static_cast<double>(k - solved));
    joints.push_back(*q);
    solved = k;
  }
  // The last sample at the exact target time: dt apart like the others (the path is sampled
  // every dt; the last step may be shorter, which MovePath's constant dt rounds up).
  return joints;
}

}  // namespace armsig::simulation
