// A laser tracker's set-up in the lab frame from three or more common points: control
// points with their own sigmas, or target points the other stations measure. Synthetic
// truth: the tracker's pose, the points, noise as stated; the recovered pose must lie
// within its propagated sigmas, in every trial and on average (χ²).
#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <random>

#include "reduction/orientation.h"
#include "reduction/polar_checks.h"
#include "reduction/sim_lab.h"

namespace armsig::reduction {
namespace {

// σ of each Cartesian component of a tracker point (AT401 class, MPE/2).
double TrackerSigmaMm(double d) { return (0.015 + 0.006 * d / 1000.0) / 2.0; }

// A tracker reading of `target` (world) from `station`: isotropic noise σ(d) on the
// point, given in Hz, V, d with the sigmas the tracker states.
Observation TrackerReading(const Station& station, const std::string& point,
                           const Eigen::Vector3d& target, std::mt19937& rng) {
  const Eigen::Vector3d in_station =
      station.pose.world_from_station.transpose() * (target - station.pose.position_mm);
  const double sigma = TrackerSigmaMm(in_station.norm());
  std::normal_distribution<double> noise(0.0, sigma);
  const Eigen::Vector3d p = in_station + Eigen::Vector3d(noise(rng), noise(rng), noise(rng));
  Observation o;
  o.station = station.pose.id;
  o.point = point;
  o.reading = ReadingOf(p.normalized());
  o.distance_mm = p.norm();
  o.sigma_hz_rad = sigma / (p.norm() * std::sin(o.reading.v_rad));
  o.sigma_v_rad = sigma / p.norm();
  o.sigma_distance_mm = sigma;
  return o;
}

struct SetUpError {
  Eigen::Vector3d position_z;  // position error / its sigma, per component
  double rotation_z = 0.0;     // rotation error angle / |σ_rotation| (or azimuth z)
};

// One trial: a tracker (levelled or tilted by `tilt_rad`) 2.5–3.5 m from `count` control
// points in a 2 m volume, the control coordinates known to 0.02 mm (weighted).
struct ControlSetUp {
  Station truth;
  OrientationProblem problem;
};
ControlSetUp MakeControlSetUp(unsigned seed, int count, double tilt_rad) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  Station truth;
  truth.pose.id = "LT1";
  truth.pose.position_mm = {3000.0 + 300 * u(rng), -500.0 + 300 * u(rng), 1500.0 + 100 * u(rng)};
  truth.pose.azimuth_rad = WrapTwoPi(3.0 * u(rng) + kPi);
  truth.pose.world_from_station = LevelledRotation(truth.pose.azimuth_rad);
  if (tilt_rad != 0.0) {
    truth.pose.levelled = false;
    const Eigen::Vector3d axis(u(rng), u(rng), 0.0);
    truth.pose.world_from_station =
        Eigen::AngleAxisd(tilt_rad, axis.normalized()).toRotationMatrix() *
        truth.pose.world_from_station;
  }
  OrientationProblem p;
  p.station_ids = {"LT1"};
  if (!truth.pose.levelled) p.unlevelled.insert("LT1");
  const double control_sigma = 0.02;
  std::normal_distribution<double> control_noise(0.0, control_sigma);
  for (int k = 0; k < count; ++k) {
    // Spread over the work volume (not on one line).
    const Eigen::Vector3d x(1000.0 * u(rng), 1000.0 * u(rng), 1000.0 + 800.0 * u(rng));
    const std::string id = "C" + std::to_string(k + 1);
    p.observations.push_back(TrackerReading(truth, id, x, rng));
    ControlPoint c;
    c.id = id;
    c.position_mm = x + Eigen::Vector3d(control_noise(rng), control_noise(rng), control_noise(rng));
    c.sigma_mm = Eigen::Vector3d::Constant(control_sigma);
    p.control.push_back(c);
  }
  return {truth, p};
}

SetUpError TrackerFromControlPoints(unsigned seed, int count, double tilt_rad) {
  const auto [truth, p] = MakeControlSetUp(seed, count, tilt_rad);
  const OrientationResult r = Orient(p);
  EXPECT_TRUE(r.status.ok()) << r.status.message << (r.refusals.empty() ? "" : r.refusals[0]);
  SetUpError e;
  if (!r.status.ok() || r.stations.size() != 1) return e;
  const Station& s = r.stations[0];
  EXPECT_EQ(s.pose.levelled, truth.pose.levelled);
  e.position_z = (s.pose.position_mm - truth.pose.position_mm).cwiseQuotient(s.sigma_position_mm);
  if (truth.pose.levelled) {
    const double d = std::remainder(s.pose.azimuth_rad - truth.pose.azimuth_rad, 2.0 * kPi);
    e.rotation_z = d / s.sigma_azimuth_rad;
  } else {
    const Eigen::AngleAxisd error(s.pose.world_from_station.transpose() *
                                  truth.pose.world_from_station);
    e.rotation_z = error.angle() / s.sigma_rotation_rad.norm();
  }
  EXPECT_EQ(r.dof, 3 * count - (truth.pose.levelled ? 4 : 6));
  return e;
}

void ExpectWithinSigmas(int count, double tilt_rad) {
  double chi2 = 0.0;
  const int trials = 40;
  for (int t = 0; t < trials; ++t) {
    const SetUpError e = TrackerFromControlPoints(100 + t, count, tilt_rad);
    for (int k = 0; k < 3; ++k) EXPECT_LT(std::abs(e.position_z(k)), 4.5) << "trial " << t;
    EXPECT_LT(std::abs(e.rotation_z), 4.5) << "trial " << t;
    chi2 += e.position_z.squaredNorm();
  }
  // Σ over trials of three squared normalised position errors: χ² with 120 degrees of
  // freedom when the sigmas are right (mean 120, sd 15.5).
  EXPECT_GT(chi2, 120.0 - 4 * 15.5) << "sigmas too pessimistic";
  EXPECT_LT(chi2, 120.0 + 4 * 15.5) << "sigmas too optimistic";
  std::cout << count << " control points, tilt " << tilt_rad << " rad: chi2 " << chi2
            << " on 120\n";
}

}  // namespace

TEST(TrackerSetUp, LevelledTrackerFromThreeControlPointsWithinItsSigmas) {
  ExpectWithinSigmas(3, 0.0);
}

// Not levelled, tilted 35° (a tracker on an angle bracket): the polar resection gives the
// start, the rotation is free; with four points there is redundancy to spare.
TEST(TrackerSetUp, TiltedTrackerFromThreeAndFourControlPointsWithinItsSigmas) {
  ExpectWithinSigmas(3, 0.61);
  ExpectWithinSigmas(4, 0.61);
}

// Hanging upside down from the ceiling (tilt 180°): still found, still within its sigmas.
TEST(TrackerSetUp, InvertedTrackerIsFound) {
  const SetUpError e = TrackerFromControlPoints(7, 4, kPi);
  EXPECT_LT(e.position_z.cwiseAbs().maxCoeff(), 4.5);
  EXPECT_LT(std::abs(e.rotation_z), 4.5);
}

// No control point in the tracker's view: it ties into the network through target points
// the two theodolites (oriented on four control points) measure too.
TEST(TrackerSetUp, TrackerFromPointsTheOtherStationsMeasure) {
  double chi2 = 0.0;
  const int trials = 20;
  for (int t = 0; t < trials; ++t) {
    testing::SimLab lab(2, 300 + t);
    std::mt19937& rng = lab.rng;
    Station tracker;
    tracker.pose.id = "LT1";
    tracker.pose.position_mm = {-2500.0, 2000.0, 1300.0};
    tracker.pose.levelled = false;
    tracker.pose.world_from_station =
        Eigen::AngleAxisd(0.02, Eigen::Vector3d::UnitX()).toRotationMatrix() *
        LevelledRotation(2.0 + 0.1 * t);
    OrientationProblem p;
    p.station_ids = {"S1", "S2", "LT1"};
    p.unlevelled.insert("LT1");
    for (int k = 0; k < 4; ++k) {
      const Eigen::Vector3d x = lab.RandomTarget();
      ControlPoint c;
      c.id = "C" + std::to_string(k + 1);
      c.position_mm = x;  // fixed
      p.control.push_back(c);
      for (int s = 0; s < 2; ++s) p.observations.push_back(lab.ObserveTo(s, c.id, x));
    }
    for (int k = 0; k < 6; ++k) {
      const Eigen::Vector3d x = lab.RandomTarget();
      const std::string id = "T" + std::to_string(k + 1);
      for (int s = 0; s < 2; ++s) p.observations.push_back(lab.ObserveTo(s, id, x));
      p.observations.push_back(TrackerReading(tracker, id, x, rng));
    }
    const OrientationResult r = Orient(p);
    ASSERT_TRUE(r.status.ok()) << r.status.message << (r.refusals.empty() ? "" : r.refusals[0]);
    ASSERT_EQ(r.stations.size(), 3u);
    const Station& s = r.stations[2];
    const Eigen::Vector3d z =
        (s.pose.position_mm - tracker.pose.position_mm).cwiseQuotient(s.sigma_position_mm);
    EXPECT_LT(z.cwiseAbs().maxCoeff(), 4.5) << "trial " << t;
    const Eigen::AngleAxisd error(s.pose.world_from_station.transpose() *
                                  tracker.pose.world_from_station);
    EXPECT_LT(error.angle(), 4.5 * s.sigma_rotation_rad.norm()) << "trial " << t;
    chi2 += z.squaredNorm();
  }
  // 60 degrees of freedom: mean 60, sd 11.
  EXPECT_GT(chi2, 60.0 - 4 * 11.0);
  EXPECT_LT(chi2, 60.0 + 4 * 11.0);
}

// The capture's on-the-spot checks of a tracker reading: its covariance is the first-order
// propagation of its Hz, V, d sigmas (against central differences), its largest sigma the
// largest of d sin V σ_Hz, d σ_V, σ_d, and two readings' disagreement Δᵀ(C_a+C_b)⁻¹Δ.
TEST(PolarChecks, CovarianceLargestSigmaAndDisagreementAgreeWithDirectComputation) {
  const AngleReading r{1.1, 1.3, 1};
  const double d = 2800.0;
  const PolarSigmas s{3e-6, 2e-6, 0.01};
  auto point = [](double hz, double v, double dist) {
    return PolarPoint(AngleReading{hz, v, 1}, dist);
  };
  Eigen::Matrix3d j;
  const double h = 1e-7;
  j.col(0) = (point(r.hz_rad + h, r.v_rad, d) - point(r.hz_rad - h, r.v_rad, d)) / (2 * h);
  j.col(1) = (point(r.hz_rad, r.v_rad + h, d) - point(r.hz_rad, r.v_rad - h, d)) / (2 * h);
  j.col(2) = (point(r.hz_rad, r.v_rad, d + 1e-3) - point(r.hz_rad, r.v_rad, d - 1e-3)) / 2e-3;
  const Eigen::Matrix3d expected =
      j * Eigen::Vector3d(s.hz_rad * s.hz_rad, s.v_rad * s.v_rad, s.distance_mm * s.distance_mm)
              .asDiagonal() *
      j.transpose();
  const Eigen::Matrix3d c = PolarCovariance(r, d, s);
  EXPECT_LT((c - expected).norm(), 1e-9 * expected.norm());
  EXPECT_NEAR(LargestSigmaMm(c),
              std::max({d * std::sin(r.v_rad) * s.hz_rad, d * s.v_rad, s.distance_mm}), 1e-12);
  // A face-II reading of the same direction is the same point and covariance.
  const AngleReading face2{r.hz_rad + kPi, 2 * kPi - r.v_rad, 2};
  EXPECT_LT((PolarPoint(face2, d) - PolarPoint(r, d)).norm(), 1e-9);
  // Δ along an eigenvector of C_a + C_b = 2C: √(Δᵀ(2C)⁻¹Δ) = |Δ| / √(2λ).
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(c);
  const Eigen::Vector3d delta = 0.05 * eig.eigenvectors().col(1);
  EXPECT_NEAR(NormalisedDisagreement(PolarPoint(r, d) + delta, c, PolarPoint(r, d), c),
              0.05 / std::sqrt(2.0 * eig.eigenvalues()(1)), 1e-9);
}

}  // namespace armsig::reduction

namespace armsig::reduction {

// The set-up is the orientation, and snoops as it does (reduction/data_snooping.h): a wrong
// distance, a mis-pointed reading or a control point typed 5 mm off is removed, named, and
// the pose comes back within its sigmas.
TEST(TrackerSetUp, ABlunderInItsReadingsOrItsControlIsRemovedAndNamed) {
  using Kind = ResidualReport::Kind;
  for (int blunder = 0; blunder < 3; ++blunder) {
    auto [truth, p] = MakeControlSetUp(31 + blunder, 6, 0.3);
    Kind kind = Kind::kDistance;
    if (blunder == 0) *p.observations[2].distance_mm += 2.0;  // 100 σ
    if (blunder == 1) {
      p.observations[2].reading.hz_rad += 0.01;  // 0.64 gon
      kind = Kind::kHz;
    }
    if (blunder == 2) {
      p.control[2].position_mm.x() += 5.0;
      kind = Kind::kControl;
    }
    const OrientationResult r = Orient(p);
    ASSERT_TRUE(r.status.ok()) << r.status.message;
    ASSERT_FALSE(r.removed.empty()) << blunder;
    EXPECT_EQ(r.removed[0].kind, kind) << blunder;
    EXPECT_EQ(r.removed[0].observation, 2) << blunder;
    EXPECT_TRUE(r.undecided.empty()) << blunder;
    const Station& s = r.stations[0];
    const Eigen::Vector3d z =
        (s.pose.position_mm - truth.pose.position_mm).cwiseQuotient(s.sigma_position_mm);
    EXPECT_LT(z.cwiseAbs().maxCoeff(), 4.5) << blunder;
    const Eigen::AngleAxisd error(s.pose.world_from_station.transpose() *
                                  truth.pose.world_from_station);
    EXPECT_LT(error.angle(), 4.5 * s.sigma_rotation_rad.norm()) << blunder;
  }
}

}  // namespace armsig::reduction
