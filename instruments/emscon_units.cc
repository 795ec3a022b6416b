// emScon units and coordinate conventions: the factors of ES_LengthUnit, ES_AngleUnit,
// ES_TemperatureUnit and ES_PressureUnit, and the spherical ⇄ Cartesian conventions
// (EMSCON.md §3). Angles through core/units.h.
#include <algorithm>
#include <cmath>

#include "core/units.h"
#include "instruments/emscon_codec.h"

namespace armsig::instruments::emscon {

// --- Units and conventions ------------------------------------------------------------

std::optional<double> MillimetresPer(int32_t unit) {
  switch (unit) {
    case length_unit::kMeter:
      return 1000.0;
    case length_unit::kMillimeter:
      return 1.0;
    case length_unit::kMicron:
      return 0.001;
    case length_unit::kFoot:
      return 304.8;
    case length_unit::kYard:
      return 914.4;
    case length_unit::kInch:
      return 25.4;
    default:
      return std::nullopt;
  }
}

std::optional<double> RadiansPer(int32_t unit) {
  switch (unit) {
    case angle_unit::kRadian:
      return 1.0;
    case angle_unit::kDegree:
      return kRadPerDeg;
    case angle_unit::kGon:
      return kRadPerGon;
    default:
      return std::nullopt;
  }
}

std::optional<double> ToCelsius(double value, int32_t unit) {
  if (unit == temperature_unit::kCelsius) return value;
  if (unit == temperature_unit::kFahrenheit) return (value - 32.0) * 5.0 / 9.0;
  return std::nullopt;
}

std::optional<double> FromCelsius(double celsius, int32_t unit) {
  if (unit == temperature_unit::kCelsius) return celsius;
  if (unit == temperature_unit::kFahrenheit) return celsius * 9.0 / 5.0 + 32.0;
  return std::nullopt;
}

namespace {
// Hectopascals per unit (conventional factors: mmHg 133.322387415 Pa, psi 6894.757 Pa,
// inH2O 249.08891 Pa, inHg 3386.38816 Pa).
std::optional<double> HectopascalsPer(int32_t unit) {
  switch (unit) {
    case pressure_unit::kMbar:
    case pressure_unit::kHPascal:
      return 1.0;
    case pressure_unit::kKPascal:
      return 10.0;
    case pressure_unit::kMmHg:
      return 1.33322387415;
    case pressure_unit::kPsi:
      return 68.94757293168;
    case pressure_unit::kInH2O:
      return 2.4908891;
    case pressure_unit::kInHg:
      return 33.8638815789;
    default:
      return std::nullopt;
  }
}
}  // namespace

std::optional<double> ToHectopascal(double value, int32_t unit) {
  const auto f = HectopascalsPer(unit);
  if (!f) return std::nullopt;
  return value * *f;
}

std::optional<double> FromHectopascal(double hpa, int32_t unit) {
  const auto f = HectopascalsPer(unit);
  if (!f) return std::nullopt;
  return hpa / *f;
}

Eigen::Vector3d PointFromSpherical(const Spherical& s) {
  const double sv = std::sin(s.v_rad);
  return s.distance_mm *
         Eigen::Vector3d(sv * std::sin(s.hz_rad), sv * std::cos(s.hz_rad), std::cos(s.v_rad));
}

Spherical SphericalFromPoint(const Eigen::Vector3d& p) {
  const double d = p.norm();
  if (!(d > 0.0)) return {};
  double hz = std::atan2(p.x(), p.y());
  if (hz < 0.0) hz += 2.0 * kPi;
  if (hz >= 2.0 * kPi) hz = 0.0;
  return {hz, std::acos(std::clamp(p.z() / d, -1.0, 1.0)), d};
}

Eigen::Vector3d PointFromScc(const SphericalCcw& s) {
  const double sv = std::sin(s.v_rad);
  return s.distance_mm *
         Eigen::Vector3d(sv * std::cos(s.hz_rad), sv * std::sin(s.hz_rad), std::cos(s.v_rad));
}

SphericalCcw SccFromPoint(const Eigen::Vector3d& p) {
  const double d = p.norm();
  if (!(d > 0.0)) return {};
  return {std::atan2(p.y(), p.x()), std::acos(std::clamp(p.z() / d, -1.0, 1.0)), d};
}

}  // namespace armsig::instruments::emscon
