#include "io/time_stamp.h"

#include <cctype>
#include <charconv>
#include <cstdint>

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
  const auto [end, ec] = std::from_chars(s.data(), s.data() + s.size(), value);
  return ec == std::errc() && end == s.data() + s.size();
}

// The seconds after "hh:mm": ":ss" or ":ss.fff", taken off the front of `*rest`; 0 when
// none are written, nullopt when what follows the ':' is no number of at least two digits.
std::optional<double> TakeSeconds(std::string_view* rest) {
  if (rest->empty() || rest->front() != ':') return 0.0;
  rest->remove_prefix(1);
  size_t n = 0;
  while (n < rest->size() &&
         (std::isdigit(static_cast<unsigned char>((*rest)[n])) || (*rest)[n] == '.'))
    ++n;
  const auto s = ParseNumber(rest->substr(0, n), false);
  if (!s || n < 2) return std::nullopt;
  rest->remove_prefix(n);
  return s;
}

// The zone written after the time, as seconds to subtract for UTC: nothing (the time as
// written), "Z", or "±hh:mm", "±hhmm", "±hh"; nullopt for anything else.
std::optional<double> ZoneOffsetSeconds(std::string_view rest) {
  if (rest.empty() || rest == "Z" || rest == "z") return 0.0;
  if (rest.front() != '+' && rest.front() != '-') return std::nullopt;
  const int sign = rest.front() == '-' ? -1 : 1;
  rest.remove_prefix(1);
  int oh = 0, om = 0;
  const bool parsed = (rest.size() == 5 && rest[2] == ':' && ParseDigits(rest.substr(0, 2), oh) &&
                       ParseDigits(rest.substr(3, 2), om)) ||
                      (rest.size() == 4 && ParseDigits(rest.substr(0, 2), oh) &&
                       ParseDigits(rest.substr(2, 2), om)) ||
                      (rest.size() == 2 && ParseDigits(rest, oh));
  if (!parsed || oh > 23 || om > 59) return std::nullopt;
  return sign * (oh * 3600.0 + om * 60.0);
}

}  // namespace

std::optional<TimeStamp> ParseTimeStamp(std::string_view text) {
  text = Trim(text, kBlank);
  if (text.empty()) return std::nullopt;
  if (auto v = ParseNumber(text, false)) return TimeStamp{*v, false};
  if (auto v = ParseNumber(text, true)) return TimeStamp{*v, false};
  // YYYY-MM-DD[T ]hh:mm[:ss[.fff]][Z|±hh[:mm]]
  if (text.size() < 16 || text[4] != '-' || text[7] != '-' || (text[10] != 'T' && text[10] != ' '))
    return std::nullopt;
  int year = 0, month = 0, day = 0, hour = 0, minute = 0;
  if (!ParseDigits(text.substr(0, 4), year) || !ParseDigits(text.substr(5, 2), month) ||
      !ParseDigits(text.substr(8, 2), day) || !ParseDigits(text.substr(11, 2), hour) ||
      text[13] != ':' || !ParseDigits(text.substr(14, 2), minute))
    return std::nullopt;
  std::string_view rest = text.substr(16);
  const std::optional<double> second = TakeSeconds(&rest);
  if (!second) return std::nullopt;
  const std::optional<double> offset_s = ZoneOffsetSeconds(rest);
  if (!offset_s) return std::nullopt;
  if (month < 1 || month > 12 || day < 1 || day > 31 || hour > 23 || minute > 59 ||
      !(*second >= 0.0 && *second < 61.0))
    return std::nullopt;
  const double seconds = static_cast<double>(DaysFromCivil(year, static_cast<unsigned>(month),
                                                           static_cast<unsigned>(day))) *
                             86400.0 +
                         hour * 3600.0 + minute * 60.0 + *second - *offset_s;
  return TimeStamp{seconds, true};
}

}  // namespace armsig::io
