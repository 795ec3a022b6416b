// K-fold cross-validation of the calibration on the fit poses only: which non-geometric
// terms earn their place (--params auto) and whether a residual map beats the parametric
// model (calibration/residual_map.h). Held-out poses are never seen here.
//
// The parametric refits are one Gauss–Newton step from the fit on all poses: the error
// model is linear in its parameters to about |parameter| (1e-3 rad, 1 mm against metre
// lever arms), so a fold's refit differs from the exact re-estimation by about 1e-3 of
// its change, far below the figures compared. That makes every subset of candidate
// columns cheap to cross-validate: the per-fold normal equations are taken once.
#pragma once

#include <Eigen/Core>
#include <vector>

namespace armsig::calibration {

// Fold (0 … folds−1) of each of `count` poses: a seeded shuffle (mt19937, the same on every
// platform), dealt round-robin so that fold sizes differ by at most one.
std::vector<int> AssignFolds(int count, int folds, unsigned seed);

class LinearisedCrossValidation {
 public:
  // `jacobian`: 3m × P stacked derivatives of the positions (pose i in rows 3i … 3i+2) by
  // every candidate column, at a fit; `residual`: 3m, model − measured at that fit;
  // `fold_of_pose`: m entries in [0, folds).
  LinearisedCrossValidation(Eigen::MatrixXd jacobian, Eigen::VectorXd residual,
                            std::vector<int> fold_of_pose, int folds);
  // With orientation equations (calibration/orientation.h): `jacobian` and `residual` have
  // three more rows for each pose listed in `pose_of_extra_rows`, after the 3m position
  // rows and in that order. They count in every refit (with their pose's fold) and in the
  // sums of squares; the held-out errors are the positions'.
  LinearisedCrossValidation(Eigen::MatrixXd jacobian, Eigen::VectorXd residual,
                            std::vector<int> fold_of_pose, int folds,
                            std::vector<int> pose_of_extra_rows);

  int folds() const { return folds_; }
  const Eigen::MatrixXd& jacobian() const { return jacobian_; }
  int poses() const { return static_cast<int>(fold_of_pose_.size()); }
  const std::vector<int>& fold_of_pose() const { return fold_of_pose_; }

  // The residual (3m, then the extra rows) of every pose under the model refitted without
  // `fold` on the columns `columns` (indices into the Jacobian's columns).
  Eigen::VectorXd RefitWithout(int fold, const std::vector<int>& columns) const;

  // Every pose's residual vector predicted by the refit that did not see its fold.
  std::vector<Eigen::Vector3d> HeldOut(const std::vector<int>& columns) const;
  double HeldOutMeanMm(const std::vector<int>& columns) const;

  // Σ r² over all poses after the refit on all of them (the linearised RSS of `columns`).
  double ResidualSumOfSquares(const std::vector<int>& columns) const;

 private:
  Eigen::MatrixXd jacobian_;
  Eigen::VectorXd residual_;
  std::vector<int> fold_of_pose_;
  int folds_;
  std::vector<int> pose_of_extra_rows_;
  std::vector<Eigen::MatrixXd> fold_normal_;    // J_fᵀ J_f, P × P
  std::vector<Eigen::VectorXd> fold_gradient_;  // J_fᵀ r_f
  Eigen::MatrixXd normal_;
  Eigen::VectorXd gradient_;
};

}  // namespace armsig::calibration
