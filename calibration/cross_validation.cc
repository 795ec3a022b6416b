#include "calibration/cross_validation.h"

#include <Eigen/Cholesky>
#include <random>
#include <stdexcept>
#include <string>

namespace armsig::calibration {

std::vector<int> AssignFolds(int count, int folds, unsigned seed) {
  if (folds < 2 || count < folds) {
    throw std::invalid_argument("cross-validation needs at least 2 folds and a pose per fold (" +
                                std::to_string(count) + " poses, " + std::to_string(folds) +
                                " folds)");
  }
  std::vector<int> order(count);
  for (int i = 0; i < count; ++i) order[i] = i;
  // Fisher–Yates on mt19937's raw output (its sequence is fixed by the standard; the
  // standard distributions are not).
  std::mt19937 rng(seed);
  for (int i = count - 1; i > 0; --i) {
    const int j = static_cast<int>(rng() % static_cast<unsigned>(i + 1));
    std::swap(order[i], order[j]);
  }
  std::vector<int> fold(count);
  for (int k = 0; k < count; ++k) fold[order[k]] = k % folds;
  return fold;
}

LinearisedCrossValidation::LinearisedCrossValidation(Eigen::MatrixXd jacobian,
                                                     Eigen::VectorXd residual,
                                                     std::vector<int> fold_of_pose, int folds)
    : LinearisedCrossValidation(std::move(jacobian), std::move(residual),
                                std::move(fold_of_pose), folds, {}) {}

LinearisedCrossValidation::LinearisedCrossValidation(Eigen::MatrixXd jacobian,
                                                     Eigen::VectorXd residual,
                                                     std::vector<int> fold_of_pose, int folds,
                                                     std::vector<int> pose_of_extra_rows)
    : jacobian_(std::move(jacobian)),
      residual_(std::move(residual)),
      fold_of_pose_(std::move(fold_of_pose)),
      folds_(folds),
      pose_of_extra_rows_(std::move(pose_of_extra_rows)) {
  const int m = static_cast<int>(fold_of_pose_.size());
  const int blocks = m + static_cast<int>(pose_of_extra_rows_.size());
  if (jacobian_.rows() != 3 * blocks || residual_.size() != 3 * blocks) {
    throw std::invalid_argument("cross-validation: Jacobian, residual and folds disagree in size");
  }
  // The fold of every block of three rows: a pose's positions, then its orientation.
  std::vector<int> fold_of_block = fold_of_pose_;
  for (int pose : pose_of_extra_rows_) {
    if (pose < 0 || pose >= m) throw std::invalid_argument("cross-validation: pose out of range");
    fold_of_block.push_back(fold_of_pose_[pose]);
  }
  const Eigen::Index p = jacobian_.cols();
  fold_normal_.assign(folds_, Eigen::MatrixXd::Zero(p, p));
  fold_gradient_.assign(folds_, Eigen::VectorXd::Zero(p));
  // Rows of each fold gathered, then one symmetric rank update per fold.
  std::vector<int> count(folds_, 0);
  for (int f : fold_of_block) {
    if (f < 0 || f >= folds_) throw std::invalid_argument("cross-validation: fold out of range");
    ++count[f];
  }
  for (int f = 0; f < folds_; ++f) {
    Eigen::MatrixXd rows(3 * count[f], p);
    Eigen::VectorXd r(3 * count[f]);
    int k = 0;
    for (int i = 0; i < blocks; ++i) {
      if (fold_of_block[i] != f) continue;
      rows.middleRows<3>(3 * k) = jacobian_.middleRows<3>(3 * i);
      r.segment<3>(3 * k) = residual_.segment<3>(3 * i);
      ++k;
    }
    fold_normal_[f].selfadjointView<Eigen::Lower>().rankUpdate(rows.transpose());
    fold_normal_[f].triangularView<Eigen::Upper>() = fold_normal_[f].transpose();
    fold_gradient_[f] = rows.transpose() * r;
  }
  normal_ = Eigen::MatrixXd::Zero(p, p);
  gradient_ = Eigen::VectorXd::Zero(p);
  for (int f = 0; f < folds_; ++f) {
    normal_ += fold_normal_[f];
    gradient_ += fold_gradient_[f];
  }
}

namespace {

Eigen::MatrixXd Select(const Eigen::MatrixXd& m, const std::vector<int>& c) {
  Eigen::MatrixXd out(c.size(), c.size());
  for (size_t i = 0; i < c.size(); ++i)
    for (size_t j = 0; j < c.size(); ++j) out(i, j) = m(c[i], c[j]);
  return out;
}

Eigen::VectorXd Select(const Eigen::VectorXd& v, const std::vector<int>& c) {
  Eigen::VectorXd out(c.size());
  for (size_t i = 0; i < c.size(); ++i) out(i) = v(c[i]);
  return out;
}

}  // namespace

Eigen::VectorXd LinearisedCrossValidation::RefitWithout(int fold,
                                                        const std::vector<int>& columns) const {
  Eigen::VectorXd out = residual_;
  if (columns.empty()) return out;
  const Eigen::MatrixXd normal = Select(normal_, columns) - Select(fold_normal_[fold], columns);
  const Eigen::VectorXd gradient =
      Select(gradient_, columns) - Select(fold_gradient_[fold], columns);
  // Gauss–Newton from the fit on all poses: minimise Σ_{i∉f} |r_i + J_i δ|².
  const Eigen::VectorXd step = -normal.ldlt().solve(gradient);
  for (size_t c = 0; c < columns.size(); ++c) out += jacobian_.col(columns[c]) * step(c);
  return out;
}

std::vector<Eigen::Vector3d> LinearisedCrossValidation::HeldOut(
    const std::vector<int>& columns) const {
  const int m = poses();
  std::vector<Eigen::Vector3d> out(m);
  for (int f = 0; f < folds_; ++f) {
    if (columns.empty()) break;
    const Eigen::MatrixXd normal = Select(normal_, columns) - Select(fold_normal_[f], columns);
    const Eigen::VectorXd gradient =
        Select(gradient_, columns) - Select(fold_gradient_[f], columns);
    const Eigen::VectorXd step = -normal.ldlt().solve(gradient);
    for (int i = 0; i < m; ++i) {
      if (fold_of_pose_[i] != f) continue;
      Eigen::Vector3d r = residual_.segment<3>(3 * i);
      for (size_t c = 0; c < columns.size(); ++c) {
        r += jacobian_.block<3, 1>(3 * i, columns[c]) * step(c);
      }
      out[i] = r;
    }
  }
  if (columns.empty()) {
    for (int i = 0; i < m; ++i) out[i] = residual_.segment<3>(3 * i);
  }
  return out;
}

double LinearisedCrossValidation::HeldOutMeanMm(const std::vector<int>& columns) const {
  double sum = 0.0;
  const auto held_out = HeldOut(columns);
  for (const auto& r : held_out) sum += r.norm();
  return held_out.empty() ? 0.0 : sum / static_cast<double>(held_out.size());
}

double LinearisedCrossValidation::ResidualSumOfSquares(const std::vector<int>& columns) const {
  const double rss = residual_.squaredNorm();
  if (columns.empty()) return rss;
  const Eigen::VectorXd g = Select(gradient_, columns);
  return rss - g.dot(Select(normal_, columns).ldlt().solve(g));
}

}  // namespace armsig::calibration
