// Ceres residuals of the station orientation (whitened: divided by the a-priori sigma).
// Each is a small struct with the measurement as members, a templated operator() and a
// static Create (Ceres examples/, COLMAP estimators/cost_functions.h).
#pragma once

#include <ceres/ceres.h>
#include <ceres/rotation.h>

#include <Eigen/Core>

#include "reduction/observation.h"

namespace armsig::reduction {

// Hz and V of a point (or another station's centre) seen from a station: the observation
// equation AngleResidualOf (HzVResidual, or PoleResidual for a reading at the zenith or nadir,
// whose two components are both weighted with sigma_v: see SigmaAcross), finite for every
// prediction, the standing axis included. kOrientationSize 1:
// levelled, the azimuth (world_from_station = Rz(−azimuth)); 3: angle-axis of world_from_station.
template <int kOrientationSize>
struct AngleResidual {
  AngleResidual(double hz, double v, double sigma_hz, double sigma_v)
      : hz(hz), v(v), sigma_hz(sigma_hz), sigma_v(sigma_v) {}

  template <typename T>
  bool operator()(const T* station, const T* orientation, const T* point, T* residual) const {
    const T world[3] = {point[0] - station[0], point[1] - station[1], point[2] - station[2]};
    Eigen::Matrix<T, 3, 1> d;
    if constexpr (kOrientationSize == 1) {
      // station_from_world = Rz(azimuth).
      using std::cos;
      using std::sin;
      const T c = cos(orientation[0]), s = sin(orientation[0]);
      d << c * world[0] - s * world[1], s * world[0] + c * world[1], world[2];
    } else {
      const T inverse[3] = {-orientation[0], -orientation[1], -orientation[2]};
      ceres::AngleAxisRotatePoint(inverse, world, d.data());
    }
    // A target on the station itself has no direction: not a step Ceres may take (it rejects
    // it and shortens the step); initial values never put one there (Orient refuses).
    if (d.dot(d) == T(0)) return false;
    const Eigen::Matrix<T, 2, 1> r = AngleResidualOf(d, hz, v);
    residual[0] = r(0) / T(SigmaAcross(v, sigma_hz, sigma_v));
    residual[1] = r(1) / T(sigma_v);
    return true;
  }

  // The sigma of the first residual: sigma_hz for an Hz reading; near a pole the first
  // residual is an angle across the line of sight (sin V·ΔHz), as precise as the pointing.
  static double SigmaAcross(double v, double sigma_hz, double sigma_v) {
    return NearPole(v) ? sigma_v : sigma_hz;
  }

  static ceres::CostFunction* Create(double hz, double v, double sigma_hz, double sigma_v) {
    return new ceres::AutoDiffCostFunction<AngleResidual, 2, 3, kOrientationSize, 3>(
        new AngleResidual(hz, v, sigma_hz, sigma_v));
  }

  double hz, v, sigma_hz, sigma_v;
};

// One component of AngleResidual (0: Hz, or across the line of sight at a pole; 1: V), for a
// reading whose other component data snooping removed.
template <int kOrientationSize>
struct AngleComponentResidual {
  AngleComponentResidual(double hz, double v, double sigma_hz, double sigma_v, int component)
      : both(hz, v, sigma_hz, sigma_v), component(component) {}

  template <typename T>
  bool operator()(const T* station, const T* orientation, const T* point, T* residual) const {
    T r[2];
    if (!both(station, orientation, point, r)) return false;
    residual[0] = r[component];
    return true;
  }

  static ceres::CostFunction* Create(double hz, double v, double sigma_hz, double sigma_v,
                                     int component) {
    return new ceres::AutoDiffCostFunction<AngleComponentResidual, 1, 3, kOrientationSize, 3>(
        new AngleComponentResidual(hz, v, sigma_hz, sigma_v, component));
  }

  AngleResidual<kOrientationSize> both;
  int component;
};

// A slope distance, or a scale-bar length, between two 3-vectors.
struct LengthResidual {
  LengthResidual(double length, double sigma) : length(length), sigma(sigma) {}
  template <typename T>
  bool operator()(const T* a, const T* b, T* residual) const {
    using std::sqrt;
    const T dx = b[0] - a[0], dy = b[1] - a[1], dz = b[2] - a[2];
    const T squared = dx * dx + dy * dy + dz * dz;
    if (squared == T(0)) return false;  // the derivative of |b − a| at a = b is 0/0
    residual[0] = (sqrt(squared) - T(length)) / T(sigma);
    return true;
  }
  static ceres::CostFunction* Create(double length, double sigma) {
    return new ceres::AutoDiffCostFunction<LengthResidual, 1, 3, 3>(
        new LengthResidual(length, sigma));
  }
  double length, sigma;
};

// A weighted control point.
struct ControlResidual {
  ControlResidual(Eigen::Vector3d known, Eigen::Vector3d sigma) : known(known), sigma(sigma) {}
  template <typename T>
  bool operator()(const T* x, T* residual) const {
    for (int i = 0; i < 3; ++i) residual[i] = (x[i] - T(known(i))) / T(sigma(i));
    return true;
  }
  static ceres::CostFunction* Create(const Eigen::Vector3d& known, const Eigen::Vector3d& sigma) {
    return new ceres::AutoDiffCostFunction<ControlResidual, 3, 3>(
        new ControlResidual(known, sigma));
  }
  Eigen::Vector3d known, sigma;
};

}  // namespace armsig::reduction
