#include "reduction/network.h"

#include <Eigen/Eigenvalues>
#include <cmath>

namespace armsig::reduction {

EffectiveSigmas SigmasOf(const Observation& obs, const Station* station,
                         const InstrumentDefaults& defaults) {
  auto pick = [](double own, double station_value, double fallback) {
    if (std::isfinite(own) && own > 0) return own;
    if (std::isfinite(station_value) && station_value > 0) return station_value;
    return fallback;
  };
  const double nan = std::numeric_limits<double>::quiet_NaN();
  return {pick(obs.sigma_hz_rad, station ? station->sigma_hz_rad : nan, defaults.sigma_hz_rad),
          pick(obs.sigma_v_rad, station ? station->sigma_v_rad : nan, defaults.sigma_v_rad),
          pick(obs.sigma_distance_mm, nan, defaults.sigma_distance_mm)};
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
