#include "reduction/observation.h"

#include <gtest/gtest.h>

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
