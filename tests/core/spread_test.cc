#include "core/spread.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <Eigen/SVD>
#include <random>

namespace armsig {

// Against the singular values of the centred points (Eigen's JacobiSVD, the direct way):
// a cloud, a flat disc, a thin needle, a line with noise of 1e-5 of its length.
TEST(PrincipalSpread, EqualsTheSingularValuesOfTheCentredPoints) {
  std::mt19937 rng(7);
  std::normal_distribution<double> noise(0.0, 1.0);
  const Eigen::Vector3d shapes[] = {{300, 200, 100}, {500, 400, 0.5}, {800, 0.2, 0.1},
                                    {1000, 1e-2, 1e-2}};
  for (const Eigen::Vector3d& axes : shapes) {
    const Eigen::Matrix3d turn =
        (Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 2, 3).normalized())).toRotationMatrix();
    Eigen::Matrix3Xd points(3, 40);
    for (int i = 0; i < points.cols(); ++i) {
      const Eigen::Vector3d local(axes(0) * noise(rng), axes(1) * noise(rng), axes(2) * noise(rng));
      points.col(i) = turn * local + Eigen::Vector3d(1500, -200, 900);
    }
    const Eigen::Matrix3Xd centred = points.colwise() - points.rowwise().mean();
    const Eigen::Vector3d expected = Eigen::JacobiSVD<Eigen::Matrix3Xd>(centred).singularValues();
    const Eigen::Vector3d spread = PrincipalSpread(points);
    for (int i = 0; i < 3; ++i) {
      EXPECT_NEAR(spread(i), expected(i), 1e-6 * expected(0)) << axes.transpose() << " " << i;
    }
    EXPECT_GE(spread(0), spread(1));
    EXPECT_GE(spread(1), spread(2));
  }
}

// Points on an exact line or in one spot: no second axis; no points: nothing.
TEST(PrincipalSpread, ALineHasNoSecondAxisAndOneSpotNone) {
  Eigen::Matrix3Xd line(3, 5), spot(3, 5);
  for (int i = 0; i < 5; ++i) {
    line.col(i) = Eigen::Vector3d(1, 2, 3) + i * Eigen::Vector3d(10, -5, 2);
    spot.col(i) = Eigen::Vector3d(1, 2, 3);
  }
  const Eigen::Vector3d l = PrincipalSpread(line);
  EXPECT_NEAR(l(0), std::sqrt(10.0) * Eigen::Vector3d(10, -5, 2).norm(), 1e-9);
  EXPECT_LT(l(1), 1e-6 * l(0));
  EXPECT_EQ(PrincipalSpread(spot), Eigen::Vector3d::Zero());
  EXPECT_EQ(PrincipalSpread(Eigen::Matrix3Xd(3, 0)), Eigen::Vector3d::Zero());
}

}  // namespace armsig
