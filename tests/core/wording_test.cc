// Counts, p-values, uncertain numbers and times as a technician reads them (core/wording.h).
#include "core/wording.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <random>

namespace armsig {
namespace {

TEST(Wording, CountsTakeTheSingularOnlyForOne) {
  EXPECT_EQ(Count(1, "ray"), "1 ray");
  EXPECT_EQ(Count(0, "ray"), "0 rays");
  EXPECT_EQ(Count(3, "station"), "3 stations");
  EXPECT_EQ(Count(1, "degree of freedom", "degrees of freedom"), "1 degree of freedom");
  EXPECT_EQ(Count(25, "degree of freedom", "degrees of freedom"), "25 degrees of freedom");
}

TEST(Wording, PValuesAreBoundedAtTheEndsAndTwoDigitsBetween) {
  EXPECT_EQ(PValueText(1.0), "p > 0.99");
  EXPECT_EQ(PValueText(0.995), "p > 0.99");
  EXPECT_EQ(PValueText(0.99), "p = 0.99");
  EXPECT_EQ(PValueText(0.5), "p = 0.50");
  EXPECT_EQ(PValueText(0.0342), "p = 0.034");
  EXPECT_EQ(PValueText(0.001), "p = 0.0010");
  EXPECT_EQ(PValueText(0.000999), "p < 0.001");
  EXPECT_EQ(PValueText(0.0), "p < 0.001");
  EXPECT_EQ(PValueText(NAN), "p = —");
}

// Every value printed with N significant digits reads back within half a unit of its last
// digit, and has exactly N significant digits (leading zeros not counted) when it has
// decimals: checked on random values over sixteen decades.
TEST(Wording, SignificantDigitsReadBackWithinHalfAUnitOfTheLastDigit) {
  EXPECT_EQ(Significant(0.000423, 2), "0.00042");
  EXPECT_EQ(Significant(-0.000423, 2), "-0.00042");
  EXPECT_EQ(Significant(14.67, 2), "15");
  EXPECT_EQ(Significant(0.000996, 2), "0.0010");
  EXPECT_EQ(Significant(0.0, 2), "0");
  EXPECT_EQ(Significant(-0.0, 2), "0");
  EXPECT_EQ(Significant(123456.0, 2), "123456");  // never an exponent in the usual range
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> exponent(-8.0, 8.0), sign(-1.0, 1.0);
  for (int k = 0; k < 2000; ++k) {
    const double value = std::copysign(std::pow(10.0, exponent(rng)), sign(rng));
    for (int digits : {1, 2, 3}) {
      const std::string text = Significant(value, digits);
      ASSERT_EQ(text.find('e'), std::string::npos) << value;
      const double back = std::strtod(text.c_str(), nullptr);
      const size_t point = text.find('.');
      const int decimals =
          point == std::string::npos ? 0 : static_cast<int>(text.size() - point - 1);
      EXPECT_LE(std::abs(back - value), 0.5 * std::pow(10.0, -decimals) * (1 + 1e-9))
          << value << " " << text;
      if (decimals > 0) {  // (an integer's trailing zeros are not all significant)
        const size_t first = text.find_first_not_of("-0.");
        int significant = 0;
        for (size_t i = first; i < text.size(); ++i) significant += text[i] != '.';
        EXPECT_EQ(significant, digits) << value << " " << text;
      }
    }
  }
}

TEST(Wording, DecimalsForSigmaShowTwoDigitsOfTheSigma) {
  EXPECT_EQ(DecimalsForSigma(0.00042), 5);
  EXPECT_EQ(DecimalsForSigma(0.018), 3);
  EXPECT_EQ(DecimalsForSigma(0.72), 2);
  EXPECT_EQ(DecimalsForSigma(14.0), 0);
  EXPECT_EQ(DecimalsForSigma(0.0996), 2);  // rounds to 0.10: two digits are 0.10
  EXPECT_EQ(DecimalsForSigma(14.0, 3), 3);
  EXPECT_EQ(DecimalsForSigma(0.0, 3), 3);
  EXPECT_EQ(DecimalsForSigma(NAN, 1), 1);
}

TEST(Wording, TimesKeepTheirZoneToTheSecond) {
  EXPECT_EQ(TimeToTheSecond("2026-11-27T12:44:19.424Z"), "2026-11-27T12:44:19Z");
  EXPECT_EQ(TimeToTheSecond("2026-11-27T12:44:19Z"), "2026-11-27T12:44:19Z");
  EXPECT_EQ(TimeToTheSecond("2026-11-27T12:44:19.5+02:00"), "2026-11-27T12:44:19+02:00");
  EXPECT_EQ(TimeToTheSecond("2026-11-27 12:44:19-0130"), "2026-11-27 12:44:19-0130");
  EXPECT_EQ(TimeToTheSecond("2026-11-27T12:44:19"), "2026-11-27T12:44:19");
  EXPECT_EQ(TimeToTheSecond("yesterday"), "yesterday");
  EXPECT_EQ(TimeToTheSecond("2026-11-27T12:44:19 and more"), "2026-11-27T12:44:19 and more");
}

}  // namespace
}  // namespace armsig
