// Time stamps as tracker exports and robot joint logs write them, for joining a point with
// the joint reading taken at its time (io/point_joint_join.h).
#pragma once

#include <optional>
#include <string_view>

namespace armsig::io {

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
