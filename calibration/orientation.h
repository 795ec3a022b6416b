// The orientation of a 6-DoF target in the fit: its residual, the residual's derivative, and
// the target frame's rotation on the last link. Pure math on rotation matrices.
//
// The model predicts the target frame as R = R_last · R_tool: R_last the last link frame's
// rotation in the measurement frame (Kinematics::LastRotation), R_tool the target frame's
// rotation in the last link frame (a constant of the set-up: how the probe is screwed on).
// A measured orientation R_meas is compared through the rotation vector of R_measᵀ·R, the
// turn that takes the measured target frame to the predicted one, in the target frame.
#pragma once

#include <Eigen/Core>
#include <optional>
#include <vector>

#include "calibration/model.h"
#include "core/types.h"

namespace armsig::calibration {

// log and exp of SO(3): the rotation vector (axis · angle, angle in [0, π]) and back.
Eigen::Vector3d RotationVector(const Eigen::Matrix3d& rotation);
Eigen::Matrix3d RotationFromVector(const Eigen::Vector3d& vector);

// The orientation residual: the rotation vector of measuredᵀ · predicted (rad, target frame).
Eigen::Vector3d OrientationResidual(const Eigen::Matrix3d& measured, const Eigen::Matrix3d& predicted);

// J_r⁻¹(e), the inverse right Jacobian of SO(3): turning the predicted frame by a small δ in
// its own frame, predicted·exp([δ]×), moves the residual e by J_r⁻¹(e)·δ to first order; a
// world-side turn ω, exp([ω]×)·predicted, moves it by J_r⁻¹(e)·predictedᵀ·ω.
Eigen::Matrix3d InverseRightJacobian(const Eigen::Vector3d& residual);

// The orientation residual of a pose predicted as R = last_rotation · tool, and what the fit
// multiplies by to linearise it: a world-side turn ω of the last link (a parameter's
// column of Kinematics::PoseAndJacobian's rotation rows, a base's rotation) moves it by
// by_world_turn·ω = J_r⁻¹(ε)·Rᵀ·ω; a turn δ of the tool in the target frame by
// by_tool_turn·δ = J_r⁻¹(ε)·δ.
struct OrientationLinearisation {
  Eigen::Vector3d residual = Eigen::Vector3d::Zero();
  Eigen::Matrix3d by_world_turn = Eigen::Matrix3d::Identity();
  Eigen::Matrix3d by_tool_turn = Eigen::Matrix3d::Identity();
};
OrientationLinearisation LineariseOrientation(const Eigen::Matrix3d& measured,
                                              const Eigen::Matrix3d& last_rotation,
                                              const Eigen::Matrix3d& tool);

// The rotation nearest (in the Frobenius norm) to the mean of `rotations`: their chordal
// mean. Identity for none.
Eigen::Matrix3d MeanRotation(const std::vector<Eigen::Matrix3d>& rotations);

// The covariance (rad², target frame) of a measured orientation from its three angles'
// sigmas (core/rotation.h); nullopt when the measurement has no sigmas.
std::optional<Eigen::Matrix3d> OrientationCovariance(const MeasuredOrientation& orientation);

// The target frame's rotation in the last link frame that best explains the measured
// orientations of `poses` (those that have one) under `params`, each pose in its frame's
// base (`base_of(frame)`): the mean of R_lastᵀ · R_meas. nullopt when no pose has an
// orientation.
template <typename BaseOf>
std::optional<Eigen::Matrix3d> AlignToolRotation(const RobotModel& model, const BaseOf& base_of,
                                                 const Eigen::VectorXd& params,
                                                 const std::vector<MeasuredPose>& poses) {
  Kinematics kin(model);
  std::vector<Eigen::Matrix3d> relative;
  for (const auto& p : poses) {
    if (!p.orientation) continue;
    kin.Position(base_of(p.frame), params, p.joints_rad.data());
    relative.push_back(kin.LastRotation().transpose() * p.orientation->world_from_target);
  }
  if (relative.empty()) return std::nullopt;
  return MeanRotation(relative);
}

}  // namespace armsig::calibration
