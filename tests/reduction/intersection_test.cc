#include "reduction/intersection.h"

#include <ceres/jet.h>
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <limits>

#include "reduction/observation.h"
#include "reduction/sim_lab.h"

namespace armsig::reduction {

using testing::SimLab;

// Over many points, the normalised squared error eᵀ Q⁻¹ e follows χ²(3): mean 3.
TEST(Intersection, ErrorIsConsistentWithPropagatedPrecision) {
  SimLab lab;
  const int n = 4000;
  double chi2 = 0.0;
  IntersectionResult r;
  // Data snooping at α0 = 0.1 % per observation would reject ~24 clean rays here.
  IntersectionOptions keep_all;
  keep_all.snooping.reject = false;
  for (int k = 0; k < n; ++k) {
    const Eigen::Vector3d truth = lab.RandomTarget();
    const Ray rays[3] = {lab.RayTo(0, truth), lab.RayTo(1, truth), lab.RayTo(2, truth)};
    Intersect(rays, keep_all, r);
    ASSERT_TRUE(r.status.ok()) << r.status.message;
    const Eigen::Vector3d e = r.position_mm - truth;
    chi2 += e.dot(r.covariance_mm2.inverse() * e) / n;
    EXPECT_EQ(r.dof, 3);
  }
  // σ of the mean of χ²(3) over 4000 points is √(6/4000) = 0.039.
  EXPECT_NEAR(chi2, 3.0, 0.2);
}

TEST(Intersection, SigmaZeroAPosterioriMatchesTheNoise) {
  SimLab lab;
  double sum_sq = 0.0;
  int dof = 0;
  IntersectionOptions keep_all;
  keep_all.snooping.reject = false;
  for (int k = 0; k < 2000; ++k) {
    const Eigen::Vector3d truth = lab.RandomTarget();
    const Ray rays[3] = {lab.RayTo(0, truth), lab.RayTo(1, truth), lab.RayTo(2, truth)};
    const auto r = Intersect(rays, keep_all);
    sum_sq += r.sigma0 * r.sigma0 * r.dof;
    dof += r.dof;
  }
  EXPECT_NEAR(std::sqrt(sum_sq / dof), 1.0, 0.03);
}

TEST(Intersection, PlantedBlunderIsFoundAndRejected) {
  SimLab lab(4, 7);
  int found = 0;
  for (int k = 0; k < 50; ++k) {
    const Eigen::Vector3d truth = lab.RandomTarget();
    std::vector<Ray> rays = {lab.RayTo(0, truth), lab.RayTo(1, truth), lab.RayTo(2, truth),
                             lab.RayTo(3, truth)};
    rays[2].reading.hz_rad += 30.0 * kRadPerArcsec;  // a 30″ pointing error
    const auto r = Intersect(rays);
    ASSERT_TRUE(r.status.ok()) << r.status.message;
    if (r.rays[2].rejected && r.rejected == 1) ++found;
    // After rejection the point is as good as three clean rays.
    EXPECT_LT((r.position_mm - truth).norm(), 0.1);
  }
  EXPECT_GE(found, 48);
}

TEST(Intersection, TwoRaysCannotRejectButReportTheSuspicion) {
  SimLab lab;
  const Eigen::Vector3d truth = lab.RandomTarget();
  std::vector<Ray> rays = {lab.RayTo(0, truth), lab.RayTo(1, truth)};
  rays[1].reading.v_rad += 60.0 * kRadPerArcsec;
  const auto r = Intersect(rays);
  EXPECT_TRUE(r.status.ok()) << r.status.message;
  EXPECT_TRUE(r.flags.Has(PointFlag::kBlunderSuspected));
  EXPECT_FALSE(r.flags.Has(PointFlag::kBlunderRejected));
  EXPECT_EQ(r.rejected, 0);
}

TEST(Intersection, OneRayAndParallelRaysAreRefusedWithTheReason) {
  SimLab lab;
  const Eigen::Vector3d truth = lab.RandomTarget();
  const Ray one[1] = {lab.RayTo(0, truth)};
  const auto a = Intersect(one);
  EXPECT_EQ(a.status.code, SolveCode::kTooFewObservations);
  EXPECT_EQ(ToString(a.flags), "one_ray");
  EXPECT_FALSE(a.status.message.empty());
  EXPECT_TRUE(std::isnan(a.position_mm.x()));  // never an invented point
  // Two stations 1 mm apart looking at a point 4 m away: rays 0.014° apart.
  Ray r1 = lab.RayTo(0, truth), r2 = r1;
  r2.station_mm += Eigen::Vector3d(1.0, 0, 0);
  r2.reading = PredictReading(r2.station_mm, r2.world_from_station, truth);
  const Ray both[2] = {r1, r2};
  const auto parallel = Intersect(both);
  EXPECT_EQ(parallel.status.code, SolveCode::kDegenerate);
  EXPECT_EQ(ToString(parallel.flags), "parallel_rays");
}

// A laser tracker (angles + distance) gives a point on its own and combines with rays.
TEST(Intersection, DistancesGivePointsAloneAndCombineWithAngles) {
  SimLab lab;
  std::normal_distribution<double> noise(0.0, 0.01);
  double chi2 = 0.0;
  const int n = 1000;
  for (int k = 0; k < n; ++k) {
    const Eigen::Vector3d truth = lab.RandomTarget();
    Ray tracker = lab.RayTo(0, truth);
    tracker.distance_mm = (truth - tracker.station_mm).norm() + noise(lab.rng);
    tracker.sigma_distance_mm = 0.01;
    const Ray alone[1] = {tracker};
    const auto a = Intersect(alone);
    ASSERT_TRUE(a.status.ok()) << a.status.message;
    EXPECT_EQ(a.dof, 0);
    EXPECT_LT((a.position_mm - truth).norm(), 0.1);
    const Ray mixed[3] = {tracker, lab.RayTo(1, truth), lab.RayTo(2, truth)};
    IntersectionOptions keep_all;
    keep_all.snooping.reject = false;
    const auto m = Intersect(mixed, keep_all);
    const Eigen::Vector3d e = m.position_mm - truth;
    chi2 += e.dot(m.covariance_mm2.inverse() * e) / n;
    EXPECT_EQ(m.dof, 4);
  }
  EXPECT_NEAR(chi2, 3.0, 0.35);
}

TEST(Intersection, FaceTwoReadingsIntersectLikeFaceOne) {
  SimLab lab;
  const Eigen::Vector3d truth = lab.RandomTarget();
  std::vector<Ray> rays = {lab.RayTo(0, truth), lab.RayTo(1, truth), lab.RayTo(2, truth)};
  const auto face1 = Intersect(rays);
  for (auto& ray : rays) {
    ray.reading = {WrapTwoPi(ray.reading.hz_rad + kPi), 2 * kPi - ray.reading.v_rad, 2};
  }
  const auto face2 = Intersect(rays);
  EXPECT_LT((face1.position_mm - face2.position_mm).norm(), 1e-9);
}

}  // namespace armsig::reduction

namespace armsig::reduction {

TEST(RayOf, TakesTheObservationsSigmasElseTheStationsElseTheDefaults) {
  Station station;
  station.pose.position_mm = {1.0, 2.0, 3.0};
  station.pose.world_from_station = LevelledRotation(0.7);
  station.sigma_hz_rad = 2e-6;
  Observation o;
  o.reading = {1.1, 1.2, 1};
  o.sigma_v_rad = 3e-6;
  InstrumentDefaults defaults;
  defaults.sigma_hz_rad = 9e-6;
  defaults.sigma_v_rad = 8e-6;
  const Ray a = RayOf(o, station, defaults);
  EXPECT_EQ(a.station_mm, station.pose.position_mm);
  EXPECT_EQ(a.world_from_station, station.pose.world_from_station);
  EXPECT_EQ(a.reading.hz_rad, 1.1);
  EXPECT_EQ(a.sigma_hz_rad, 2e-6);  // the station's
  EXPECT_EQ(a.sigma_v_rad, 3e-6);   // the observation's
  EXPECT_FALSE(a.distance_mm.has_value());
  o.distance_mm = 1234.5;
  station.sigma_hz_rad = std::numeric_limits<double>::quiet_NaN();
  const Ray b = RayOf(o, station, defaults);
  EXPECT_EQ(b.sigma_hz_rad, 9e-6);  // the default
  ASSERT_TRUE(b.distance_mm.has_value());
  EXPECT_EQ(*b.distance_mm, 1234.5);
}

// The analytic Jacobian in Intersect against autodiff of the one observation equation:
// with three exact rays the covariance is (AᵀWA)⁻¹ of the autodiff Jacobian.
TEST(Intersection, CovarianceMatchesAutodiffOfTheObservationEquation) {
  SimLab lab;
  const Eigen::Vector3d truth = lab.RandomTarget();
  std::vector<Ray> rays;
  for (int s = 0; s < 3; ++s) {
    Ray r = lab.RayTo(s, truth);
    r.reading = PredictReading(r.station_mm, r.world_from_station, truth);  // exact
    rays.push_back(r);
  }
  const auto result = Intersect(rays);
  ASSERT_TRUE(result.status.ok());
  EXPECT_LT((result.position_mm - truth).norm(), 1e-9);
  using Jet = ceres::Jet<double, 3>;
  Eigen::Matrix3d normal = Eigen::Matrix3d::Zero();
  for (const Ray& r : rays) {
    Eigen::Matrix<Jet, 3, 1> x;
    for (int i = 0; i < 3; ++i) x(i) = Jet(truth(i), i);
    const Eigen::Matrix<Jet, 3, 1> d =
        r.world_from_station.transpose().cast<Jet>() * (x - r.station_mm.cast<Jet>());
    const Eigen::Matrix<Jet, 2, 1> hz_v = HzVOf(d);
    const Eigen::RowVector3d a_hz = hz_v(0).v.transpose() / r.sigma_hz_rad;
    const Eigen::RowVector3d a_v = hz_v(1).v.transpose() / r.sigma_v_rad;
    normal += a_hz.transpose() * a_hz + a_v.transpose() * a_v;
  }
  const Eigen::Matrix3d expected = normal.inverse();
  EXPECT_LT((result.covariance_mm2 - expected).norm(), 1e-6 * expected.norm());
}

TEST(Intersection, NonFiniteInputIsNeverOk) {
  SimLab lab;
  const Eigen::Vector3d truth = lab.RandomTarget();
  std::vector<Ray> rays = {lab.RayTo(0, truth), lab.RayTo(1, truth), lab.RayTo(2, truth)};
  rays[1].reading.v_rad = std::numeric_limits<double>::quiet_NaN();
  const auto r = Intersect(rays);
  EXPECT_EQ(r.status.code, SolveCode::kNonFinite);
  EXPECT_EQ(ToString(r.flags), "non_finite");
  EXPECT_FALSE(r.position_mm.allFinite());
}

TEST(IntersectPoint, MissToleranceFlagsOnlyAboveIt) {
  SimLab lab;
  const Eigen::Vector3d truth = lab.RandomTarget();
  RayGroup group;
  group.rays = {lab.RayTo(0, truth), lab.RayTo(1, truth), lab.RayTo(2, truth)};
  PointOptions options;
  const ReducedPoint unchecked = IntersectPoint(group, options);
  ASSERT_TRUE(unchecked.result.status.ok());
  const double miss = unchecked.result.max_miss_mm;
  EXPECT_GT(miss, 0.0);
  EXPECT_FALSE(unchecked.result.flags.Has(PointFlag::kMissExceeded));
  options.checks.max_miss_mm = 0.5 * miss;
  const ReducedPoint strict = IntersectPoint(group, options);
  EXPECT_TRUE(strict.result.flags.Has(PointFlag::kMissExceeded));
  EXPECT_FALSE(strict.accepted());
  options.checks.max_miss_mm = 2.0 * miss;
  const ReducedPoint loose = IntersectPoint(group, options);
  EXPECT_FALSE(loose.result.flags.Has(PointFlag::kMissExceeded));
  EXPECT_TRUE(loose.accepted());
}

TEST(IntersectPoint, RepeatIsTheSpreadOfTheRepeatedRoundsPoints) {
  SimLab lab;
  const Eigen::Vector3d truth = lab.RandomTarget();
  RayGroup group;
  for (int round = 0; round < 3; ++round) {
    group.repeats.push_back({lab.RayTo(0, truth), lab.RayTo(1, truth), lab.RayTo(2, truth)});
    group.rays.insert(group.rays.end(), group.repeats.back().begin(), group.repeats.back().end());
  }
  // Independent computation of the spread.
  std::vector<Eigen::Vector3d> points;
  for (const auto& round : group.repeats) points.push_back(Intersect(round).position_mm);
  double spread = 0.0;
  for (size_t a = 0; a < points.size(); ++a)
    for (size_t b = a + 1; b < points.size(); ++b)
      spread = std::max(spread, (points[a] - points[b]).norm());
  PointOptions options;
  options.checks.max_repeat_mm = 0.9 * spread;
  const ReducedPoint p = IntersectPoint(group, options);
  ASSERT_TRUE(p.repeat_mm.has_value());
  EXPECT_DOUBLE_EQ(*p.repeat_mm, spread);
  EXPECT_TRUE(p.result.flags.Has(PointFlag::kRepeatExceeded));
  EXPECT_EQ(p.result.rays.size(), 9u);  // the point itself is from every ray
  options.checks.max_repeat_mm = 1.1 * spread;
  EXPECT_FALSE(IntersectPoint(group, options).result.flags.Has(PointFlag::kRepeatExceeded));
  group.repeats.resize(1);  // one round: no repeatability to check
  EXPECT_FALSE(IntersectPoint(group, options).repeat_mm.has_value());
}

TEST(IntersectPoint, FailedPointCarriesItsFlagAndNoChecks) {
  SimLab lab;
  RayGroup group;
  group.rays = {lab.RayTo(0, lab.RandomTarget())};
  PointOptions options;
  options.checks.max_miss_mm = 0.0;
  const ReducedPoint p = IntersectPoint(group, options);
  EXPECT_EQ(p.result.status.code, SolveCode::kTooFewObservations);
  EXPECT_EQ(ToString(p.result.flags), "one_ray");
}

TEST(CarriedOverFlags, KeepsOnlyWhatTheStoredRaysCannotShow) {
  PointFlags stored;
  stored.Set(PointFlag::kMissExceeded)
      .Set(PointFlag::kRepeatExceeded)
      .Set(PointFlag::kBlunderRejected);
  EXPECT_EQ(ToString(CarriedOverFlags(stored, PointChecks{})), "miss_exceeded repeat_exceeded");
  PointChecks with_miss;
  with_miss.max_miss_mm = 0.1;
  EXPECT_EQ(ToString(CarriedOverFlags(stored, with_miss)), "repeat_exceeded");
  EXPECT_TRUE(CarriedOverFlags(PointFlag::kBlunderSuspected, PointChecks{}).empty());
}

}  // namespace armsig::reduction
