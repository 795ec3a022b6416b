#include "calibration/cross_validation.h"

#include <gtest/gtest.h>

#include <Eigen/QR>
#include <random>

namespace armsig::calibration {

TEST(CrossValidation, FoldsAreBalancedSeededAndDeterministic) {
  const auto folds = AssignFolds(103, 5, 7);
  std::vector<int> size(5, 0);
  for (int f : folds) ++size[f];
  for (int s : size) EXPECT_TRUE(s == 20 || s == 21) << s;
  EXPECT_EQ(folds, AssignFolds(103, 5, 7));
  EXPECT_NE(folds, AssignFolds(103, 5, 8));
  // Shuffled: not dealt in file order.
  int in_order = 0;
  for (int i = 0; i < 103; ++i) in_order += folds[i] == i % 5;
  EXPECT_LT(in_order, 60);
  EXPECT_THROW(AssignFolds(3, 5, 1), std::invalid_argument);
}

TEST(CrossValidation, RefitsEqualLeastSquaresWithoutTheFold) {
  // A linear model: the linearised refit is then exact. Independent check: solve each
  // fold's least squares from its own rows (Householder QR), predict the held-out rows.
  std::mt19937 rng(4);
  std::normal_distribution<double> normal;
  const int m = 60, p = 7;
  Eigen::MatrixXd j(3 * m, p);
  for (int r = 0; r < j.rows(); ++r)
    for (int c = 0; c < p; ++c) j(r, c) = normal(rng);
  Eigen::VectorXd truth(p), noise(3 * m);
  for (int c = 0; c < p; ++c) truth(c) = normal(rng);
  for (int r = 0; r < 3 * m; ++r) noise(r) = 0.1 * normal(rng);
  // Residual r = model − measured at parameters 0; measured = J·truth + noise.
  const Eigen::VectorXd residual = -(j * truth + noise);
  const auto folds = AssignFolds(m, 4, 1);
  const LinearisedCrossValidation cv(j, residual, folds, 4);
  const std::vector<int> columns = {0, 2, 3, 6};
  const auto held_out = cv.HeldOut(columns);
  double mean = 0.0;
  for (int f = 0; f < 4; ++f) {
    std::vector<int> train;
    for (int i = 0; i < m; ++i)
      if (folds[i] != f) train.push_back(i);
    Eigen::MatrixXd a(3 * train.size(), columns.size());
    Eigen::VectorXd b(3 * train.size());
    for (size_t t = 0; t < train.size(); ++t) {
      for (size_t c = 0; c < columns.size(); ++c) {
        a.block<3, 1>(3 * t, c) = j.block<3, 1>(3 * train[t], columns[c]);
      }
      b.segment<3>(3 * t) = -residual.segment<3>(3 * train[t]);  // measured − model(0)
    }
    const Eigen::VectorXd x = a.householderQr().solve(b);
    const Eigen::VectorXd refit = cv.RefitWithout(f, columns);
    for (int i = 0; i < m; ++i) {
      Eigen::Vector3d expected = residual.segment<3>(3 * i);
      for (size_t c = 0; c < columns.size(); ++c)
        expected += j.block<3, 1>(3 * i, columns[c]) * x(c);
      EXPECT_LT((refit.segment<3>(3 * i) - expected).norm(), 1e-10);
      if (folds[i] == f) {
        EXPECT_LT((held_out[i] - expected).norm(), 1e-10);
        mean += expected.norm() / m;
      }
    }
  }
  EXPECT_NEAR(cv.HeldOutMeanMm(columns), mean, 1e-12);
  // The RSS on all poses is the least-squares minimum.
  Eigen::MatrixXd a(3 * m, columns.size());
  for (size_t c = 0; c < columns.size(); ++c) a.col(c) = j.col(columns[c]);
  const Eigen::VectorXd x = a.householderQr().solve(-residual);
  EXPECT_NEAR(cv.ResidualSumOfSquares(columns), (residual + a * x).squaredNorm(), 1e-9);
}

}  // namespace armsig::calibration
