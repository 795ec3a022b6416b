#include "reduction/intersection.h"

#include <gtest/gtest.h>

#include <Eigen/Dense>

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
  keep_all.reject_blunders = false;
  for (int k = 0; k < n; ++k) {
    const Eigen::Vector3d truth = lab.RandomTarget();
    const Ray rays[3] = {lab.RayTo(0, truth), lab.RayTo(1, truth), lab.RayTo(2, truth)};
    Intersect(rays, keep_all, r);
    ASSERT_EQ(r.status, IntersectionStatus::kOk);
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
  keep_all.reject_blunders = false;
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
    ASSERT_EQ(r.status, IntersectionStatus::kOk);
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
  EXPECT_EQ(r.status, IntersectionStatus::kOk);
  EXPECT_TRUE(r.blunder_suspected);
  EXPECT_EQ(r.rejected, 0);
}

TEST(Intersection, OneRayAndParallelRaysAreRefusedWithTheReason) {
  SimLab lab;
  const Eigen::Vector3d truth = lab.RandomTarget();
  const Ray one[1] = {lab.RayTo(0, truth)};
  const auto a = Intersect(one);
  EXPECT_EQ(a.status, IntersectionStatus::kOneRay);
  EXPECT_FALSE(a.reason.empty());
  EXPECT_TRUE(std::isnan(a.position_mm.x()));  // never an invented point
  // Two stations 1 mm apart looking at a point 4 m away: rays 0.014° apart.
  Ray r1 = lab.RayTo(0, truth), r2 = r1;
  r2.station_mm += Eigen::Vector3d(1.0, 0, 0);
  r2.reading = PredictReading(r2.station_mm, r2.world_from_station, truth);
  const Ray both[2] = {r1, r2};
  EXPECT_EQ(Intersect(both).status, IntersectionStatus::kParallelRays);
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
    ASSERT_EQ(a.status, IntersectionStatus::kOk);
    EXPECT_EQ(a.dof, 0);
    EXPECT_LT((a.position_mm - truth).norm(), 0.1);
    const Ray mixed[3] = {tracker, lab.RayTo(1, truth), lab.RayTo(2, truth)};
    IntersectionOptions keep_all;
    keep_all.reject_blunders = false;
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
