#include "reduction/observation.h"

#include <ceres/jet.h>
#include <gtest/gtest.h>

#include <cmath>

#include "core/units.h"

namespace armsig::reduction {

TEST(Observation, HzOneHundredGonPointsAlongX) {
  const Eigen::Vector3d d =
      DirectionInStation({ToRad(100, AngleUnit::kGon), ToRad(100, AngleUnit::kGon), 1});
  EXPECT_LT((d - Eigen::Vector3d::UnitX()).norm(), 1e-15);
  const Eigen::Vector3d up = DirectionInStation({0.3, 0.0, 1});
  EXPECT_LT((up - Eigen::Vector3d::UnitZ()).norm(), 1e-15);
}

TEST(Observation, FaceTwoReadingIsTheSameDirection) {
  const AngleReading face1{ToRad(37.5, AngleUnit::kGon), ToRad(88.0, AngleUnit::kGon), 1};
  const AngleReading face2{ToRad(237.5, AngleUnit::kGon), ToRad(312.0, AngleUnit::kGon), 2};
  EXPECT_LT((DirectionInStation(face1) - DirectionInStation(face2)).norm(), 1e-14);
}

TEST(Observation, ReadingOfInvertsDirection) {
  const AngleReading r{4.2, 1.3, 1};
  const AngleReading back = ReadingOf(DirectionInStation(r));
  EXPECT_NEAR(back.hz_rad, 4.2, 1e-14);
  EXPECT_NEAR(back.v_rad, 1.3, 1e-14);
}

TEST(Observation, LevelledStationAzimuthTurnsClockwise) {
  // Azimuth 100 gon: circle zero looks along world +x, so Hz = 0 maps to +x.
  const Eigen::Matrix3d r = LevelledRotation(ToRad(100, AngleUnit::kGon));
  EXPECT_LT((r * Eigen::Vector3d::UnitY() - Eigen::Vector3d::UnitX()).norm(), 1e-15);
}

}  // namespace armsig::reduction

namespace armsig::reduction {

// The templated observation equation on ceres::Jet (autodiff) against central
// differences of the double version, at directions all around the station.
TEST(ObservationEquation, AutodiffMatchesCentralDifferences) {
  using Jet = ceres::Jet<double, 3>;
  const Eigen::Vector3d targets[] = {{1200.0, 3400.0, 500.0},
                                     {-2500.0, 800.0, -300.0},
                                     {-100.0, -4000.0, 2000.0},
                                     {3.0, -2.0, 1.0}};
  for (const Eigen::Vector3d& d : targets) {
    Eigen::Matrix<Jet, 3, 1> dj;
    for (int i = 0; i < 3; ++i) dj(i) = Jet(d(i), i);
    const Eigen::Matrix<Jet, 2, 1> hz_v = HzVOf(dj);
    const Eigen::Vector2d value = HzVOf<double>(d);
    EXPECT_DOUBLE_EQ(hz_v(0).a, value(0));
    EXPECT_DOUBLE_EQ(hz_v(1).a, value(1));
    for (int i = 0; i < 3; ++i) {
      const double h = 1e-6 * d.norm();
      Eigen::Vector3d plus = d, minus = d;
      plus(i) += h;
      minus(i) -= h;
      const Eigen::Vector2d numeric = (HzVOf<double>(plus) - HzVOf<double>(minus)) / (2 * h);
      EXPECT_NEAR(hz_v(0).v(i), numeric(0), 1e-9 * numeric.norm() + 1e-12) << d.transpose();
      EXPECT_NEAR(hz_v(1).v(i), numeric(1), 1e-9 * numeric.norm() + 1e-12) << d.transpose();
    }
  }
}

TEST(ObservationEquation, AgreesWithDirectionInStation) {
  // HzVOf inverts DirectionInStation: the reading of a direction is the reading itself.
  const AngleReading r{ToRad(312.5, AngleUnit::kGon), ToRad(71.25, AngleUnit::kGon), 1};
  const Eigen::Vector2d hz_v = HzVOf<double>(DirectionInStation(r) * 2500.0);
  EXPECT_NEAR(WrapTwoPi(hz_v(0)), r.hz_rad, 1e-14);
  EXPECT_NEAR(hz_v(1), r.v_rad, 1e-14);
}

TEST(ObservationEquation, HzResidualIsWrappedAcrossCircleZero) {
  // Target just left of circle zero, observed just right of it: 2″ apart, not 2π.
  const double eps = 1.0 * kRadPerArcsec;
  const Eigen::Vector3d d(-std::sin(eps), std::cos(eps), 0.0);
  const Eigen::Vector2d r = HzVResidual<double>(d, eps, kPi / 2);
  EXPECT_NEAR(r(0), -2.0 * eps, 1e-15);
  EXPECT_NEAR(r(1), 0.0, 1e-15);
}

}  // namespace armsig::reduction
