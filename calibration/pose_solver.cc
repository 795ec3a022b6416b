#include "calibration/pose_solver.h"

#include <fmt/format.h>

#include <Eigen/Cholesky>
#include <cmath>

#include "calibration/damped_step.h"
#include "core/units.h"

namespace armsig::calibration {

JointSolution SolvePose(const RobotModel& model, const Eigen::Isometry3d& world_from_base,
                        const Eigen::VectorXd& params, const Eigen::Vector3d& target_mm,
                        const Eigen::Matrix3d& rotation, const Eigen::VectorXd& seed_rad,
                        const JointSolveOptions& options) {
  options.Check();
  const int n = model.num_joints();
  Kinematics kin(model);
  JointSolution s;
  s.joints_rad = seed_rad;
  // The weighted 6-vector error [position; lever · rotation vector] and its Jacobian.
  Eigen::Matrix<double, 6, 1> e;
  Eigen::MatrixXd j(6, n);
  auto evaluate = [&](const Eigen::VectorXd& q) {
    const Eigen::Vector3d x = kin.Position(world_from_base, params, q.data());
    const Eigen::AngleAxisd turn(rotation * kin.LastRotation().transpose());
    e.head<3>() = target_mm - x;
    e.tail<3>() = kPoseLeverMm * turn.angle() * turn.axis();
    // ∂x/∂θ and the angular velocity's ∂ω/∂θ (the joint axes), as in SolveJoints the
    // h-terms' own dependence on the angles is left to the iteration.
    kin.WriteJointJacobian(j.topRows<3>());
    kin.WriteJointAxes(j.bottomRows<3>());
    j.bottomRows<3>() *= kPoseLeverMm;
    return e.norm();
  };
  StallWatch watch;
  DampedStepper stepper;
  for (; s.iterations < options.max_iterations; ++s.iterations) {
    s.residual_mm = evaluate(s.joints_rad);
    if (!(s.residual_mm >= options.tolerance_mm)) break;  // converged, or not a number
    s.joints_rad += stepper.Step(j, e, s.residual_mm, options);
    if (watch.Stalled(s.residual_mm)) break;
  }
  s.residual_mm = evaluate(s.joints_rad);
  if (!std::isfinite(s.residual_mm) || !s.joints_rad.allFinite()) {
    s.status = {SolveCode::kNonFinite,
                "the solution is not a finite number (seed, pose or parameters not finite)"};
    return s;
  }
  if (s.residual_mm > options.tolerance_mm * 10) {
    s.status = {SolveCode::kNotConverged,
                fmt::format("no joint angles reach the pose (closest {:.3f} mm and {:.3f} deg)",
                            e.head<3>().norm(), e.tail<3>().norm() / kPoseLeverMm / kRadPerDeg)};
    return s;
  }
  s.status = JointLimitStatus(model, s.joints_rad);
  return s;
}

Eigen::Matrix3d LastLinkRotation(const RobotModel& model, const Eigen::Isometry3d& world_from_base,
                                 const Eigen::VectorXd& params, const Eigen::VectorXd& joints_rad) {
  Kinematics kin(model);
  kin.Position(world_from_base, params, joints_rad.data());
  return kin.LastRotation();
}

}  // namespace armsig::calibration
