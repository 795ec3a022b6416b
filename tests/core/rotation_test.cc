#include "core/rotation.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

namespace armsig {
namespace {

// The elementary rotations written out, independently of Eigen's AngleAxis.
Eigen::Matrix3d Rx(double a) {
  Eigen::Matrix3d m;
  m << 1, 0, 0, 0, std::cos(a), -std::sin(a), 0, std::sin(a), std::cos(a);
  return m;
}
Eigen::Matrix3d Ry(double a) {
  Eigen::Matrix3d m;
  m << std::cos(a), 0, std::sin(a), 0, 1, 0, -std::sin(a), 0, std::cos(a);
  return m;
}
Eigen::Matrix3d Rz(double a) {
  Eigen::Matrix3d m;
  m << std::cos(a), -std::sin(a), 0, std::sin(a), std::cos(a), 0, 0, 0, 1;
  return m;
}
Eigen::Matrix3d Skew(const Eigen::Vector3d& w) {
  Eigen::Matrix3d m;
  m << 0, -w.z(), w.y(), w.z(), 0, -w.x(), -w.y(), w.x(), 0;
  return m;
}

constexpr double kDeg = M_PI / 180.0;

TEST(RotationFromRxRyRz, IsRxTimesRyTimesRz) {
  const Eigen::Vector3d a(-90.179563 * kDeg, -20.112975 * kDeg, -90.157388 * kDeg);
  EXPECT_LT((RotationFromRxRyRz(a) - Rx(a.x()) * Ry(a.y()) * Rz(a.z())).norm(), 1e-15);
  // A quarter turn about x alone takes the frame's y axis to the world's z.
  EXPECT_LT((RotationFromRxRyRz({M_PI / 2, 0, 0}) * Eigen::Vector3d::UnitY() -
             Eigen::Vector3d::UnitZ())
                .norm(),
            1e-15);
  // Intrinsic x, y′, z″: after a quarter turn about x, the turn "about y" is about the
  // turned frame's y, which is the world's z.
  const Eigen::Matrix3d r = RotationFromRxRyRz({M_PI / 2, M_PI / 2, 0});
  EXPECT_LT((r * Eigen::Vector3d::UnitX() - Eigen::Vector3d(0, 1, 0)).norm(), 1e-15);
}

TEST(RxRyRzFromRotation, RecoversTheAnglesEverywhereButAtGimbalLock) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> angle(-M_PI, M_PI), tilt(-M_PI / 2 + 1e-3, M_PI / 2 - 1e-3);
  for (int k = 0; k < 1000; ++k) {
    const Eigen::Vector3d a(angle(rng), tilt(rng), angle(rng));
    const Eigen::Vector3d back = RxRyRzFromRotation(Rx(a.x()) * Ry(a.y()) * Rz(a.z()));
    EXPECT_LT((back - a).norm(), 1e-9) << a.transpose();
  }
  // At ry = ±90° only rx ± rz is defined: rz comes back 0 and the rotation is the same.
  for (double b : {M_PI / 2, -M_PI / 2}) {
    const Eigen::Matrix3d r = Rx(0.3) * Ry(b) * Rz(0.2);
    const Eigen::Vector3d back = RxRyRzFromRotation(r);
    EXPECT_EQ(back.z(), 0.0);
    EXPECT_LT((Rx(back.x()) * Ry(back.y()) * Rz(back.z()) - r).norm(), 1e-12);
  }
}

TEST(BodyRatesOfRxRyRz, MatchCentralDifferences) {
  const Eigen::Vector3d a(0.7, -0.4, 2.1);
  const Eigen::Matrix3d r = Rx(a.x()) * Ry(a.y()) * Rz(a.z());
  const Eigen::Matrix3d j = BodyRatesOfRxRyRz(a);
  const double h = 1e-6;
  for (int k = 0; k < 3; ++k) {
    Eigen::Vector3d plus = a, minus = a;
    plus(k) += h;
    minus(k) -= h;
    const Eigen::Matrix3d d = (RotationFromRxRyRz(plus) - RotationFromRxRyRz(minus)) / (2 * h);
    // Rᵀ·dR/da is the cross-product matrix of the body rate.
    EXPECT_LT((r.transpose() * d - Skew(j.col(k))).norm(), 1e-9) << "angle " << k;
  }
}

}  // namespace
}  // namespace armsig
