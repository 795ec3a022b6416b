// Rays at the zenith and the nadir (V = 0 or 200 gon), where Hz is undefined: the
// orientation used to crash (a Jacobian of NaN, then the failed evaluation's empty
// matrix indexed) on one such ray with a distance to a new point.
#include <ceres/jet.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "reduction/intersection.h"
#include "reduction/observation.h"
#include "reduction/orientation.h"
#include "reduction/sim_lab.h"

namespace armsig::reduction {
namespace {

using testing::SimLab;

// Three stations with mutual pointings, 20 targets and a distance-free scale bar.
OrientationProblem Network(SimLab& lab) {
  OrientationProblem p;
  for (const auto& s : lab.stations) p.station_ids.push_back(s.pose.id);
  const int ns = static_cast<int>(lab.stations.size());
  for (int i = 0; i < ns; ++i) {
    for (int j = 0; j < ns; ++j) {
      if (i != j) {
        p.observations.push_back(
            lab.ObserveTo(i, lab.stations[j].pose.id, lab.stations[j].pose.position_mm));
      }
    }
  }
  for (int k = 0; k < 20; ++k) {
    const Eigen::Vector3d t = lab.RandomTarget();
    for (int i = 0; i < ns; ++i)
      p.observations.push_back(lab.ObserveTo(i, "T" + std::to_string(k), t));
  }
  const Eigen::Vector3d a = lab.RandomTarget(), b = a + Eigen::Vector3d(1000.0, 0.0, 0.0);
  for (int i = 0; i < ns; ++i) {
    p.observations.push_back(lab.ObserveTo(i, "BA", a));
    p.observations.push_back(lab.ObserveTo(i, "BB", b));
  }
  p.scale_bars.push_back({"BA", "BB", 1000.0, 0.002});
  return p;
}

// One reading straight up (V = 0) or down (V = 200 gon) with a distance to a new point.
Observation PoleRay(const SimLab& lab, int station, double v_rad, double distance_mm) {
  Observation o;
  o.station = lab.stations[station].pose.id;
  o.point = "P";
  o.reading = {1.2345, v_rad, 1};  // Hz is whatever the circle shows: meaningless here
  o.distance_mm = distance_mm;
  o.sigma_hz_rad = o.sigma_v_rad = testing::kSigmaAngle;
  o.sigma_distance_mm = 0.01;
  return o;
}

TEST(PoleRays, OneZenithOrNadirRayWithADistanceGivesThePointOnTheStandingAxis) {
  for (const double v : {0.0, kPi}) {
    for (const int station : {0, 1}) {
      SimLab lab(3, 7);
      OrientationProblem problem = Network(lab);
      problem.observations.push_back(PoleRay(lab, station, v, 1500.0));
      const OrientationResult r = Orient(problem);
      ASSERT_TRUE(r.status.ok()) << "V = " << v << ", station " << station << ": "
                                 << r.status.message;
      const auto point = std::find_if(r.points.begin(), r.points.end(),
                                      [](const PointEstimate& p) { return p.id == "P"; });
      ASSERT_NE(point, r.points.end());
      // The station's standing axis is the adjusted frame's z axis (levelled stations): the
      // point lies 1500 mm above (zenith) or below (nadir) the adjusted station centre. The
      // ray has no redundancy, so it is met exactly.
      const Eigen::Vector3d expected =
          r.stations[station].pose.position_mm + Eigen::Vector3d(0, 0, v == 0.0 ? 1500.0 : -1500.0);
      EXPECT_LT((point->position_mm - expected).norm(), 1e-6) << point->position_mm.transpose();
      EXPECT_TRUE(point->covariance_mm2.allFinite());
    }
  }
}

TEST(PoleRays, ZenithRayAmongOthersIntersectsAtTheTruth) {
  // A target straight above station 0, seen from all three stations: the zenith ray holds
  // V only (its Hz is noise), the others fix the point.
  SimLab lab(3, 11);
  const Eigen::Vector3d target = lab.stations[0].pose.position_mm + Eigen::Vector3d(0, 0, 2000.0);
  std::vector<Ray> rays;
  for (int s = 0; s < 3; ++s) rays.push_back(lab.RayTo(s, target));
  rays[0].reading = {4.0, 0.0, 1};  // exactly at the zenith, any Hz
  const IntersectionResult r = Intersect(rays, IntersectionOptions{});
  ASSERT_TRUE(r.status.ok()) << r.status.message;
  // 0.5" noise at ~4 m: a few hundredths of a millimetre.
  EXPECT_LT((r.position_mm - target).norm(), 0.1);
  EXPECT_TRUE(r.covariance_mm2.allFinite());
}

TEST(PoleRays, PoleResidualIsTheAngleAcrossTheLineOfSight) {
  // Reading at V = 0 (any Hz), target 1e-4 rad off the axis towards the reading's e_v: the
  // residual is (0, 1e-4) to first order, where Hz/V residuals are undefined.
  const double hz = 0.7;
  const Eigen::Vector3d e_v(std::sin(hz), std::cos(hz), 0.0);
  const Eigen::Vector3d d = Eigen::Vector3d(0, 0, 1000.0) + 0.1 * e_v;
  const Eigen::Vector2d r = PoleResidual<double>(d, hz, 0.0);
  EXPECT_NEAR(r(0), 0.0, 1e-12);
  EXPECT_NEAR(r(1), 1e-4, 1e-10);
  EXPECT_TRUE(NearPole(0.0));
  EXPECT_TRUE(NearPole(kPi));
  EXPECT_FALSE(NearPole(ToRad(1.0, AngleUnit::kGon)));
}

// --- Nothing the data say may reach Ceres as a NaN or an abort.

TEST(PoleRays, HzVResidualHasFiniteDerivativesWhereThePredictionIsOnTheStandingAxis) {
  // The reading is an ordinary one (V = 60 gon); the prediction is straight up, where Hz has
  // no derivative. The equation must stay finite (it gave NaN, and Ceres stopped).
  using Jet = ceres::Jet<double, 3>;
  for (const Eigen::Vector3d& d :
       {Eigen::Vector3d(0, 0, 1500), Eigen::Vector3d(0, 0, -1500), Eigen::Vector3d(1e-9, 0, 2)}) {
    Eigen::Matrix<Jet, 3, 1> dj;
    for (int i = 0; i < 3; ++i) dj(i) = Jet(d(i), i);
    const auto r = AngleResidualOf(dj, 0.4, ToRad(60.0, AngleUnit::kGon));
    for (int k = 0; k < 2; ++k) {
      EXPECT_TRUE(std::isfinite(r(k).a)) << d.transpose();
      EXPECT_TRUE(r(k).v.allFinite()) << d.transpose() << ": " << r(k).v.transpose();
    }
  }
  // Near the observed direction it is still the Hz/V residual.
  const AngleReading reading{0.4, ToRad(60.0, AngleUnit::kGon), 1};
  const Eigen::Vector3d d = DirectionInStation(reading) * 2000.0 + Eigen::Vector3d(0.01, 0, 0);
  const Eigen::Vector2d a = AngleResidualOf<double>(d, reading.hz_rad, reading.v_rad);
  const Eigen::Vector2d hz_v = HzVOf<double>(d);
  EXPECT_NEAR(a(0), WrapPi(hz_v(0) - reading.hz_rad), 1e-15);
  EXPECT_NEAR(a(1), hz_v(1) - reading.v_rad, 1e-15);
}

TEST(PoleRays, ABlunderAtTheZenithOrNadirIsAdjustedAndNamedNotNaN) {
  // One ray of target T0 from station 1 read at V = 0 or 200 gon with a distance that does
  // not fit the target's other rays: the approximate T0 lies on the standing axis.
  for (const double v : {0.0, kPi}) {
    SimLab lab(3, 7);
    OrientationProblem problem = Network(lab);
    Observation blunder = PoleRay(lab, 1, v, 1500.0);
    blunder.point = "T0";
    problem.observations.push_back(blunder);
    const int planted = static_cast<int>(problem.observations.size()) - 1;
    // Tested only (no removal): adjusted without NaN, the blunder the largest residual.
    OrientationOptions test_only;
    test_only.snooping.reject = false;
    const OrientationResult tested = Orient(problem, test_only);
    ASSERT_TRUE(tested.status.ok()) << "V = " << v << ": " << tested.status.message;
    double worst = 0.0;
    for (const auto& res : tested.residuals) {
      if (res.observation == planted) worst = std::max(worst, std::abs(res.w));
    }
    EXPECT_GT(worst, tested.levels.critical_w) << "V = " << v;
    // Snooping removes it and names it.
    const OrientationResult r = Orient(problem);
    ASSERT_TRUE(r.status.ok()) << "V = " << v << ": " << r.status.message;
    bool named = false;
    for (const auto& m : r.removed) named |= m.observation == planted;
    EXPECT_TRUE(named) << "V = " << v;
    EXPECT_TRUE(r.undecided.empty()) << "V = " << v;
  }
}

TEST(PoleRays, ARepeatedSightingOfTheDatumStationOrients) {
  SimLab lab(3, 7);
  OrientationProblem problem = Network(lab);
  // Station 0 (the datum) sighted from station 1: the same observation twice.
  for (const auto& o : std::vector<Observation>(problem.observations)) {
    if (o.station == lab.stations[1].pose.id && o.point == lab.stations[0].pose.id) {
      problem.observations.push_back(o);
    }
  }
  const OrientationResult r = Orient(problem);
  ASSERT_TRUE(r.status.ok()) << r.status.message;
  // The result is in the datum of docs/reference/conventions.md: station 0's frame (its
  // centre the origin, its circle
  // zero the +y axis).
  const auto& first = lab.stations[0].pose;
  const Eigen::Vector3d truth = first.world_from_station.transpose() *
                                (lab.stations[1].pose.position_mm - first.position_mm);
  EXPECT_LT((r.stations[1].pose.position_mm - truth).norm(), 0.1);
}

TEST(PoleRays, ConstraintsOnOnePointAreRefusedNotAborted) {
  SimLab lab(3, 7);
  OrientationProblem problem = Network(lab);
  problem.scale_bars.push_back({"T1", "T1", 1000.0, 0.01});  // Ceres: duplicate blocks, abort
  OrientationResult r = Orient(problem);
  EXPECT_EQ(r.status.code, SolveCode::kDegenerate);
  EXPECT_NE(r.status.message.find("scale bar T1:T1: both ends are the same point"),
            std::string::npos)
      << r.status.message;

  problem = Network(lab);
  problem.scale_bars.clear();
  for (const char* id : {"T1", "T2", "T3"}) problem.control.push_back({id, {100, 200, 300}, {}});
  r = Orient(problem);
  EXPECT_EQ(r.status.code, SolveCode::kDegenerate);
  EXPECT_NE(r.status.message.find("control points all lie in one place"), std::string::npos)
      << r.status.message;

  problem = Network(lab);
  problem.control.push_back({"T1", {0, 0, 0}, {}});
  problem.control.push_back({"T1", {0, 0, 1}, {}});
  EXPECT_EQ(Orient(problem).status.code, SolveCode::kDegenerate);

  problem = Network(lab);
  problem.station_ids.insert(problem.station_ids.begin(), "NOBODY");  // a datum without rays
  r = Orient(problem);
  EXPECT_EQ(r.status.code, SolveCode::kDegenerate);
  EXPECT_NE(r.status.message.find("station NOBODY has no observations"), std::string::npos)
      << r.status.message;
}

}  // namespace
}  // namespace armsig::reduction
