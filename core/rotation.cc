#include "core/rotation.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>

namespace armsig {

Eigen::Matrix3d RotationFromRxRyRz(const Eigen::Vector3d& a) {
  return (Eigen::AngleAxisd(a.x(), Eigen::Vector3d::UnitX()) *
          Eigen::AngleAxisd(a.y(), Eigen::Vector3d::UnitY()) *
          Eigen::AngleAxisd(a.z(), Eigen::Vector3d::UnitZ()))
      .toRotationMatrix();
}

Eigen::Vector3d RxRyRzFromRotation(const Eigen::Matrix3d& r) {
  // R = Rx(a)·Ry(b)·Rz(c): R02 = sin b, R12 = −sin a cos b, R22 = cos a cos b,
  // R01 = −cos b sin c, R00 = cos b cos c.
  const double sin_b = std::clamp(r(0, 2), -1.0, 1.0);
  const double cos_b = std::hypot(r(1, 2), r(2, 2));
  if (cos_b > 1e-12) {
    return {std::atan2(-r(1, 2), r(2, 2)), std::atan2(sin_b, cos_b), std::atan2(-r(0, 1), r(0, 0))};
  }
  // Gimbal lock, c = 0: R = Rx(a)·Ry(±π/2), R21 = sin a, R11 = cos a.
  return {std::atan2(r(2, 1), r(1, 1)), std::atan2(sin_b, cos_b), 0.0};
}

Eigen::Matrix3d BodyRatesOfRxRyRz(const Eigen::Vector3d& a) {
  // Rᵀ·dR = (Rz(c)ᵀRy(b)ᵀ e_x) da + (Rz(c)ᵀ e_y) db + e_z dc, each as a cross-product matrix.
  const Eigen::Matrix3d rz_t =
      Eigen::AngleAxisd(-a.z(), Eigen::Vector3d::UnitZ()).toRotationMatrix();
  const Eigen::Matrix3d ry_t =
      Eigen::AngleAxisd(-a.y(), Eigen::Vector3d::UnitY()).toRotationMatrix();
  Eigen::Matrix3d j;
  j.col(0) = rz_t * ry_t * Eigen::Vector3d::UnitX();
  j.col(1) = rz_t * Eigen::Vector3d::UnitY();
  j.col(2) = Eigen::Vector3d::UnitZ();
  return j;
}

}  // namespace armsig
