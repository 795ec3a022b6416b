// Time stamps of tracker exports and joint logs: ISO 8601 date-times against an independent
// computation of the same instants (timegm), plain seconds, and what is neither.
#include "io/time_stamp.h"

#include <gtest/gtest.h>

#include <cmath>
#include <ctime>

namespace armsig::io {

TEST(TimeStamp, IsAnIsoDateTimeOrSeconds) {
  // An independent computation of the same instants: timegm of the broken-down UTC time.
  std::tm tm{};
  tm.tm_year = 2024 - 1900;
  tm.tm_mon = 2;
  tm.tm_mday = 5;
  tm.tm_hour = 9;
  tm.tm_min = 15;
  tm.tm_sec = 30;
  const double utc = static_cast<double>(::timegm(&tm));
  auto seconds = [](const char* text) {
    const auto t = ParseTimeStamp(text);
    EXPECT_TRUE(t.has_value()) << text;
    return t ? t->seconds : NAN;
  };
  EXPECT_DOUBLE_EQ(seconds("2024-03-05T09:15:30Z"), utc);
  EXPECT_DOUBLE_EQ(seconds("2024-03-05 09:15:30.25"), utc + 0.25);
  EXPECT_DOUBLE_EQ(seconds("2024-03-05T10:15:30+01:00"), utc);
  EXPECT_DOUBLE_EQ(seconds("2024-03-05T04:45:30-0430"), utc);
  EXPECT_DOUBLE_EQ(seconds("1970-01-01T00:00Z"), 0.0);
  EXPECT_TRUE(ParseTimeStamp("2024-03-05T09:15:30Z")->absolute);
  EXPECT_FALSE(ParseTimeStamp("1234.5")->absolute);
  EXPECT_DOUBLE_EQ(ParseTimeStamp("1234,5")->seconds, 1234.5);
  for (const char* bad : {"", "2024-13-05T09:15:30", "2024-03-05", "2024-03-05T25:00", "noon",
                          "2024-03-05T09:15:30+25:00", "2024-03-05T09:15:30 UTC"}) {
    EXPECT_FALSE(ParseTimeStamp(bad).has_value()) << bad;
  }
}

}  // namespace armsig::io
