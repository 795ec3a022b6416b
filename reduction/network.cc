#include "reduction/network.h"

#include <Eigen/Eigenvalues>
#include <cmath>

namespace armsig::reduction {

EffectiveSigmas SigmasOf(const Observation& obs, const Station* station,
                         const InstrumentDefaults& defaults) {
  auto pick = [](std::optional<double> own, std::optional<double> station_value, double fallback) {
    if (own && *own > 0) return *own;
    if (station_value && *station_value > 0) return *station_value;
    return fallback;
  };
  return {
      pick(obs.sigma_hz_rad, station ? station->sigma_hz_rad : std::nullopt, defaults.sigma_hz_rad),
      pick(obs.sigma_v_rad, station ? station->sigma_v_rad : std::nullopt, defaults.sigma_v_rad),
      pick(obs.sigma_distance_mm, std::nullopt, defaults.sigma_distance_mm)};
}

ErrorEllipsoid EllipsoidOf(const Eigen::Matrix3d& covariance_mm2) {
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eigen(covariance_mm2);
  ErrorEllipsoid e;
  for (int k = 0; k < 3; ++k) {
    const double lambda = std::max(0.0, eigen.eigenvalues()(2 - k));
    e.semi_axes_mm(k) = kEllipsoid95Scale * std::sqrt(lambda);
    e.axes.col(k) = eigen.eigenvectors().col(2 - k);
  }
  return e;
}

}  // namespace armsig::reduction
