// ISO 9283 geometry and figures against independent computations: cycles constructed so
// that the barycentre and every distance l_j are known exactly, Gaussian cycles checked
// against a separate long-double computation, the cube's points against its definition.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "calibration/iso9283_cube.h"
#include "calibration/iso9283_figures.h"
#include "calibration/pose_solver.h"
#include "core/units.h"
#include "test_support.h"

namespace armsig::calibration::iso9283 {
namespace {

TEST(Iso9283Cube, TestPointsLieOnTheMeasuringPlaneAtATenthOfTheDiagonal) {
  const TestCube cube{{600.0, -150.0, 400.0}, 500.0};
  const auto c = CubeCorners(cube);
  // C1…C4 on top, C(k+4) straight below Ck, every edge 500 mm.
  for (int k = 0; k < 4; ++k) {
    EXPECT_NEAR(c[k].z() - cube.centre_mm.z(), 250.0, 1e-12);
    EXPECT_NEAR((c[k] - c[k + 4] - Eigen::Vector3d(0, 0, 500)).norm(), 0.0, 1e-12);
    EXPECT_NEAR((c[k] - c[(k + 1) % 4]).norm(), 500.0, 1e-12);
  }
  // C1–C2–C7–C8 is a plane through the centre holding the top edge at −y and the bottom
  // edge at +y.
  const Eigen::Vector3d normal = (c[1] - c[0]).cross(c[7] - c[0]).normalized();
  EXPECT_NEAR(normal.dot(c[6] - c[0]), 0.0, 1e-9);
  EXPECT_NEAR(c[0].y(), cube.centre_mm.y() - 250.0, 1e-12);
  EXPECT_NEAR(c[7].y(), cube.centre_mm.y() + 250.0, 1e-12);
  const auto p = TestPoints(cube);
  EXPECT_EQ(p[0].name, "P1");
  EXPECT_NEAR((p[0].position_mm - cube.centre_mm).norm(), 0.0, 1e-12);
  const double diagonal = 500.0 * std::sqrt(3.0);  // C1–C7, a space diagonal
  EXPECT_NEAR((c[6] - c[0]).norm(), diagonal, 1e-9);
  // P2…P5 at 10 % of the diagonal from C1, C2, C7, C8, on the diagonal (the other
  // 90 % to the opposite corner), on the plane.
  const int corner[4] = {0, 1, 6, 7}, opposite[4] = {6, 7, 0, 1};
  for (int k = 0; k < 4; ++k) {
    const Eigen::Vector3d& x = p[k + 1].position_mm;
    EXPECT_EQ(p[k + 1].name, "P" + std::to_string(k + 2));
    EXPECT_NEAR((x - c[corner[k]]).norm(), 0.1 * diagonal, 1e-9);
    EXPECT_NEAR((x - c[opposite[k]]).norm(), 0.9 * diagonal, 1e-9);
    EXPECT_NEAR(normal.dot(x - c[0]), 0.0, 1e-9);
  }
  // The distance pairs are the diagonals: P2–P4 and P3–P5, 80 % of the diagonal long.
  for (const auto& pair : kDistancePairs)
    EXPECT_NEAR((p[pair.from].position_mm - p[pair.to].position_mm).norm(), 0.8 * diagonal, 1e-9);
  EXPECT_EQ(kDistancePairs[0].from, 1);
  EXPECT_EQ(kDistancePairs[0].to, 3);
  EXPECT_EQ((std::array<int, 5>{0, 4, 3, 2, 1}), kCycleOrder);  // P1 P5 P4 P3 P2
}

TEST(Iso9283Cube, LargestEdgeIsFoundByBisectionToTheTolerance) {
  int calls = 0;
  const auto reachable = [&](const TestCube& cube) {
    ++calls;
    return cube.edge_mm <= 123.4;
  };
  const double edge = LargestCubeEdge({0, 0, 0}, reachable, 10.0, 4000.0, 0.5);
  EXPECT_LE(edge, 123.4);
  EXPECT_GT(edge, 123.4 - 0.5);
  EXPECT_LT(calls, 20);
  EXPECT_EQ(LargestCubeEdge(
                {0, 0, 0}, [](const TestCube&) { return false; }, 10, 100, 1),
            0.0);
  EXPECT_EQ(LargestCubeEdge(
                {0, 0, 0}, [](const TestCube&) { return true; }, 10, 100, 1),
            100.0);
}

// Cycles whose barycentre is exactly `centre` and whose distances from it are exactly
// `l`: each distance twice, in opposite directions, along axes that differ per pair.
PointData Constructed(const Eigen::Vector3d& commanded, const Eigen::Vector3d& centre,
                      const std::vector<double>& l) {
  PointData p{"P1", commanded, std::nullopt, {}};
  int cycle = 1;
  for (size_t k = 0; k < l.size(); ++k) {
    const Eigen::Vector3d u = Eigen::Vector3d::Unit(k % 3);
    p.samples.push_back({cycle++, 0, centre + l[k] * u, std::nullopt});
    p.samples.push_back({cycle++, 0, centre - l[k] * u, std::nullopt});
  }
  return p;
}

TEST(Iso9283Figures, ApAndRpOfCyclesWithAKnownBarycentreAndSpread) {
  const Eigen::Vector3d commanded(1000.0, 200.0, 500.0);
  const Eigen::Vector3d offset(0.30, -0.40, 1.20);  // the barycentre's error: |offset| = 1.3
  // l_j = 0.01, 0.01, 0.03, 0.03 mm: l̄ = 0.02, Σ(l − l̄)² = 4e-4.
  const auto f = EvaluatePoint(Constructed(commanded, commanded + offset, {0.01, 0.03}));
  EXPECT_EQ(f.n, 4);
  EXPECT_NEAR((f.barycentre_mm - commanded - offset).norm(), 0.0, 1e-12);
  EXPECT_NEAR(f.ap_xyz_mm.x(), 0.30, 1e-12);
  EXPECT_NEAR(f.ap_xyz_mm.y(), -0.40, 1e-12);
  EXPECT_NEAR(f.ap_xyz_mm.z(), 1.20, 1e-12);
  EXPECT_NEAR(f.ap_mm, 1.3, 1e-12);
  EXPECT_NEAR(f.mean_l_mm, 0.02, 1e-12);
  // S_l on n − 1 = 3: √(4e-4 / 3) = 0.011547 (on n it would be 0.01, RP 0.05).
  EXPECT_NEAR(f.s_l_mm, std::sqrt(4e-4 / 3.0), 1e-12);
  EXPECT_NEAR(f.rp_mm, 0.02 + 3.0 * std::sqrt(4e-4 / 3.0), 1e-12);
  EXPECT_GT(f.rp_mm, 0.05 + 1e-3);
  EXPECT_NEAR(PoseRepeatability([&] {
                std::vector<Eigen::Vector3d> x;
                for (const auto& s : Constructed(commanded, commanded, {0.01, 0.03}).samples)
                  x.push_back(s.position_mm);
                return x;
              }()),
              f.rp_mm, 1e-12);
  // Equal distances: S_l = 0 and RP = l̄.
  const auto g = EvaluatePoint(Constructed(commanded, commanded, {0.05, 0.05, 0.05}));
  EXPECT_NEAR(g.s_l_mm, 0.0, 1e-12);
  EXPECT_NEAR(g.rp_mm, 0.05, 1e-12);
  EXPECT_NEAR(g.ap_mm, 0.0, 1e-12);
  // One cycle: AP, but no repeatability.
  PointData one{"P2", commanded, std::nullopt, {{1, 0, commanded + offset, std::nullopt}}};
  const auto h = EvaluatePoint(one);
  EXPECT_NEAR(h.ap_mm, 1.3, 1e-12);
  EXPECT_TRUE(std::isnan(h.rp_mm));
}

TEST(Iso9283Figures, GaussianCyclesMatchAnIndependentComputation) {
  std::mt19937 rng(42);
  std::normal_distribution<double> noise(0.0, 0.03);
  const Eigen::Vector3d commanded(812.5, -40.0, 933.0),
      truth = commanded + Eigen::Vector3d(0.8, 0.1, -0.5);
  PointData p{"P3", commanded, std::nullopt, {}};
  for (int j = 1; j <= 30; ++j)
    p.samples.push_back(
        {j, 0, truth + Eigen::Vector3d(noise(rng), noise(rng), noise(rng)), std::nullopt});
  const auto f = EvaluatePoint(p);
  // Written out in long double, with S_l from Σl² − n·l̄² (another formula for the same sum).
  long double b[3] = {0, 0, 0};
  for (const auto& s : p.samples)
    for (int k = 0; k < 3; ++k) b[k] += static_cast<long double>(s.position_mm(k)) / 30.0L;
  long double sum_l = 0, sum_l2 = 0;
  for (const auto& s : p.samples) {
    long double d2 = 0;
    for (int k = 0; k < 3; ++k) d2 += (s.position_mm(k) - b[k]) * (s.position_mm(k) - b[k]);
    sum_l += std::sqrt(d2);
    sum_l2 += d2;
  }
  const long double mean_l = sum_l / 30.0L;
  const long double s_l = std::sqrt((sum_l2 - 30.0L * mean_l * mean_l) / 29.0L);
  long double ap2 = 0;
  for (int k = 0; k < 3; ++k) {
    EXPECT_NEAR(f.ap_xyz_mm(k), static_cast<double>(b[k] - commanded(k)), 1e-10);
    ap2 += (b[k] - commanded(k)) * (b[k] - commanded(k));
  }
  EXPECT_NEAR(f.ap_mm, static_cast<double>(std::sqrt(ap2)), 1e-10);
  EXPECT_NEAR(f.mean_l_mm, static_cast<double>(mean_l), 1e-12);
  EXPECT_NEAR(f.s_l_mm, static_cast<double>(s_l), 1e-10);
  EXPECT_NEAR(f.rp_mm, static_cast<double>(mean_l + 3 * s_l), 1e-10);
  // And the barycentre is the truth within its own sampling spread (σ/√30 per axis).
  EXPECT_LT((f.barycentre_mm - truth).cwiseAbs().maxCoeff(), 4 * 0.03 / std::sqrt(30.0));
}

TEST(Iso9283Figures, OrientationAccuracyAndRepeatabilityAcrossTheHalfTurn) {
  // c commanded at 179.9°: the attained angles cross ±180°, which must not matter.
  const Eigen::Vector3d commanded_abc = Eigen::Vector3d(10.0, -5.0, 179.9) * kRadPerDeg;
  const Eigen::Vector3d bias = Eigen::Vector3d(0.02, -0.01, 0.15) * kRadPerDeg;
  const double e[4] = {0.010, -0.010, 0.030, -0.030};  // deg; Σe = 0, Σe² = 0.002
  PointData p{"P1", Eigen::Vector3d::Zero(), commanded_abc, {}};
  for (int j = 0; j < 4; ++j) {
    Eigen::Vector3d abc = commanded_abc + bias + Eigen::Vector3d::Constant(e[j] * kRadPerDeg);
    abc(2) = WrapPi(abc(2));  // 180.05° is written as −179.95°
    p.samples.push_back({j + 1, 0, Eigen::Vector3d::Zero(), abc});
  }
  const auto f = EvaluatePoint(p);
  ASSERT_TRUE(f.ap_abc_rad && f.rp_abc_rad);
  for (int k = 0; k < 3; ++k) {
    EXPECT_NEAR((*f.ap_abc_rad)(k), bias(k), 1e-12);
    EXPECT_NEAR((*f.rp_abc_rad)(k), 3.0 * std::sqrt(0.002 / 3.0) * kRadPerDeg, 1e-12);
  }
  // Without a commanded orientation: the spread only.
  p.commanded_orientation_rad.reset();
  const auto g = EvaluatePoint(p);
  EXPECT_FALSE(g.ap_abc_rad);
  ASSERT_TRUE(g.rp_abc_rad);
  EXPECT_NEAR((*g.rp_abc_rad)(2), (*f.rp_abc_rad)(2), 1e-12);
}

TEST(Iso9283Figures, DistanceAccuracyAndRepeatabilityPairTheCycles) {
  const Eigen::Vector3d u = Eigen::Vector3d(1.0, 2.0, -2.0).normalized();
  const double commanded_distance = 692.82;
  PointData a{"P2", Eigen::Vector3d(100, 100, 100), std::nullopt, {}};
  PointData b{"P4", a.commanded_mm + commanded_distance * u, std::nullopt, {}};
  // D_j = D_c + 0.05 + δ_j with δ = ±0.02, ±0.04: D̄ − D_c = 0.05, S_D = √(0.004/3).
  const double delta[4] = {0.02, -0.02, 0.04, -0.04};
  for (int j = 0; j < 4; ++j) {
    const Eigen::Vector3d start = a.commanded_mm + Eigen::Vector3d(0.1 * j, -0.05 * j, 0.02);
    a.samples.push_back({j + 1, 0, start, std::nullopt});
    b.samples.push_back(
        {j + 1, 0, start + (commanded_distance + 0.05 + delta[j]) * u, std::nullopt});
  }
  std::swap(b.samples[0], b.samples[3]);                      // paired by cycle, not by order
  a.samples.push_back({9, 0, a.commanded_mm, std::nullopt});  // cycle 9: P4 missing, not paired
  const auto d = EvaluateDistance(a, b);
  ASSERT_TRUE(d);
  EXPECT_EQ(d->n, 4);
  EXPECT_NEAR(d->commanded_mm, commanded_distance, 1e-9);
  EXPECT_NEAR(d->ad_mm, 0.05, 1e-9);
  EXPECT_NEAR(d->s_d_mm, std::sqrt(0.004 / 3.0), 1e-9);
  EXPECT_NEAR(d->rd_mm, 3.0 * std::sqrt(0.004 / 3.0), 1e-9);
  PointData none{"P5",
                 Eigen::Vector3d::Zero(),
                 std::nullopt,
                 {{42, 0, Eigen::Vector3d::Zero(), std::nullopt}}};
  EXPECT_FALSE(EvaluateDistance(a, none));
}

TEST(Iso9283Figures, VapIsTheLargestDistanceBetweenTheApproachBarycentres) {
  PointData p{"P1", Eigen::Vector3d::Zero(), std::nullopt, {}};
  const Eigen::Vector3d centre[3] = {{0.0, 0.0, 0.0}, {0.03, 0.04, 0.0}, {0.0, -0.02, 0.0}};
  for (int k = 0; k < 3; ++k) {
    for (int j = 1; j <= 4; ++j) {
      const Eigen::Vector3d scatter = (j % 2 ? 0.01 : -0.01) * Eigen::Vector3d::Unit(j % 3);
      p.samples.push_back({j, k + 1, centre[k] + scatter, std::nullopt});
      p.samples.push_back({j + 10, k + 1, centre[k] - scatter, std::nullopt});
    }
  }
  const auto f = EvaluatePoint(p);
  ASSERT_TRUE(f.vap_mm);
  EXPECT_EQ(f.approaches, 3);
  EXPECT_NEAR(*f.vap_mm, std::hypot(0.03, 0.06), 1e-12);  // between centres 2 and 3
  PointData single{
      "P2", Eigen::Vector3d::Zero(), std::nullopt, {{1, 0, Eigen::Vector3d::Zero(), std::nullopt}}};
  EXPECT_FALSE(EvaluatePoint(single).vap_mm);
}

TEST(Iso9283Figures, BootstrapIntervalIsDeterministicAndNarrowsWithMoreCycles) {
  std::mt19937 rng(3);
  std::normal_distribution<double> noise(0.0, 0.03);
  auto draw = [&](int n) {
    std::vector<Eigen::Vector3d> x;
    for (int j = 0; j < n; ++j) x.emplace_back(noise(rng), noise(rng), noise(rng));
    return x;
  };
  const auto thirty = draw(30);
  const auto a = BootstrapRpInterval(thirty, 1000, 0.95, 5);
  const auto b = BootstrapRpInterval(thirty, 1000, 0.95, 5);
  ASSERT_TRUE(a && b);
  EXPECT_EQ(a->lo, b->lo);
  EXPECT_EQ(a->hi, b->hi);
  EXPECT_LT(a->lo, PoseRepeatability(thirty));
  EXPECT_GT(a->hi, PoseRepeatability(thirty));
  const auto wide = BootstrapRpInterval(draw(480), 1000, 0.95, 5);
  ASSERT_TRUE(wide);
  // Sixteen times the cycles: about a quarter of the width.
  const double ratio = (wide->hi - wide->lo) / (a->hi - a->lo);
  EXPECT_GT(ratio, 0.12);
  EXPECT_LT(ratio, 0.45);
  EXPECT_FALSE(BootstrapRpInterval(draw(2)));
}

TEST(Iso9283Figures, BootstrapIntervalCoversTheRepeatabilityOfTheDistribution) {
  // For a 3-D N(0, σ²) the distance from the mean is σ·χ3: E = 2σ√(2/π), var = σ²(3 − 8/π);
  // the population's RP is E + 3·SD = 3.6161 σ. A 90 % interval from 30 cycles should cover
  // it in most of 120 repetitions (a percentile bootstrap of a skewed statistic covers a
  // little less than it claims).
  const double sigma = 0.03;
  const double rp = sigma * (2 * std::sqrt(2 / kPi) + 3 * std::sqrt(3 - 8 / kPi));
  std::mt19937 rng(11);
  std::normal_distribution<double> noise(0.0, sigma);
  int covered = 0;
  for (int r = 0; r < 120; ++r) {
    std::vector<Eigen::Vector3d> x;
    for (int j = 0; j < 30; ++j) x.emplace_back(noise(rng), noise(rng), noise(rng));
    const auto i = BootstrapRpInterval(x, 400, 0.90, 100 + r);
    covered += i->lo <= rp && rp <= i->hi;
  }
  EXPECT_GE(covered, 90);  // ≥ 75 %
}

TEST(Iso9283Figures, RigidAlignmentRecoversAPlantedFrameAndTurnsOrientations) {
  Eigen::Isometry3d measuring_from_robot = Eigen::Isometry3d::Identity();
  measuring_from_robot.translate(Eigen::Vector3d(2300.0, -900.0, 410.0));
  measuring_from_robot.rotate(Eigen::AngleAxisd(2.1, Eigen::Vector3d(0.1, 0.2, 1.0).normalized()));
  const auto points = TestPoints({{700.0, 100.0, 600.0}, 400.0});
  std::vector<Eigen::Vector3d> commanded, attained;
  for (const auto& p : points) {
    commanded.push_back(p.position_mm);
    attained.push_back(measuring_from_robot * p.position_mm);
  }
  const auto fit = AlignRigidly(attained, commanded);
  ASSERT_TRUE(fit);
  EXPECT_LT(fit->rms_mm, 1e-9);
  EXPECT_TRUE(fit->commanded_from_attained.isApprox(measuring_from_robot.inverse(), 1e-12));
  // An orientation measured in the measuring frame comes back as commanded.
  const Eigen::Vector3d abc = Eigen::Vector3d(30.0, -20.0, 100.0) * kRadPerDeg;
  EXPECT_TRUE(AbcFromRotation(RotationFromAbc(abc)).isApprox(abc, 1e-12));
  PointData p{"P1", commanded[0], abc, {}};
  p.samples.push_back(
      {1, 0, attained[0], AbcFromRotation(measuring_from_robot.linear() * RotationFromAbc(abc))});
  TransformSamples(p, fit->commanded_from_attained);
  EXPECT_LT((p.samples[0].position_mm - commanded[0]).norm(), 1e-9);
  EXPECT_TRUE(p.samples[0].orientation_rad->isApprox(abc, 1e-9));
  // Three points on a line fix no frame.
  EXPECT_FALSE(AlignRigidly({{0, 0, 0}, {1, 0, 0}, {2, 0, 0}}, {{0, 0, 0}, {1, 0, 0}, {2, 0, 0}}));
}

}  // namespace
}  // namespace armsig::calibration::iso9283

namespace armsig::calibration {
namespace {

TEST(PoseSolver, ReachesAPositionAndAnOrientationOfTheNominalPuma) {
  const auto model = testing::Puma();
  const Eigen::VectorXd zero = Eigen::VectorXd::Zero(model.num_parameters());
  Eigen::VectorXd truth(6);
  truth << 0.3, -0.5, 1.4, 0.4, -0.7, 0.9;
  Kinematics kin(model);
  const Eigen::Vector3d x = kin.Position(Eigen::Isometry3d::Identity(), zero, truth.data());
  const Eigen::Matrix3d r = kin.LastRotation();
  Eigen::VectorXd seed = truth + Eigen::VectorXd::Constant(6, 0.15);
  const auto s = SolvePose(model, Eigen::Isometry3d::Identity(), zero, x, r, seed);
  ASSERT_TRUE(s.status.ok()) << s.status.message;
  EXPECT_LT((kin.Position(Eigen::Isometry3d::Identity(), zero, s.joints_rad.data()) - x).norm(),
            1e-5);
  EXPECT_LT(Eigen::AngleAxisd(kin.LastRotation() * r.transpose()).angle(), 1e-8);
  // The joint axes are what the orientation turns about: a finite difference of the last
  // frame by each joint is the axis (as a rotation vector), to first order.
  const auto axes = [&] {
    kin.Position(Eigen::Isometry3d::Identity(), zero, truth.data());
    return Eigen::Matrix<double, 3, Eigen::Dynamic>(kin.JointAxes());
  }();
  for (int i = 0; i < 6; ++i) {
    Eigen::VectorXd q = truth;
    q(i) += 1e-6;
    kin.Position(Eigen::Isometry3d::Identity(), zero, q.data());
    const Eigen::AngleAxisd turn(kin.LastRotation() * r.transpose());
    EXPECT_LT((turn.angle() * turn.axis() / 1e-6 - axes.col(i)).norm(), 1e-5) << "joint " << i + 1;
  }
  // Out of reach: 5 m away.
  const auto far =
      SolvePose(model, Eigen::Isometry3d::Identity(), zero, Eigen::Vector3d(5000, 0, 0), r, seed);
  EXPECT_EQ(far.status.code, SolveCode::kNotConverged);
}

}  // namespace
}  // namespace armsig::calibration
