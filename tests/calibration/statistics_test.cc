#include "calibration/statistics.h"

#include <gtest/gtest.h>

#include <cmath>

namespace armsig::calibration {

TEST(Statistics, IncompleteBetaKnownValues) {
  EXPECT_NEAR(RegularizedIncompleteBeta(2, 2, 0.5), 0.5, 1e-14);
  // I_x(1, 1) = x; I_x(a, 1) = x^a.
  EXPECT_NEAR(RegularizedIncompleteBeta(1, 1, 0.3), 0.3, 1e-14);
  EXPECT_NEAR(RegularizedIncompleteBeta(3.5, 1, 0.7), std::pow(0.7, 3.5), 1e-13);
  // Symmetry I_x(a, b) = 1 − I_{1−x}(b, a).
  EXPECT_NEAR(RegularizedIncompleteBeta(4.2, 7.1, 0.33),
              1.0 - RegularizedIncompleteBeta(7.1, 4.2, 0.67), 1e-13);
}

TEST(Statistics, FisherCriticalValuesFromTables) {
  // Upper 5 % points of F from standard tables.
  EXPECT_NEAR(FisherFSurvival(4.9646, 1, 10), 0.05, 1e-4);
  EXPECT_NEAR(FisherFSurvival(2.7109, 5, 20), 0.05, 1e-4);
  // Upper 1 % point of F(2, 100) = 4.8239.
  EXPECT_NEAR(FisherFSurvival(4.8239, 2, 100), 0.01, 1e-4);
  EXPECT_EQ(FisherFSurvival(0.0, 3, 30), 1.0);
}

}  // namespace armsig::calibration
