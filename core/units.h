// Angle and length units. Inside armsig everything is mm and rad; files carry
// their unit in the column or key name (docs/reference/conventions.md).
#pragma once

#include <numbers>
#include <optional>
#include <string_view>

namespace armsig {

inline constexpr double kPi = std::numbers::pi;
inline constexpr double kRadPerDeg = kPi / 180.0;
inline constexpr double kRadPerGon = kPi / 200.0;
inline constexpr double kRadPerArcsec = kPi / (180.0 * 3600.0);

enum class AngleUnit { kRad, kDeg, kGon };

constexpr double ToRad(double value, AngleUnit unit) {
  switch (unit) {
    case AngleUnit::kDeg:
      return value * kRadPerDeg;
    case AngleUnit::kGon:
      return value * kRadPerGon;
    case AngleUnit::kRad:
      break;
  }
  return value;
}

constexpr double FromRad(double rad, AngleUnit unit) {
  switch (unit) {
    case AngleUnit::kDeg:
      return rad / kRadPerDeg;
    case AngleUnit::kGon:
      return rad / kRadPerGon;
    case AngleUnit::kRad:
      break;
  }
  return rad;
}

// "_deg" / "_gon" / "_rad" at the end of a column or key name; nullopt otherwise.
std::optional<AngleUnit> AngleUnitFromSuffix(std::string_view name);
// The name without its unit suffix ("q3_deg" -> "q3"); unchanged if it has none.
std::string_view StripUnitSuffix(std::string_view name);
std::string_view AngleUnitSuffix(AngleUnit unit);

// Wraps an angle to [0, 2π).
double WrapTwoPi(double rad);
// Wraps an angle to (−π, π].
double WrapPi(double rad);

}  // namespace armsig
