#include "core/units.h"

#include <gtest/gtest.h>

#include "core/error.h"

namespace armsig {

TEST(Units, ConvertsEveryAngleUnitToRadians) {
  EXPECT_DOUBLE_EQ(ToRad(180.0, AngleUnit::kDeg), kPi);
  EXPECT_DOUBLE_EQ(ToRad(200.0, AngleUnit::kGon), kPi);
  EXPECT_DOUBLE_EQ(ToRad(1.25, AngleUnit::kRad), 1.25);
  EXPECT_NEAR(FromRad(ToRad(123.4567, AngleUnit::kGon), AngleUnit::kGon), 123.4567, 1e-12);
  EXPECT_NEAR(3600.0 * kRadPerArcsec, kRadPerDeg, 1e-18);
}

TEST(Units, ReadsUnitFromColumnSuffix) {
  EXPECT_EQ(AngleUnitFromSuffix("q3_deg"), AngleUnit::kDeg);
  EXPECT_EQ(AngleUnitFromSuffix("hz_gon"), AngleUnit::kGon);
  EXPECT_EQ(AngleUnitFromSuffix("azimuth_rad"), AngleUnit::kRad);
  EXPECT_FALSE(AngleUnitFromSuffix("x_mm").has_value());
  EXPECT_EQ(StripUnitSuffix("q3_deg"), "q3");
  EXPECT_EQ(StripUnitSuffix("x_mm"), "x");
}

TEST(Units, WrapsAngles) {
  EXPECT_NEAR(WrapTwoPi(-0.5), 2 * kPi - 0.5, 1e-15);
  EXPECT_NEAR(WrapPi(1.5 * kPi), -0.5 * kPi, 1e-15);
}

TEST(InputError, NamesFileLineAndColumn) {
  InputError e({"poses.csv", 7, 3, "q2_deg"}, "expected a finite number, got 'abc'");
  EXPECT_STREQ(e.what(), "poses.csv:7:3 (q2_deg): expected a finite number, got 'abc'");
}

}  // namespace armsig
