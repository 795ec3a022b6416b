// The model's inverse for a whole pose: encoder angles that put the target point at a
// position and the last link frame at an orientation (a six-joint arm has exactly the
// freedom for both). The ISO 9283 plan commands its five test points with one tool
// orientation, as the standard asks.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "calibration/compensation.h"
#include "calibration/model.h"

namespace armsig::calibration {

// Each radian of orientation error weighs as much as this many mm of position error in
// the damped least squares (and in the convergence test).
inline constexpr double kPoseLeverMm = 1000.0;

// Encoder angles for which the model (with `params`) puts its target point at
// `target_mm` and its last link frame at `rotation` (world from link n), by damped least
// squares from `seed` on the position error and the rotation vector of
// rotation·R(θ)ᵀ (weighted by kPoseLeverMm). Status as SolveJoints: kNotConverged when no
// joint angles reach the pose (residual_mm is then the weighted error), kOutOfRange
// outside the model's joint limits, kNonFinite for no number at all.
JointSolution SolvePose(const RobotModel& model, const Eigen::Isometry3d& world_from_base,
                        const Eigen::VectorXd& params, const Eigen::Vector3d& target_mm,
                        const Eigen::Matrix3d& rotation, const Eigen::VectorXd& seed_rad,
                        const JointSolveOptions& options = {});

// The last link frame's rotation (world from link n) at these encoder angles.
Eigen::Matrix3d LastLinkRotation(const RobotModel& model, const Eigen::Isometry3d& world_from_base,
                                 const Eigen::VectorXd& params, const Eigen::VectorXd& joints_rad);

}  // namespace armsig::calibration
