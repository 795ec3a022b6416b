#include "calibration/statistics.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

namespace armsig::calibration {

// Critical values F(1 − α; d1, d2) from standard printed tables (e.g. NIST/SEMATECH
// e-Handbook 1.3.6.7.3), rounded to the tables' digits.
TEST(Statistics, FisherCriticalValuesFromTables) {
  EXPECT_NEAR(FisherFCritical(0.05, 3, 20), 3.10, 0.005);
  EXPECT_NEAR(FisherFCritical(0.01, 5, 50), 3.41, 0.005);
  EXPECT_NEAR(FisherFCritical(0.05, 1, 10), 4.9646, 5e-5);
  EXPECT_NEAR(FisherFCritical(0.05, 5, 20), 2.7109, 5e-5);
  EXPECT_NEAR(FisherFCritical(0.01, 2, 100), 4.8239, 5e-5);
}

TEST(Statistics, SurvivalAtTabulatedCriticalValuesIsAlpha) {
  EXPECT_NEAR(FisherFSurvival(4.9646, 1, 10), 0.05, 1e-4);
  EXPECT_NEAR(FisherFSurvival(2.7109, 5, 20), 0.05, 1e-4);
  EXPECT_NEAR(FisherFSurvival(4.8239, 2, 100), 0.01, 1e-4);
  EXPECT_NEAR(FisherFSurvival(3.10, 3, 20), 0.05, 1e-3);
  EXPECT_NEAR(FisherFSurvival(3.41, 5, 50), 0.01, 1e-3);
}

TEST(Statistics, SurvivalClosedFormForTwoNumeratorDegrees) {
  // d1 = 2: P(F > f) = (1 + 2 f / d2)^(−d2/2), an independent closed form.
  for (double f : {0.1, 1.0, 3.7, 12.0}) {
    EXPECT_NEAR(FisherFSurvival(f, 2, 17), std::pow(1.0 + 2.0 * f / 17.0, -8.5), 1e-13) << f;
  }
}

TEST(Statistics, SurvivalEdges) {
  EXPECT_EQ(FisherFSurvival(0.0, 3, 30), 1.0);
  EXPECT_EQ(FisherFSurvival(-1.0, 3, 30), 1.0);
  EXPECT_EQ(FisherFSurvival(std::numeric_limits<double>::infinity(), 3, 30), 0.0);
}

}  // namespace armsig::calibration
