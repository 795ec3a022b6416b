#include "calibration/orientation.h"

#include <gtest/gtest.h>

#include <random>

#include "core/rotation.h"

namespace armsig::calibration {
namespace {

Eigen::Matrix3d Turn(double angle, const Eigen::Vector3d& axis) {
  return Eigen::AngleAxisd(angle, axis.normalized()).toRotationMatrix();
}

TEST(RotationVector, IsTheAxisTimesTheAngleAndInvertsExp) {
  const Eigen::Vector3d axis = Eigen::Vector3d(1, -2, 0.5).normalized();
  EXPECT_LT((RotationVector(Turn(0.3, axis)) - 0.3 * axis).norm(), 1e-15);
  EXPECT_LT((RotationFromVector(0.3 * axis) - Turn(0.3, axis)).norm(), 1e-15);
  EXPECT_EQ(RotationFromVector(Eigen::Vector3d::Zero()), Eigen::Matrix3d::Identity());
  // The residual turns the measured frame into the predicted one, in the target frame.
  const Eigen::Matrix3d measured = Turn(2.0, Eigen::Vector3d(0, 1, 1));
  const Eigen::Vector3d e(1e-3, -2e-3, 5e-4);
  EXPECT_LT((OrientationResidual(measured, measured * RotationFromVector(e)) - e).norm(), 1e-15);
}

TEST(InverseRightJacobian, MatchesCentralDifferencesOfTheResidual) {
  // e(δ) = log(exp([e0]×)·exp([δ]×)): ∂e/∂δ at 0 against central differences, for residuals
  // from rounding size to a large turn (the series and the closed form both).
  for (double size : {1e-9, 3e-5, 2e-4, 0.02, 1.0, 2.5}) {
    const Eigen::Vector3d e0 = size * Eigen::Vector3d(0.6, -0.3, 0.74).normalized();
    const Eigen::Matrix3d j = InverseRightJacobian(e0);
    const double h = 1e-6;
    for (int k = 0; k < 3; ++k) {
      Eigen::Vector3d d = Eigen::Vector3d::Zero();
      d(k) = h;
      const Eigen::Vector3d plus = RotationVector(RotationFromVector(e0) * RotationFromVector(d));
      const Eigen::Vector3d minus = RotationVector(RotationFromVector(e0) * RotationFromVector(-d));
      EXPECT_LT(((plus - minus) / (2 * h) - j.col(k)).norm(), 1e-8) << "size " << size << " column " << k;
    }
  }
}

TEST(MeanRotation, RecoversTheCentreOfSymmetricTurns) {
  const Eigen::Matrix3d centre = Turn(1.2, Eigen::Vector3d(1, 1, 0));
  std::vector<Eigen::Matrix3d> around;
  for (int k = 0; k < 3; ++k) {
    const Eigen::Vector3d axis = Eigen::Vector3d::Unit(k);
    around.push_back(centre * Turn(0.01, axis));
    around.push_back(centre * Turn(-0.01, axis));
  }
  EXPECT_LT((MeanRotation(around) - centre).norm(), 1e-12);
  EXPECT_EQ(MeanRotation({}), Eigen::Matrix3d::Identity());
}

TEST(OrientationCovariance, AgreesWithSampledAngles) {
  // The angles drawn with their sigmas; the sampled covariance of the residual against the
  // propagated one, to the sampling error of 20,000 draws.
  const Eigen::Vector3d angles(-1.574, -0.351, -1.573), sigma(4.3e-5, 1.1e-4, 1.5e-4);
  MeasuredOrientation m{RotationFromRxRyRz(angles), sigma};
  const Eigen::Matrix3d c = *OrientationCovariance(m);
  std::mt19937 rng(3);
  std::normal_distribution<double> unit;
  Eigen::Matrix3d sampled = Eigen::Matrix3d::Zero();
  const int n = 20000;
  for (int k = 0; k < n; ++k) {
    const Eigen::Vector3d a = angles + Eigen::Vector3d(sigma.x() * unit(rng), sigma.y() * unit(rng),
                                                       sigma.z() * unit(rng));
    const Eigen::Vector3d e = OrientationResidual(m.world_from_target, RotationFromRxRyRz(a));
    sampled += e * e.transpose() / n;
  }
  EXPECT_LT((sampled - c).norm(), 0.05 * c.norm());
  EXPECT_FALSE(OrientationCovariance(MeasuredOrientation{m.world_from_target, std::nullopt}));
}

}  // namespace
}  // namespace armsig::calibration
