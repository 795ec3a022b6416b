// Time stamps as tracker exports and robot joint logs write them, for joining a point with
// the joint reading taken at its time (io/point_joint_join.h).
#pragma once

#include <optional>
#include <string>
#include <string_view>

namespace armsig::io {

// An ISO 8601 calendar date, or date and time, as written:
// YYYY-MM-DD[(T| )hh:mm[:ss[.f…]][Z|±hh[[:]mm]]]. Each field is checked (the month, the
// month's days, the time of day, the zone's offset); nothing around it is trimmed. The one
// parser of dates in armsig: time stamps in files (ParseTimeStamp) and dates typed as
// options (recalibrate --since, which reads a time without a zone as local time).
struct IsoDateTime {
  int year = 0, month = 0, day = 0;
  bool has_time = false;
  int hour = 0, minute = 0, second = 0;  // second 60: a leap second
  double fraction = 0.0;                 // of the second
  int milliseconds = 0;                  // the fraction's first three digits
  std::string zone;                      // as written: "Z", "+01:00", "-0130"; "" when none
  int offset_s = 0;                      // the zone's offset east of UTC
};
// The date or date-time `text` names; nullopt when none, with why in `*why` when given
// ("there is no month 13", "2026-02 has 28 days, there is no day 30", …).
std::optional<IsoDateTime> ParseIsoDateTime(std::string_view text, std::string* why = nullptr);

// Seconds since 1970-01-01T00:00:00Z of a date and time of day read as UTC (the zone and
// its offset not applied).
double UtcSecondsOf(const IsoDateTime& t);

// A time stamp as written: an ISO 8601 date-time ("2024-03-05T10:15:30.25", a space for the
// T, optional Z or ±hh:mm) is absolute (seconds since 1970-01-01 UTC; no zone = as written);
// a plain number is seconds on the writer's own clock. Only stamps of one kind compare.
struct TimeStamp {
  double seconds = 0.0;
  bool absolute = false;
};
// nullopt for text that is neither (a date without a time, a month 13, a zone name).
std::optional<TimeStamp> ParseTimeStamp(std::string_view text);

}  // namespace armsig::io
