// The damped least-squares iteration of the joint solvers (SolveJoints: a position,
// SolveJointsForPose: a whole pose): one step and the stall test they share.
#pragma once

#include <Eigen/Cholesky>
#include <Eigen/Core>
#include <algorithm>
#include <cmath>

#include "calibration/compensation.h"

namespace armsig::calibration {

// One step of the joints towards the target: Δθ = Jᵀ (J Jᵀ + λ² I)⁻¹ e (the damped
// pseudo-inverse, λ = damping shrinking with the error below 10 mm so that the last steps are
// Gauss-Newton's), its largest joint move capped at options.max_step_rad.
inline Eigen::VectorXd DampedJointStep(const Eigen::MatrixXd& j, const Eigen::VectorXd& e,
                                       double residual_mm, const JointSolveOptions& options) {
  const double lambda = options.damping_mm * std::min(1.0, residual_mm / 10.0);
  const Eigen::MatrixXd jjt =
      j * j.transpose() + lambda * lambda * Eigen::MatrixXd::Identity(j.rows(), j.rows());
  Eigen::VectorXd step = j.transpose() * jjt.ldlt().solve(e);
  const double largest = step.cwiseAbs().maxCoeff();
  if (largest > options.max_step_rad) step *= options.max_step_rad / largest;
  return step;
}

// An iteration that stopped improving: the best residual not bettered by 0.1 % in 20 steps.
class StallWatch {
 public:
  bool Stalled(double residual_mm) {
    if (residual_mm < best_ * 0.999) {
      best_ = residual_mm;
      stalled_ = 0;
      return false;
    }
    return ++stalled_ > 20;
  }

 private:
  double best_ = INFINITY;
  int stalled_ = 0;
};

}  // namespace armsig::calibration
