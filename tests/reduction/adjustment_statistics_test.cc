#include "reduction/adjustment_statistics.h"

#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <random>

namespace armsig::reduction {

// A random whitened linear model: 12 observations, 4 unknowns.
TEST(AdjustmentStatistics, RedundancyNumbersSumToTheDegreesOfFreedom) {
  std::mt19937 rng(3);
  std::normal_distribution<double> n(0.0, 1.0);
  Eigen::MatrixXd a(12, 4);
  for (int i = 0; i < a.size(); ++i) a(i) = n(rng);
  Eigen::VectorXd v(12);
  for (int i = 0; i < 12; ++i) v(i) = n(rng);
  const Eigen::MatrixXd q = (a.transpose() * a).inverse();
  std::vector<ResidualRow> rows;
  for (int i = 0; i < 12; ++i)
    rows.push_back({ResidualReport::Kind::kHz, i, "r", 2.0, i < 6 ? "first" : "second"});
  const Eigen::SparseMatrix<double> sparse = a.sparseView();
  const std::vector<double> residuals(v.data(), v.data() + 12);
  const auto s = ResidualStatisticsOf(sparse, residuals, q, rows, 4.13);
  ASSERT_EQ(s.residuals.size(), 12u);
  double sum = 0.0;
  // Independent: the diagonal of the residual projector I − A Q Aᵀ.
  const Eigen::MatrixXd projector = Eigen::MatrixXd::Identity(12, 12) - a * q * a.transpose();
  for (int i = 0; i < 12; ++i) {
    const auto& r = s.residuals[i];
    EXPECT_NEAR(r.redundancy, projector(i, i), 1e-12);
    EXPECT_NEAR(r.w, v(i) / std::sqrt(projector(i, i)), 1e-9);
    EXPECT_NEAR(r.mdb, 2.0 * 4.13 / std::sqrt(projector(i, i)), 1e-9);
    EXPECT_NEAR(r.residual, 2.0 * v(i), 1e-15);
    sum += r.redundancy;
  }
  EXPECT_NEAR(sum, 12 - 4, 1e-10);
  ASSERT_EQ(s.groups.size(), 2u);
  EXPECT_EQ(s.groups[0].count + s.groups[1].count, 12);
  EXPECT_NEAR(s.groups[0].redundancy + s.groups[1].redundancy, 8.0, 1e-10);
}

TEST(AdjustmentStatistics, InnerConstraintCovarianceHasNoDatumPart) {
  // Three points, the cofactor matrix of the last two (the first held fixed).
  const Eigen::Vector3d p[3] = {{0, 0, 0}, {1000, 0, 50}, {300, 800, -20}};
  std::vector<DatumBlock> blocks;
  for (int k = 0; k < 3; ++k)
    blocks.push_back({p[k].data(), 3, DatumBlock::Kind::kPosition, "P" + std::to_string(k)});
  std::mt19937 rng(5);
  std::normal_distribution<double> n(0.0, 1.0);
  Eigen::MatrixXd m(6, 6);
  for (int i = 0; i < m.size(); ++i) m(i) = n(rng);
  Eigen::MatrixXd q = m * m.transpose() + Eigen::MatrixXd::Identity(6, 6);
  std::map<const double*, int> column_of = {{p[1].data(), 0}, {p[2].data(), 3}};
  EXPECT_EQ(InnerConstraintCovariance(blocks, {}, q, column_of), 3);
  ASSERT_EQ(q.rows(), 9);
  ASSERT_EQ(column_of.size(), 3u);
  // Inner constraints: no translation of the centroid (Σ over points of the rows is 0)
  // and the covariance is unchanged by a second transformation.
  Eigen::MatrixXd sum = Eigen::MatrixXd::Zero(3, 9);
  for (int k = 0; k < 3; ++k) sum += q.middleRows(column_of.at(p[k].data()), 3);
  EXPECT_LT(sum.norm(), 1e-9 * q.norm());
  Eigen::MatrixXd again = q;
  auto columns = column_of;
  InnerConstraintCovariance(blocks, {}, again, columns);
  EXPECT_LT((again - q).norm(), 1e-9 * q.norm());
  // Fewer than two datum points: nothing changes.
  Eigen::MatrixXd untouched = q;
  EXPECT_EQ(InnerConstraintCovariance(blocks, {"P1"}, untouched, columns), 0);
  EXPECT_EQ(untouched, q);
}

}  // namespace armsig::reduction
