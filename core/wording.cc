#include "core/wording.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>

namespace armsig {

std::string Count(int64_t n, std::string_view singular, std::string_view plural) {
  std::string out = std::to_string(n) + " ";
  if (n == 1 || n == -1) return out.append(singular);
  if (plural.empty()) return out.append(singular).append("s");
  return out.append(plural);
}

namespace {

// The decimal exponent of `value` once rounded to `digits` significant digits (0.000996
// to two digits is 1.0e-03: exponent −3).
int RoundedExponent(double value, int digits) {
  char text[64];
  std::snprintf(text, sizeof text, "%.*e", std::max(digits - 1, 0), value);
  const char* e = std::strchr(text, 'e');
  return e ? std::atoi(e + 1) : 0;
}

}  // namespace

std::string Significant(double value, int digits) {
  digits = std::clamp(digits, 1, 17);
  char text[64];
  if (!std::isfinite(value)) {
    std::snprintf(text, sizeof text, "%g", value);
    return text;
  }
  if (value == 0.0) return "0";
  const double magnitude = std::abs(value);
  if (magnitude >= 1e9 || magnitude < 1e-9) {
    std::snprintf(text, sizeof text, "%.*g", digits, value);
    return text;
  }
  const int decimals = std::max(0, digits - 1 - RoundedExponent(value, digits));
  std::snprintf(text, sizeof text, "%.*f", decimals, value);
  return text;
}

int DecimalsForSigma(double sigma, int min_decimals) {
  if (!std::isfinite(sigma) || !(std::abs(sigma) > 0.0)) return std::clamp(min_decimals, 0, 9);
  return std::clamp(std::max(min_decimals, 1 - RoundedExponent(std::abs(sigma), 2)), 0, 9);
}

std::string PValueText(double p) {
  if (!std::isfinite(p)) return "p = —";
  if (p < 0.001) return "p < 0.001";
  if (p > 0.99) return "p > 0.99";
  return "p = " + Significant(p, 2);
}

std::string TimeToTheSecond(std::string_view iso) {
  // YYYY-MM-DDTHH:MM:SS, then an optional fraction, then the zone (Z or ±hh[:]mm) or none.
  auto digit = [&](size_t i) {
    return i < iso.size() && std::isdigit(static_cast<unsigned char>(iso[i]));
  };
  static constexpr const char* kShape = "dddd-dd-ddTdd:dd:dd";
  if (iso.size() < 19) return std::string(iso);
  for (size_t i = 0; i < 19; ++i) {
    const char want = kShape[i];
    const bool ok = want == 'd'   ? digit(i)
                    : want == 'T' ? (iso[i] == 'T' || iso[i] == ' ')
                                  : iso[i] == want;
    if (!ok) return std::string(iso);
  }
  size_t at = 19;
  if (at < iso.size() && iso[at] == '.') {
    ++at;
    while (digit(at)) ++at;
  }
  const std::string_view zone = iso.substr(at);
  const bool utc = zone == "Z";
  const bool offset = (zone.size() == 6 && (zone[0] == '+' || zone[0] == '-') && digit(at + 1) &&
                       digit(at + 2) && zone[3] == ':' && digit(at + 4) && digit(at + 5)) ||
                      (zone.size() == 5 && (zone[0] == '+' || zone[0] == '-') && digit(at + 1) &&
                       digit(at + 2) && digit(at + 3) && digit(at + 4));
  if (!zone.empty() && !utc && !offset) return std::string(iso);
  return std::string(iso.substr(0, 19)).append(zone);
}

}  // namespace armsig
