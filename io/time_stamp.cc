#include "io/time_stamp.h"

#include <cctype>
#include <charconv>
#include <cstdint>

#include <fmt/format.h>

#include <string>

#include "core/text.h"
#include "io/csv.h"

namespace armsig::io {

namespace {

// What std::isspace calls white space: a time stamp is trimmed of it.
constexpr std::string_view kBlank = " \t\n\v\f\r";

// Days since 1970-01-01 of a civil date (H. Hinnant, "chrono-compatible low-level date
// algorithms", days_from_civil).
int64_t DaysFromCivil(int64_t y, unsigned m, unsigned d) {
  y -= m <= 2;
  const int64_t era = (y >= 0 ? y : y - 399) / 400;
  const unsigned yoe = static_cast<unsigned>(y - era * 400);
  const unsigned doy = (153 * (m + (m > 2 ? -3 : 9)) + 2) / 5 + d - 1;
  const unsigned doe = yoe * 365 + yoe / 4 - yoe / 100 + doy;
  return era * 146097 + static_cast<int64_t>(doe) - 719468;
}

bool ParseDigits(std::string_view s, int& value) {
  if (s.empty()) return false;
  for (const char c : s) {
    if (!std::isdigit(static_cast<unsigned char>(c))) return false;
  }
  const auto [end, ec] = std::from_chars(s.data(), s.data() + s.size(), value);
  return ec == std::errc() && end == s.data() + s.size();
}

bool LeapYear(int y) { return (y % 4 == 0 && y % 100 != 0) || y % 400 == 0; }

int DaysInMonth(int year, int month) {
  static constexpr int kDays[12] = {31, 28, 31, 30, 31, 30, 31, 31, 30, 31, 30, 31};
  return month == 2 && LeapYear(year) ? 29 : kDays[month - 1];
}

// The zone after the time: "Z", or "±hh:mm", "±hhmm", "±hh"; false for anything else.
// `*in_range`: false for an offset of 24 hours or more, or 60 minutes or more.
bool ParseZone(std::string_view rest, IsoDateTime& t, bool* in_range) {
  if (rest == "Z" || rest == "z") {
    t.zone = std::string(rest);
    return true;
  }
  if (rest.empty() || (rest.front() != '+' && rest.front() != '-')) return false;
  const int sign = rest.front() == '-' ? -1 : 1;
  const std::string_view digits = rest.substr(1);
  int oh = 0, om = 0;
  const bool parsed =
      (digits.size() == 5 && digits[2] == ':' && ParseDigits(digits.substr(0, 2), oh) &&
       ParseDigits(digits.substr(3, 2), om)) ||
      (digits.size() == 4 && ParseDigits(digits.substr(0, 2), oh) &&
       ParseDigits(digits.substr(2, 2), om)) ||
      (digits.size() == 2 && ParseDigits(digits, oh));
  if (!parsed) return false;
  t.zone = std::string(rest);
  t.offset_s = sign * (oh * 3600 + om * 60);
  *in_range = oh <= 23 && om <= 59;
  return true;
}

// The time after the date's separator: hh:mm[:ss[.f…]] and the zone.
bool ParseTimeOfDay(std::string_view rest, IsoDateTime& t, bool* zone_in_range) {
  if (rest.size() < 5 || rest[2] != ':' || !ParseDigits(rest.substr(0, 2), t.hour) ||
      !ParseDigits(rest.substr(3, 2), t.minute))
    return false;
  rest.remove_prefix(5);
  if (!rest.empty() && rest.front() == ':') {
    if (rest.size() < 3 || !ParseDigits(rest.substr(1, 2), t.second)) return false;
    rest.remove_prefix(3);
    if (!rest.empty() && rest.front() == '.') {
      size_t n = 1;
      while (n < rest.size() && std::isdigit(static_cast<unsigned char>(rest[n]))) ++n;
      if (n == 1) return false;
      const std::string digits(rest.substr(1, n - 1));
      t.fraction = std::stod("0." + digits);
      t.milliseconds = std::stoi((digits + "00").substr(0, 3));
      rest.remove_prefix(n);
    }
  }
  t.has_time = true;
  return rest.empty() || ParseZone(rest, t, zone_in_range);
}

}  // namespace

std::optional<IsoDateTime> ParseIsoDateTime(std::string_view text, std::string* why) {
  auto fail = [&](std::string reason) -> std::optional<IsoDateTime> {
    if (why) *why = std::move(reason);
    return std::nullopt;
  };
  IsoDateTime t;
  bool zone_in_range = true;
  if (text.size() < 10 || text[4] != '-' || text[7] != '-' ||
      !ParseDigits(text.substr(0, 4), t.year) || !ParseDigits(text.substr(5, 2), t.month) ||
      !ParseDigits(text.substr(8, 2), t.day) ||
      (text.size() > 10 && ((text[10] != 'T' && text[10] != ' ') ||
                            !ParseTimeOfDay(text.substr(11), t, &zone_in_range)))) {
    return fail(
        "expected an ISO 8601 date or date and time, e.g. 2026-11-01, 2026-11-01T02:30 (local "
        "time), 2026-11-01T02:30:00Z (UTC) or 2026-11-01T02:30+01:00");
  }
  if (t.month < 1 || t.month > 12) return fail(fmt::format("there is no month {:02d}", t.month));
  if (t.day < 1 || t.day > DaysInMonth(t.year, t.month)) {
    return fail(fmt::format("{:04d}-{:02d} has {} days, there is no day {:02d}", t.year, t.month,
                            DaysInMonth(t.year, t.month), t.day));
  }
  if (t.hour > 23 || t.minute > 59 || t.second > 60) {
    return fail(
        fmt::format("{:02d}:{:02d}:{:02d} is no time of day", t.hour, t.minute, t.second));
  }
  if (!zone_in_range) return fail(fmt::format("{} is no offset from UTC", t.zone));
  return t;
}

double UtcSecondsOf(const IsoDateTime& t) {
  return static_cast<double>(DaysFromCivil(t.year, static_cast<unsigned>(t.month),
                                           static_cast<unsigned>(t.day))) *
             86400.0 +
         t.hour * 3600.0 + t.minute * 60.0 + t.second + t.fraction;
}

std::optional<TimeStamp> ParseTimeStamp(std::string_view text) {
  text = Trim(text, kBlank);
  if (text.empty()) return std::nullopt;
  if (auto v = ParseNumber(text, false)) return TimeStamp{*v, false};
  if (auto v = ParseNumber(text, true)) return TimeStamp{*v, false};
  const std::optional<IsoDateTime> t = ParseIsoDateTime(text);
  if (!t || !t->has_time) return std::nullopt;
  return TimeStamp{UtcSecondsOf(*t) - t->offset_s, true};
}

}  // namespace armsig::io
