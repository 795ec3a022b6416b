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
// Gauss-Newton's), its largest joint move capped at options.max_step_rad. A solver's loop
// keeps one stepper: its matrices are allocated at the first step and reused (a controller's
// inverse runs thousands of steps per target, and under the sanitizers each allocation
// records a stack).
class DampedStepper {
 public:
  template <typename Jacobian, typename Error>
  const Eigen::VectorXd& Step(const Eigen::MatrixBase<Jacobian>& j, const Eigen::MatrixBase<Error>& e,
                              double residual_mm, const JointSolveOptions& options) {
    const double lambda = options.damping_mm * std::min(1.0, residual_mm / 10.0);
    jjt_.resize(j.rows(), j.rows());
    jjt_.noalias() = j * j.transpose();
    jjt_.diagonal().array() += lambda * lambda;
    ldlt_.compute(jjt_);
    y_ = ldlt_.solve(e);
    step_.resize(j.cols());
    step_.noalias() = j.transpose() * y_;
    const double largest = step_.cwiseAbs().maxCoeff();
    if (largest > options.max_step_rad) step_ *= options.max_step_rad / largest;
    return step_;
  }

 private:
  Eigen::MatrixXd jjt_;
  Eigen::LDLT<Eigen::MatrixXd> ldlt_;
  Eigen::VectorXd y_, step_;
};

// One step, for a loop that does not keep a stepper.
inline Eigen::VectorXd DampedJointStep(const Eigen::MatrixXd& j, const Eigen::VectorXd& e,
                                       double residual_mm, const JointSolveOptions& options) {
  DampedStepper stepper;
  return stepper.Step(j, e, residual_mm, options);
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
