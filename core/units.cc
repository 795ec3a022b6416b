#include "core/units.h"

#include <cmath>

namespace armsig {

std::optional<AngleUnit> AngleUnitFromSuffix(std::string_view name) {
  if (name.ends_with("_deg")) return AngleUnit::kDeg;
  if (name.ends_with("_gon")) return AngleUnit::kGon;
  if (name.ends_with("_rad")) return AngleUnit::kRad;
  return std::nullopt;
}

std::string_view StripUnitSuffix(std::string_view name) {
  for (std::string_view suffix : {"_deg", "_gon", "_rad", "_mm", "_arcsec"}) {
    if (name.ends_with(suffix)) return name.substr(0, name.size() - suffix.size());
  }
  return name;
}

std::string_view AngleUnitSuffix(AngleUnit unit) {
  switch (unit) {
    case AngleUnit::kDeg:
      return "_deg";
    case AngleUnit::kGon:
      return "_gon";
    case AngleUnit::kRad:
      break;
  }
  return "_rad";
}

double WrapTwoPi(double rad) {
  double wrapped = std::fmod(rad, 2.0 * kPi);
  if (wrapped < 0.0) wrapped += 2.0 * kPi;
  return wrapped;
}

double WrapPi(double rad) {
  double wrapped = WrapTwoPi(rad);
  if (wrapped > kPi) wrapped -= 2.0 * kPi;
  return wrapped;
}

}  // namespace armsig
