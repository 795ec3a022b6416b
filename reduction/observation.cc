#include "reduction/observation.h"

#include <cmath>

#include "core/units.h"

namespace armsig::reduction {

AngleReading ToFaceOne(const AngleReading& reading) {
  if (reading.face != 2) return reading;
  return {WrapTwoPi(reading.hz_rad - kPi), 2.0 * kPi - reading.v_rad, 1};
}

Eigen::Vector3d DirectionInStation(const AngleReading& reading) {
  const AngleReading r = ToFaceOne(reading);
  const double sv = std::sin(r.v_rad);
  return {sv * std::sin(r.hz_rad), sv * std::cos(r.hz_rad), std::cos(r.v_rad)};
}

AngleReading ReadingOf(const Eigen::Vector3d& d) {
  const Eigen::Vector2d hz_v = HzVOf<double>(d);
  return {WrapTwoPi(hz_v(0)), hz_v(1), 1};
}

Eigen::Matrix3d LevelledRotation(double azimuth_rad) {
  return Eigen::AngleAxisd(-azimuth_rad, Eigen::Vector3d::UnitZ()).toRotationMatrix();
}

}  // namespace armsig::reduction
