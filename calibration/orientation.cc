#include "calibration/orientation.h"

#include <Eigen/Geometry>
#include <Eigen/SVD>
#include <cmath>

#include "core/rotation.h"

namespace armsig::calibration {

namespace {

Eigen::Matrix3d Skew(const Eigen::Vector3d& w) {
  Eigen::Matrix3d m;
  m << 0, -w.z(), w.y(), w.z(), 0, -w.x(), -w.y(), w.x(), 0;
  return m;
}

}  // namespace

Eigen::Vector3d RotationVector(const Eigen::Matrix3d& rotation) {
  const Eigen::AngleAxisd a(rotation);
  return a.angle() * a.axis();
}

Eigen::Matrix3d RotationFromVector(const Eigen::Vector3d& vector) {
  const double angle = vector.norm();
  if (angle == 0.0) return Eigen::Matrix3d::Identity();
  return Eigen::AngleAxisd(angle, vector / angle).toRotationMatrix();
}

Eigen::Vector3d OrientationResidual(const Eigen::Matrix3d& measured,
                                    const Eigen::Matrix3d& predicted) {
  return RotationVector(measured.transpose() * predicted);
}

Eigen::Matrix3d InverseRightJacobian(const Eigen::Vector3d& e) {
  // J_r⁻¹(e) = I + ½[e]× + (1/θ² − (1 + cos θ)/(2θ sin θ))·[e]×², θ = |e|; its series
  // I + ½[e]× + [e]×²/12 below 1e-4 rad, where the closed form loses digits.
  const double theta = e.norm();
  const Eigen::Matrix3d k = Skew(e);
  const double c = theta < 1e-4 ? 1.0 / 12.0 + theta * theta / 720.0
                                : 1.0 / (theta * theta) -
                                      (1.0 + std::cos(theta)) / (2.0 * theta * std::sin(theta));
  return Eigen::Matrix3d::Identity() + 0.5 * k + c * k * k;
}

OrientationLinearisation LineariseOrientation(const Eigen::Matrix3d& measured,
                                              const Eigen::Matrix3d& last_rotation,
                                              const Eigen::Matrix3d& tool) {
  const Eigen::Matrix3d predicted = last_rotation * tool;
  OrientationLinearisation l;
  l.residual = OrientationResidual(measured, predicted);
  l.by_tool_turn = InverseRightJacobian(l.residual);
  l.by_world_turn = l.by_tool_turn * predicted.transpose();
  return l;
}

Eigen::Matrix3d MeanRotation(const std::vector<Eigen::Matrix3d>& rotations) {
  Eigen::Matrix3d sum = Eigen::Matrix3d::Zero();
  for (const auto& r : rotations) sum += r;
  if (rotations.empty()) return Eigen::Matrix3d::Identity();
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(sum, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d d = Eigen::Matrix3d::Identity();
  d(2, 2) = (svd.matrixU() * svd.matrixV().transpose()).determinant() < 0 ? -1.0 : 1.0;
  return svd.matrixU() * d * svd.matrixV().transpose();
}

std::optional<Eigen::Matrix3d> OrientationCovariance(const MeasuredOrientation& orientation) {
  if (!orientation.sigma_rad) return std::nullopt;
  const Eigen::Matrix3d j = BodyRatesOfRxRyRz(RxRyRzFromRotation(orientation.world_from_target));
  return j * orientation.sigma_rad->cwiseAbs2().asDiagonal() * j.transpose();
}

}  // namespace armsig::calibration
