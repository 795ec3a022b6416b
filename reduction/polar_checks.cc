#include "reduction/polar_checks.h"

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <cmath>
#include <limits>

#include "reduction/observation.h"

namespace armsig::reduction {

Eigen::Vector3d PolarPoint(const AngleReading& reading, double distance_mm) {
  return distance_mm * DirectionInStation(ToFaceOne(reading));
}

Eigen::Matrix3d PolarCovariance(const AngleReading& reading, double distance_mm,
                                const PolarSigmas& sigma) {
  const AngleReading r = ToFaceOne(reading);
  const double sh = std::sin(r.hz_rad), ch = std::cos(r.hz_rad);
  const double sv = std::sin(r.v_rad), cv = std::cos(r.v_rad);
  Eigen::Matrix3d j;
  j.col(0) = distance_mm * Eigen::Vector3d(sv * ch, -sv * sh, 0.0);  // ∂p/∂Hz
  j.col(1) = distance_mm * Eigen::Vector3d(cv * sh, cv * ch, -sv);   // ∂p/∂V
  j.col(2) = Eigen::Vector3d(sv * sh, sv * ch, cv);                  // ∂p/∂d
  const Eigen::Vector3d variances(sigma.hz_rad * sigma.hz_rad, sigma.v_rad * sigma.v_rad,
                                  sigma.distance_mm * sigma.distance_mm);
  return j * variances.asDiagonal() * j.transpose();
}

double LargestSigmaMm(const Eigen::Matrix3d& covariance_mm2) {
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eigen(covariance_mm2,
                                                             Eigen::EigenvaluesOnly);
  return std::sqrt(std::max(0.0, eigen.eigenvalues().maxCoeff()));
}

double NormalisedDisagreement(const Eigen::Vector3d& a, const Eigen::Matrix3d& covariance_a,
                              const Eigen::Vector3d& b, const Eigen::Matrix3d& covariance_b) {
  const Eigen::Vector3d delta = a - b;
  const Eigen::Matrix3d sum = covariance_a + covariance_b;
  const Eigen::LDLT<Eigen::Matrix3d> ldlt(sum);
  if (ldlt.info() != Eigen::Success || !(ldlt.vectorD().minCoeff() > 0.0)) {
    // No stated uncertainty in some direction: any difference is infinitely many sigmas.
    return delta.norm() > 0.0 ? std::numeric_limits<double>::infinity() : 0.0;
  }
  return std::sqrt(std::max(0.0, delta.dot(ldlt.solve(delta))));
}

}  // namespace armsig::reduction
