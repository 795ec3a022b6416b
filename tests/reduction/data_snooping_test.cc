// The blunder policy (reduction/data_snooping.h) on linear models whose residuals and test
// correlations are computed here from their design matrix, independently of the adjustments
// that use the policy.
#include "reduction/data_snooping.h"

#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <cmath>
#include <random>

namespace armsig::reduction {
namespace {

// A whitened linear model y = A x + e: residuals v = A x̂ − y, their cofactor
// Qvv = I − A (AᵀA)⁻¹ Aᵀ and the standardised residuals w_i = v_i / √Qvv_ii.
struct LinearModel {
  LinearModel(Eigen::MatrixXd a_in, Eigen::VectorXd y_in) : a(std::move(a_in)), y(std::move(y_in)) {
    const Eigen::MatrixXd q = (a.transpose() * a).inverse();
    v = a * (q * a.transpose() * y) - y;
    qvv = Eigen::MatrixXd::Identity(a.rows(), a.rows()) - a * q * a.transpose();
    w = v.array() / qvv.diagonal().array().sqrt();
  }
  int dof() const { return static_cast<int>(a.rows() - a.cols()); }
  double Correlation(int i, int j) const {
    return qvv(i, j) / std::sqrt(qvv(i, i) * qvv(j, j));
  }
  std::vector<SnoopCandidate> Candidates() const {
    std::vector<SnoopCandidate> c(a.rows());
    for (int i = 0; i < a.rows(); ++i) c[i] = {w(i), qvv(i, i), i, 1, false};
    return c;
  }
  SnoopDecision Decide(const DataSnooping& policy = {}) const {
    const auto candidates = Candidates();
    return DecideRejection(candidates, dof(), policy, policy.Levels(a.rows()),
                           [this](int i, int j) { return Correlation(i, j); });
  }
  LinearModel Without(int row) const {
    Eigen::MatrixXd a2(a.rows() - 1, a.cols());
    Eigen::VectorXd y2(a.rows() - 1);
    for (int i = 0, k = 0; i < a.rows(); ++i) {
      if (i == row) continue;
      a2.row(k) = a.row(i);
      y2(k++) = y(i);
    }
    return LinearModel(a2, y2);
  }

  Eigen::MatrixXd a;
  Eigen::VectorXd y, v, w;
  Eigen::MatrixXd qvv;
};

// Unknowns x1, x2: rows 0..count-1 observe x1 with weights `x1_rows`, then `x2_rows` rows
// observe x2 (whitened, σ = 1), noise-free.
LinearModel TwoGroups(const std::vector<double>& x1_rows, int x2_rows) {
  const int m = static_cast<int>(x1_rows.size()) + x2_rows;
  Eigen::MatrixXd a = Eigen::MatrixXd::Zero(m, 2);
  for (size_t i = 0; i < x1_rows.size(); ++i) a(i, 0) = x1_rows[i];
  for (int i = 0; i < x2_rows; ++i) a(x1_rows.size() + i, 1) = 1.0;
  return LinearModel(a, Eigen::VectorXd::Zero(m));
}

LinearModel WithBlunders(const LinearModel& model, const std::vector<std::pair<int, double>>& e) {
  Eigen::VectorXd y = model.y;
  for (const auto& [row, size] : e) y(row) += size;
  return LinearModel(model.a, y);
}

}  // namespace

// α is the adjustment's: n tests at α0 = 1 − (1 − α)^(1/n) each (Šidák), k the two-sided
// normal quantile of α0, δ0 = k + Φ⁻¹(β0). Checked through erfc, not the quantile function.
TEST(DataSnooping, LevelsKeepTheAdjustmentsSignificanceLevel) {
  const DataSnooping policy;
  for (int n : {1, 6, 192, 359, 2000}) {
    const SnoopLevels l = policy.Levels(n);
    EXPECT_EQ(l.tests, n);
    EXPECT_NEAR(1.0 - std::pow(1.0 - l.alpha0, n), 1e-3, 1e-12) << n;
    EXPECT_NEAR(std::erfc(l.critical_w / std::sqrt(2.0)) / l.alpha0, 1.0, 1e-9) << n;
    EXPECT_NEAR(l.delta0 - l.critical_w, 0.8416212335729143, 1e-12) << n;  // Φ⁻¹(0.80)
    EXPECT_NEAR(std::erfc(l.pair_critical_w / std::sqrt(2.0)), 1e-3, 1e-15) << n;
  }
  // Baarda's values for one test: k = 3.29, δ0 = 4.13; K06's 359 tests: 4.69.
  EXPECT_NEAR(policy.Levels(1).critical_w, 3.2905, 1e-4);
  EXPECT_NEAR(policy.Levels(1).delta0, 4.1321, 1e-4);
  EXPECT_NEAR(policy.Levels(359).critical_w, 4.686, 1e-3);
  // A critical value given instead: the same for every number of tests.
  DataSnooping fixed;
  fixed.critical_w = 3.29;
  EXPECT_EQ(fixed.Levels(100).critical_w, 3.29);
  EXPECT_NEAR(fixed.Levels(100).alpha0, std::erfc(3.29 / std::sqrt(2.0)), 1e-15);
}

// The twin rule rests on w_i|j = (w_i − ρ_ij w_j) / √(1 − ρ_ij²) being the w of i once j is
// removed: checked against refitting without j.
TEST(DataSnooping, TheCorrelationPredictsTheTestOnceAnotherIsRemoved) {
  std::mt19937 rng(5);
  std::normal_distribution<double> n(0.0, 1.0);
  Eigen::MatrixXd a(12, 3);
  Eigen::VectorXd y(12);
  for (int i = 0; i < 12; ++i) {
    for (int j = 0; j < 3; ++j) a(i, j) = n(rng);
    y(i) = n(rng);
  }
  y(4) += 8.0;
  const LinearModel model(a, y);
  for (int i = 0; i < 12; ++i) {
    for (int j = 0; j < 12; ++j) {
      if (i == j) continue;
      const double rho = model.Correlation(i, j);
      const double predicted = (model.w(i) - rho * model.w(j)) / std::sqrt(1.0 - rho * rho);
      const LinearModel without = model.Without(j);
      EXPECT_NEAR(without.w(i < j ? i : i - 1), predicted, 1e-9) << i << " without " << j;
    }
  }
}

TEST(DataSnooping, IndependentBlundersAreRemovedOneAfterTheOther) {
  // x1 and x2 each read 8 times: a blunder in each group; the groups' tests are independent.
  const LinearModel model = WithBlunders(TwoGroups(std::vector<double>(8, 1.0), 8), {{2, 12.0}, {11, -9.0}});
  const SnoopDecision first = model.Decide();
  ASSERT_EQ(first.remove, std::vector<int>{2});
  EXPECT_TRUE(first.undecided.empty());
  const LinearModel rest = model.Without(2);
  const SnoopDecision second = rest.Decide();
  ASSERT_EQ(second.remove, std::vector<int>{10});  // row 11 of the full model
  EXPECT_TRUE(rest.Without(10).Decide().remove.empty());
}

// Equal |w| in a pair: x1 read twice, nothing else checks it. One of the two is wrong and
// the data cannot say which; removing both would leave x1 undetermined: said, not removed.
TEST(DataSnooping, EqualWInAPairIsSaidNotGuessed) {
  const LinearModel model = WithBlunders(TwoGroups({1.0, 1.0}, 8), {{0, 10.0}});
  EXPECT_NEAR(std::abs(model.w(0)), std::abs(model.w(1)), 1e-12);
  const SnoopDecision d = model.Decide();
  EXPECT_TRUE(d.remove.empty());
  ASSERT_FALSE(d.undecided.empty());
  EXPECT_EQ(d.undecided[0].why, Undecided::kBarelyChecked);
  EXPECT_EQ(d.undecided[0].twins, std::vector<int>{1});
}

// Nearly the same test (ρ = −0.917), but a third, weak reading of x1 keeps it determined
// without both: the pair goes together, named as twins.
TEST(DataSnooping, TwinsThatCanGoTogetherAreRemovedTogether) {
  const LinearModel model = WithBlunders(TwoGroups({1.0, 1.0, 0.3}, 8), {{0, 10.0}});
  EXPECT_NEAR(model.Correlation(0, 1), -1.0 / 2.09 / (1.0 - 1.0 / 2.09), 1e-12);
  const SnoopDecision d = model.Decide();
  ASSERT_EQ(d.remove.size(), 2u);
  EXPECT_EQ(d.remove[0], 0);
  EXPECT_EQ(d.remove[1], 1);
}

TEST(DataSnooping, AnObservationTheOthersBarelyCheckIsSaidNotRemoved) {
  // x1 read once precisely and once 100 000 times less precisely: the precise one has
  // r ≈ 1e-10, and its blunder hardly shows; a w beyond k is not enough to remove it.
  const LinearModel model = WithBlunders(TwoGroups({1.0, 1e-5}, 6), {{0, 2e6}});
  ASSERT_LT(model.qvv(0, 0), 1e-3);
  ASSERT_GT(std::abs(model.w(0)), DataSnooping{}.Levels(8).critical_w);
  const SnoopDecision d = model.Decide();
  EXPECT_TRUE(d.remove.empty());
  ASSERT_FALSE(d.undecided.empty());
  EXPECT_EQ(d.undecided[0].candidate, 0);
  EXPECT_EQ(d.undecided[0].why, Undecided::kBarelyChecked);
}

TEST(DataSnooping, NoRemovalLeavesTheAdjustmentWithoutRedundancy) {
  // Two unknowns, three readings: one degree of freedom, nothing can go.
  Eigen::MatrixXd a(3, 2);
  a << 1, 0, 0, 1, 1, 1;
  Eigen::VectorXd y(3);
  y << 0, 0, 30;
  const LinearModel model(a, y);
  const SnoopDecision d = model.Decide();
  EXPECT_TRUE(d.remove.empty());
  ASSERT_FALSE(d.undecided.empty());
  EXPECT_EQ(d.undecided[0].why, Undecided::kNoRedundancyLeft);
}

TEST(DataSnooping, KeptObservationsAreTestedButNeverRemoved) {
  const LinearModel model = WithBlunders(TwoGroups(std::vector<double>(8, 1.0), 8), {{2, 12.0}, {11, -9.0}});
  auto candidates = model.Candidates();
  candidates[2].kept = true;
  const DataSnooping policy;
  const SnoopDecision d =
      DecideRejection(candidates, model.dof(), policy, policy.Levels(16),
                      [&](int i, int j) { return model.Correlation(i, j); });
  ASSERT_EQ(d.remove, std::vector<int>{11});
}

TEST(DataSnooping, RejectionOffOnlyReportsTheWorst) {
  const LinearModel model = WithBlunders(TwoGroups(std::vector<double>(8, 1.0), 8), {{2, 12.0}});
  DataSnooping policy;
  policy.reject = false;
  const SnoopDecision d = model.Decide(policy);
  EXPECT_TRUE(d.remove.empty());
  ASSERT_EQ(d.undecided.size(), 1u);
  EXPECT_EQ(d.undecided[0].candidate, 2);
  EXPECT_EQ(d.undecided[0].why, Undecided::kRejectionOff);
}

// A failing test that removing an undecided one would clear may be its echo: it stays too.
TEST(DataSnooping, AnEchoOfAnUndecidedOneStays) {
  const std::vector<SnoopCandidate> candidates = {
      {10.0, 5e-4, 0, 1, false},  // fails, barely checked: undecided
      {6.0, 0.5, 1, 1, false},    // fails; 0 would explain it: (6 − 0.7·10)/√(1 − 0.49) = −1.4
      {0.5, 0.9, 2, 1, false}};
  auto rho = [](int i, int j) { return (i == 0 && j == 1) || (i == 1 && j == 0) ? 0.7 : 0.0; };
  const DataSnooping policy;
  const SnoopDecision d = DecideRejection(candidates, 20, policy, policy.Levels(1), rho);
  EXPECT_TRUE(d.remove.empty());
  ASSERT_EQ(d.undecided.size(), 2u);
  EXPECT_EQ(d.undecided[0].why, Undecided::kBarelyChecked);
  EXPECT_EQ(d.undecided[1].candidate, 1);
  EXPECT_EQ(d.undecided[1].why, Undecided::kEcho);
  EXPECT_EQ(d.undecided[1].twins, std::vector<int>{0});
}

}  // namespace armsig::reduction
