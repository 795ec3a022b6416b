// The on-the-spot checks of a polar instrument (a laser tracker) against the standard
// deviations it states with every reading: a reading whose stated sigma is too large, and
// repeated readings of one target that disagree beyond their own sigmas.
#pragma once

#include <Eigen/Core>

#include "core/types.h"

namespace armsig::reduction {

// One-sigma errors of a polar reading, independent per component.
struct PolarSigmas {
  double hz_rad = 0.0, v_rad = 0.0, distance_mm = 0.0;
};

// The point distance · (sin V sin Hz, sin V cos Hz, cos V) of a reading (either face) in the
// instrument frame, mm.
Eigen::Vector3d PolarPoint(const AngleReading& reading, double distance_mm);

// Covariance (mm²) of that point from the reading's sigmas, to first order: C = J S Jᵀ with
// J = [∂p/∂Hz ∂p/∂V ∂p/∂d] = [d sin V e_hz, d e_v, u] (orthogonal columns), so its
// eigenvalues are (d sin V σ_Hz)², (d σ_V)², σ_d².
Eigen::Matrix3d PolarCovariance(const AngleReading& reading, double distance_mm,
                                const PolarSigmas& sigma);

// The largest one-sigma error of a point along any direction, mm: √ of the covariance's
// largest eigenvalue.
double LargestSigmaMm(const Eigen::Matrix3d& covariance_mm2);

// Two readings of one target in units of their combined sigma, √(Δᵀ (C_a + C_b)⁻¹ Δ): about
// √3 ≈ 1.7 for agreeing readings (χ with 3 degrees of freedom), above 4 in 0.1 % of pairs.
double NormalisedDisagreement(const Eigen::Vector3d& a, const Eigen::Matrix3d& covariance_a,
                              const Eigen::Vector3d& b, const Eigen::Matrix3d& covariance_b);

}  // namespace armsig::reduction
