#include "core/spread.h"

#include <Eigen/Eigenvalues>
#include <cmath>

namespace armsig {

Eigen::Vector3d PrincipalSpread(const Eigen::Matrix3Xd& points) {
  if (points.cols() == 0) return Eigen::Vector3d::Zero();
  const Eigen::Matrix3Xd centred = points.colwise() - points.rowwise().mean();
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> scatter(centred * centred.transpose(),
                                                                Eigen::EigenvaluesOnly);
  const Eigen::Vector3d variances = scatter.eigenvalues();  // increasing
  Eigen::Vector3d spread;
  for (int i = 0; i < 3; ++i) spread(i) = std::sqrt(std::max(0.0, variances(2 - i)));
  return spread;
}

}  // namespace armsig
