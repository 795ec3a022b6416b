// Theodolite observation model (docs/reference/conventions.md): z up along the standing
// axis, y towards circle zero, Hz clockwise seen from above, V the zenith angle.
#pragma once

#include <Eigen/Core>
#include <cmath>

#include "core/types.h"

namespace armsig::reduction {

// The one Hz/V observation equation, templated on the scalar so that plain double and
// Ceres's autodiff (ceres::Jet) share it. `d` is the target in the station frame,
// station_from_world · (target − station); returns (Hz, V) with Hz = atan2(dx, dy) in
// (−π, π] (clockwise from circle zero) and V = atan2(√(dx² + dy²), dz) (zenith angle).
template <typename T>
Eigen::Matrix<T, 2, 1> HzVOf(const Eigen::Matrix<T, 3, 1>& d) {
  using std::atan2;
  using std::sqrt;
  return {atan2(d(0), d(1)), atan2(sqrt(d(0) * d(0) + d(1) * d(1)), d(2))};
}

// The zenith and the nadir are the poles of the Hz/V angles: on the standing axis
// Hz = atan2(dx, dy) is undefined (its derivative is 0/0) and V = atan2(ρ, dz) has a kink,
// and near them the Hz derivative grows as 1/sin V. A reading with |sin V| below this is
// adjusted by PoleResidual instead of HzVResidual (≈ 0.064 gon, 3.4' from the axis).
inline constexpr double kPoleSinV = 1e-3;
inline bool NearPole(double v_rad) { return std::abs(std::sin(v_rad)) < kPoleSinV; }

// Whether the predicted direction `d` (station frame) lies within the same cap around the
// standing axis.
template <typename T>
bool PredictedNearPole(const Eigen::Matrix<T, 3, 1>& d) {
  const T rho2 = d(0) * d(0) + d(1) * d(1);
  return rho2 <= T(kPoleSinV * kPoleSinV) * (rho2 + d(2) * d(2));
}

// Residuals of a face-I reading near the zenith or nadir: the predicted unit direction's
// components across the observed direction, along the tangent axes of the reading
// e_hz = (cos Hz, −sin Hz, 0) and e_v = ∂u/∂V = (cos V sin Hz, cos V cos Hz, −sin V).
// For a small misfit they are sin V·ΔHz and ΔV in rad (computed − observed, as
// HzVResidual), and unlike Hz and V they are smooth for every d ≠ 0, on the axis too.
template <typename T>
Eigen::Matrix<T, 2, 1> PoleResidual(const Eigen::Matrix<T, 3, 1>& d, double hz_obs, double v_obs) {
  using std::sqrt;
  const T length = sqrt(d.dot(d));
  const Eigen::Matrix<T, 3, 1> e_hz(T(std::cos(hz_obs)), T(-std::sin(hz_obs)), T(0));
  const Eigen::Matrix<T, 3, 1> e_v(T(std::cos(v_obs) * std::sin(hz_obs)),
                                   T(std::cos(v_obs) * std::cos(hz_obs)), T(-std::sin(v_obs)));
  return {e_hz.dot(d) / length, e_v.dot(d) / length};
}

// Residuals computed − observed of a face-I reading (hz_obs, v_obs) away from the poles
// (!NearPole(v_obs)) for the target at `d` ≠ 0 in the station frame; the Hz residual is
// wrapped to (−π, π]. Finite for every d ≠ 0: while a prediction passes through the
// standing axis (an approximate point straight above the station, a step of the adjustment),
// where Hz has no derivative, the residual is PoleResidual's with its first component divided
// by sin V_obs, which equals ΔHz to first order and is smooth there.
template <typename T>
Eigen::Matrix<T, 2, 1> HzVResidual(const Eigen::Matrix<T, 3, 1>& d, double hz_obs, double v_obs) {
  using std::atan2;
  using std::cos;
  using std::sin;
  if (PredictedNearPole(d)) {
    Eigen::Matrix<T, 2, 1> r = PoleResidual(d, hz_obs, v_obs);
    r(0) /= T(std::sin(v_obs));
    return r;
  }
  const Eigen::Matrix<T, 2, 1> predicted = HzVOf(d);
  const T delta_hz = predicted(0) - T(hz_obs);
  return {atan2(sin(delta_hz), cos(delta_hz)), predicted(1) - T(v_obs)};
}

// The observation equation of a face-I reading for every V: PoleResidual at the poles (both
// components weighted with σ_V, SigmaAcross), HzVResidual elsewhere. Finite for every d ≠ 0.
template <typename T>
Eigen::Matrix<T, 2, 1> AngleResidualOf(const Eigen::Matrix<T, 3, 1>& d, double hz_obs,
                                       double v_obs) {
  return NearPole(v_obs) ? PoleResidual(d, hz_obs, v_obs) : HzVResidual(d, hz_obs, v_obs);
}

// Face-II readings reduced to face I: Hz − 200 gon, 400 gon − V.
AngleReading ToFaceOne(const AngleReading& reading);

// Unit direction in the instrument frame of a face-I reading:
// (sin V sin Hz, sin V cos Hz, cos V).
Eigen::Vector3d DirectionInStation(const AngleReading& reading);

// Hz, V (face I; Hz in [0, 2π)) of a direction in the instrument frame (HzVOf).
AngleReading ReadingOf(const Eigen::Vector3d& direction_in_station);

// World from station for a levelled station: rotation about z by −azimuth.
Eigen::Matrix3d LevelledRotation(double azimuth_rad);

}  // namespace armsig::reduction
