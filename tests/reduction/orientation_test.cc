#include "reduction/orientation.h"

#include <gtest/gtest.h>

#include "reduction/intersection.h"
#include "reduction/sim_lab.h"

namespace armsig::reduction {

using testing::SimLab;

namespace {

// The truth in the datum of docs/reference/conventions.md: the first station's frame
// (origin, circle zero = +y).
struct DatumFrame {
  Eigen::Vector3d origin;
  Eigen::Matrix3d datum_from_world;
  double azimuth;
  explicit DatumFrame(const Station& first)
      : origin(first.pose.position_mm),
        datum_from_world(first.pose.world_from_station.transpose()),
        azimuth(first.pose.azimuth_rad) {}
  Eigen::Vector3d operator()(const Eigen::Vector3d& x) const {
    return datum_from_world * (x - origin);
  }
};

// A lab where every station sights every other (mutual pointings) and 30 targets, and
// a 1 m scale bar set up at four places.
OrientationProblem MutualLab(SimLab& lab, std::vector<Eigen::Vector3d>& bar_ends) {
  OrientationProblem p;
  for (const auto& s : lab.stations) p.station_ids.push_back(s.pose.id);
  const int ns = static_cast<int>(lab.stations.size());
  for (int i = 0; i < ns; ++i) {
    for (int j = 0; j < ns; ++j) {
      if (i != j)
        p.observations.push_back(
            lab.ObserveTo(i, lab.stations[j].pose.id, lab.stations[j].pose.position_mm));
    }
  }
  for (int k = 0; k < 30; ++k) {
    const Eigen::Vector3d t = lab.RandomTarget();
    lab.targets.push_back(t);
    for (int i = 0; i < ns; ++i)
      p.observations.push_back(lab.ObserveTo(i, "T" + std::to_string(k), t));
  }
  for (int b = 0; b < 4; ++b) {
    const Eigen::Vector3d a = lab.RandomTarget();
    Eigen::Vector3d dir = Eigen::Vector3d::Random().normalized();
    const Eigen::Vector3d c = a + 1000.0 * dir;
    bar_ends.push_back(a);
    bar_ends.push_back(c);
    const std::string ia = "B" + std::to_string(b) + "a", ic = "B" + std::to_string(b) + "c";
    for (int i = 0; i < ns; ++i) {
      p.observations.push_back(lab.ObserveTo(i, ia, a));
      p.observations.push_back(lab.ObserveTo(i, ic, c));
    }
    p.scale_bars.push_back({ia, ic, 1000.0, 0.002});
  }
  return p;
}

}  // namespace

TEST(Orientation, MutualPointingsAndScaleBarReproduceTheStationsWithinTheirPrecision) {
  double worst = 0.0;
  for (unsigned seed : {1u, 2u, 3u, 4u}) {
    SimLab lab(3, seed);
    std::vector<Eigen::Vector3d> bars;
    const auto problem = MutualLab(lab, bars);
    const auto r = Orient(problem);
    ASSERT_TRUE(r.status.ok()) << (r.refusals.empty() ? "" : r.refusals[0]);
    const DatumFrame datum(lab.stations[0]);
    for (int s = 1; s < 3; ++s) {
      const Eigen::Vector3d truth = datum(lab.stations[s].pose.position_mm);
      for (int k = 0; k < 3; ++k) {
        const double z =
            (r.stations[s].pose.position_mm(k) - truth(k)) / r.stations[s].sigma_position_mm(k);
        worst = std::max(worst, std::abs(z));
      }
      const double az = WrapPi(r.stations[s].pose.azimuth_rad -
                               (lab.stations[s].pose.azimuth_rad - datum.azimuth));
      worst = std::max(worst, std::abs(az / r.stations[s].sigma_azimuth_rad));
    }
    EXPECT_NEAR(r.sigma0, 1.0, 0.25);
    // Every target within 4σ too.
    for (const auto& p : r.points) {
      if (p.id[0] != 'T') continue;
      const Eigen::Vector3d e = p.position_mm - datum(lab.targets[std::stoi(p.id.substr(1))]);
      EXPECT_LT(e.dot(p.covariance_mm2.inverse() * e), 25.0) << p.id;
    }
  }
  EXPECT_LT(worst, 4.0);
}

TEST(Orientation, UnlevelledStationRotationIsRecovered) {
  SimLab lab(3, 11);
  // Station 3 tilted by about 2.5°: its rotation is free.
  Station& tilted = lab.stations[2];
  tilted.pose.levelled = false;
  tilted.pose.world_from_station = (Eigen::AngleAxisd(0.03, Eigen::Vector3d::UnitX()) *
                                    Eigen::AngleAxisd(-0.025, Eigen::Vector3d::UnitY()))
                                       .toRotationMatrix() *
                                   tilted.pose.world_from_station;
  std::vector<Eigen::Vector3d> bars;
  auto problem = MutualLab(lab, bars);
  problem.unlevelled.insert(tilted.pose.id);
  const auto r = Orient(problem);
  ASSERT_TRUE(r.status.ok());
  const DatumFrame datum(lab.stations[0]);
  const Eigen::Matrix3d truth = datum.datum_from_world * tilted.pose.world_from_station;
  const Eigen::AngleAxisd error(r.stations[2].pose.world_from_station.transpose() * truth);
  EXPECT_FALSE(r.stations[2].pose.levelled);
  EXPECT_LT(error.angle(), 4.0 * r.stations[2].sigma_rotation_rad.norm());
  EXPECT_LT((r.stations[2].pose.position_mm - datum(tilted.pose.position_mm)).norm(),
            4.0 * r.stations[2].sigma_position_mm.norm());
}

TEST(Orientation, LaserTrackerDistancesGiveTheScaleWithoutBars) {
  SimLab lab(3, 5);
  OrientationProblem p;
  std::normal_distribution<double> noise(0.0, 0.01);
  for (const auto& s : lab.stations) p.station_ids.push_back(s.pose.id);
  for (int k = 0; k < 25; ++k) {
    const Eigen::Vector3d t = lab.RandomTarget();
    lab.targets.push_back(t);
    for (int i = 0; i < 3; ++i) {
      auto o = lab.ObserveTo(i, "T" + std::to_string(k), t);
      if (i == 0) {  // station 1 is a laser tracker
        o.distance_mm = (t - lab.stations[0].pose.position_mm).norm() + noise(lab.rng);
        o.sigma_distance_mm = 0.01;
      }
      p.observations.push_back(o);
    }
  }
  const auto r = Orient(p);
  ASSERT_TRUE(r.status.ok()) << (r.refusals.empty() ? "" : r.refusals[0]);
  const DatumFrame datum(lab.stations[0]);
  for (int s = 1; s < 3; ++s) {
    EXPECT_LT((r.stations[s].pose.position_mm - datum(lab.stations[s].pose.position_mm)).norm(),
              4.0 * r.stations[s].sigma_position_mm.norm());
  }
  bool has_distance_group = false;
  for (const auto& g : r.groups) has_distance_group |= g.group == "distances";
  EXPECT_TRUE(has_distance_group);
}

TEST(Orientation, PlantedBlunderStandsOutInTheResidualsAndIsRemoved) {
  SimLab lab(3, 8);
  std::vector<Eigen::Vector3d> bars;
  auto problem = MutualLab(lab, bars);
  problem.observations[20].reading.hz_rad += 25.0 * kRadPerArcsec;  // 50 σ
  OrientationOptions test_only;
  test_only.snooping.reject = false;
  const auto tested = Orient(problem, test_only);
  ASSERT_TRUE(tested.status.ok());
  const ResidualReport* worst = nullptr;
  for (const auto& res : tested.residuals) {
    if (!worst || std::abs(res.w) > std::abs(worst->w)) worst = &res;
  }
  EXPECT_EQ(worst->observation, 20);
  EXPECT_EQ(worst->kind, ResidualReport::Kind::kHz);
  EXPECT_GT(std::abs(worst->w), tested.levels.critical_w);
  EXPECT_TRUE(tested.removed.empty());
  // Snooping removes it, and only it; its estimated error is the planted 25″.
  const auto r = Orient(problem);
  ASSERT_TRUE(r.status.ok());
  ASSERT_EQ(r.removed.size(), 1u);
  EXPECT_EQ(r.removed[0].observation, 20);
  EXPECT_EQ(r.removed[0].kind, ResidualReport::Kind::kHz);
  EXPECT_NEAR(r.removed[0].error, 25.0, 2.0);  // ± a few σ of 0.5″
  EXPECT_EQ(r.dof, tested.dof - 1);
}

TEST(Orientation, RefusesANetworkWithoutScale) {
  SimLab lab;
  std::vector<Eigen::Vector3d> bars;
  auto problem = MutualLab(lab, bars);
  problem.scale_bars.clear();
  const auto r = Orient(problem);
  EXPECT_FALSE(r.status.ok());
  ASSERT_FALSE(r.refusals.empty());
  EXPECT_NE(r.refusals[0].find("no scale"), std::string::npos);
}

TEST(Orientation, RefusesAStationWithTooFewRays) {
  SimLab lab(3, 9);
  std::vector<Eigen::Vector3d> bars;
  auto problem = MutualLab(lab, bars);
  std::vector<Observation> kept;
  int from_s3 = 0;
  for (const auto& o : problem.observations) {
    const bool touches_s3 = o.station == "S3" || o.point == "S3";
    if (touches_s3 && from_s3++ >= 1) continue;  // S3 keeps a single ray
    kept.push_back(o);
  }
  problem.observations = kept;
  const auto r = Orient(problem);
  EXPECT_FALSE(r.status.ok());
  std::string all;
  for (const auto& why : r.refusals) all += why + "\n";
  EXPECT_NE(all.find("station S3 has 1 rays"), std::string::npos) << all;
}

// Levelled stations, angles only, every target on one vertical line (a scale bar on
// it): a station can turn about the line with its azimuth compensating.
TEST(Orientation, RefusesTargetsAllOnOneLine) {
  SimLab lab(3, 12);
  OrientationProblem p;
  for (const auto& s : lab.stations) p.station_ids.push_back(s.pose.id);
  for (int k = 0; k < 6; ++k) {
    const Eigen::Vector3d t(100.0, -50.0, 300.0 * k);
    for (int i = 0; i < 3; ++i)
      p.observations.push_back(lab.ObserveTo(i, "P" + std::to_string(k), t));
  }
  p.scale_bars.push_back({"P0", "P5", 1500.0, 0.01});
  const auto r = Orient(p);
  EXPECT_FALSE(r.status.ok());
  std::string all;
  for (const auto& why : r.refusals) all += why + "\n";
  EXPECT_NE(all.find("one line"), std::string::npos) << all;
}

// With distances and mutual pointings the same kind of line is solvable: levelled
// instruments carry the vertical, the datum fixes the azimuth.
TEST(Orientation, LineOfTargetsWithDistancesAndMutualPointingsIsSolvable) {
  OrientationProblem p;
  p.station_ids = {"A", "B"};
  auto obs = [&](const std::string& s, const Eigen::Vector3d& from, const std::string& point,
                 const Eigen::Vector3d& to) {
    Observation o;
    o.station = s;
    o.point = point;
    o.reading = PredictReading(from, Eigen::Matrix3d::Identity(), to);
    o.distance_mm = (to - from).norm();
    p.observations.push_back(o);
  };
  const Eigen::Vector3d a(0, 0, 0), b(0, 5000, 0);
  obs("A", a, "B", b);
  obs("B", b, "A", a);
  for (int k = 1; k <= 3; ++k) {
    obs("A", a, "P" + std::to_string(k), Eigen::Vector3d(0, 1000.0 * k, 0));
    obs("B", b, "P" + std::to_string(k), Eigen::Vector3d(0, 1000.0 * k, 0));
  }
  const auto r = Orient(p);
  ASSERT_TRUE(r.status.ok());
  EXPECT_LT((r.stations[1].pose.position_mm - b).norm(), 1e-6);
}

}  // namespace armsig::reduction
