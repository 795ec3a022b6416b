// ISO 9283 path characteristics against synthetic truth: attained cycles built from the
// command with planted offsets, crossings, corner cuts, overshoot bumps and speed profiles,
// the expected figures computed here from what was planted (RT in long double from the
// planted crossings), and the standard's test paths against the cube's definition.
#include "calibration/iso9283_path.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <random>
#include <stdexcept>
#include <string>

#include "calibration/iso9283_cube.h"
#include "core/units.h"

namespace armsig::calibration::iso9283 {
namespace {

// Samples along the polyline `points` (every point among them, at most `step_mm` apart),
// timed at the constant `speed_mm_s` from t = 0.
AttainedCycle PathWalk(const std::vector<Eigen::Vector3d>& points, double step_mm,
                       double speed_mm_s) {
  AttainedCycle cycle;
  double t = 0.0;
  cycle.samples.push_back({t, points.front()});
  for (size_t k = 0; k + 1 < points.size(); ++k) {
    const Eigen::Vector3d step = points[k + 1] - points[k];
    const int pieces = std::max(1, static_cast<int>(std::ceil(step.norm() / step_mm)));
    for (int i = 1; i <= pieces; ++i) {
      t += step.norm() / pieces / speed_mm_s;
      cycle.samples.push_back({t, points[k] + (static_cast<double>(i) / pieces) * step});
    }
  }
  return cycle;
}

// Two unit vectors perpendicular to `u` and to each other.
std::pair<Eigen::Vector3d, Eigen::Vector3d> PathNormals(const Eigen::Vector3d& u) {
  const Eigen::Vector3d n1 = u.unitOrthogonal();
  return {n1, u.cross(n1).normalized()};
}

TEST(Iso9283Path, ConstantOffsetCountsOnlyAcrossThePath) {
  const Eigen::Vector3d a(100, -50, 300), b(400, 250, 100);
  const Eigen::Vector3d u = (b - a).normalized();
  const auto [n1, n2] = PathNormals(u);
  // 2 mm along the path (a cycle late or early on its own path) and 0.5 mm across it.
  const Eigen::Vector3d across = 0.3 * n1 + 0.4 * n2;
  const Eigen::Vector3d offset = 2.0 * u + across;
  std::vector<AttainedCycle> cycles;
  for (int c = 0; c < 4; ++c) cycles.push_back(PathWalk({a + offset, b + offset}, 0.7, 100.0));
  const PathFigures f = EvaluatePath({{a, b}, 100.0}, cycles);
  EXPECT_EQ(f.n, 4);
  EXPECT_NEAR(f.length_mm, (b - a).norm(), 1e-9);
  // |b − a| = 469 mm, 10 % left out at either end: 375 mm at the default 1 mm spacing.
  EXPECT_EQ(f.plane_spacing_mm, 1.0);
  EXPECT_GE(f.planes_used, 370);
  EXPECT_EQ(f.planes_used, static_cast<int>(f.planes.size()));
  EXPECT_EQ(f.planes_skipped, 0);
  EXPECT_EQ(f.missed_crossings, 0);
  EXPECT_NEAR(f.at_mm, 0.5, 1e-9);  // |across|, not |offset| = 2.06 mm
  EXPECT_NEAR(f.mean_at_mm, 0.5, 1e-9);
  EXPECT_NEAR((f.at_xyz_mm - across).norm(), 0.0, 1e-9);
  ASSERT_GE(f.at_plane, 0);
  EXPECT_NEAR(f.planes[f.at_plane].at_mm, 0.5, 1e-9);
  for (const auto& plane : f.planes) {
    EXPECT_EQ(plane.n, 4);
    EXPECT_NEAR((plane.commanded_mm - (a + plane.s_mm * u)).norm(), 0.0, 1e-9);
    EXPECT_NEAR(plane.at_mm, 0.5, 1e-9);
  }
  EXPECT_NEAR(f.rt_mm, 0.0, 1e-9);  // every cycle the same
  EXPECT_TRUE(f.corners.empty());
}

TEST(Iso9283Path, RepeatabilityIsTheLargestOfThePlantedCrossingsLPlusThreeS) {
  const Eigen::Vector3d a(-120, 40, 250), u = Eigen::Vector3d(2, 1, -2) / 3.0;
  const Eigen::Vector3d b = a + 252.0 * u;
  const auto [n1, n2] = PathNormals(u);
  // 252 mm, 25.2 mm left out at either end, planes every 5 mm: s = 30, 35, …, 225.
  PathOptions options;
  options.plane_spacing_mm = 5.0;
  const int planes = 40, cycles_n = 8;
  std::mt19937 rng(7);
  std::normal_distribution<double> noise(0.0, 0.05);
  std::uniform_real_distribution<double> jitter(-0.5, 0.5);
  // planted[j][c]: cycle c's crossing of plane j, relative to the commanded point.
  std::vector<std::vector<Eigen::Vector3d>> planted(planes);
  std::vector<AttainedCycle> cycles(cycles_n);
  for (int c = 0; c < cycles_n; ++c) {
    // Samples every 2.5 mm: those at multiples of 5 mm lie in a plane position (their
    // offset is the crossing there), those between wander ±0.5 mm along the path too
    // and so cross no plane.
    for (int k = 0; k <= 100; ++k) {
      const double s = 2.5 * k;
      Eigen::Vector3d off = noise(rng) * n1 + noise(rng) * n2;
      if (k % 2 == 1) off += jitter(rng) * u;
      const int j = k / 2 - 6;
      if (k % 2 == 0 && j >= 0 && j < planes) planted[j].push_back(off);
      cycles[c].samples.push_back({0.025 * k, a + s * u + off});
    }
  }
  const PathFigures f = EvaluatePath({{a, b}, 100.0}, cycles, options);
  ASSERT_EQ(static_cast<int>(f.planes.size()), planes);
  EXPECT_EQ(f.plane_spacing_mm, 5.0);
  EXPECT_EQ(f.missed_crossings, 0);
  // Independently: per plane the barycentre, l_ij, l̄_j and S_lj on n − 1, in long double.
  long double rt_max = -1, at_max = -1;
  int rt_at = -1, at_at = -1;
  for (int j = 0; j < planes; ++j) {
    EXPECT_NEAR(f.planes[j].s_mm, 30.0 + 5.0 * j, 1e-9);
    long double mean[3] = {0, 0, 0};
    for (const auto& x : planted[j])
      for (int i = 0; i < 3; ++i) mean[i] += static_cast<long double>(x(i)) / cycles_n;
    const long double at = std::sqrt(mean[0] * mean[0] + mean[1] * mean[1] + mean[2] * mean[2]);
    std::vector<long double> l;
    for (const auto& x : planted[j]) {
      long double squares = 0;
      for (int i = 0; i < 3; ++i) squares += (x(i) - mean[i]) * (x(i) - mean[i]);
      l.push_back(std::sqrt(squares));
    }
    long double l_mean = 0, l_squares = 0;
    for (long double v : l) l_mean += v / cycles_n;
    for (long double v : l) l_squares += (v - l_mean) * (v - l_mean);
    const long double rt = l_mean + 3 * std::sqrt(l_squares / (cycles_n - 1));
    EXPECT_EQ(f.planes[j].n, cycles_n);
    EXPECT_NEAR(f.planes[j].rt_mm, static_cast<double>(rt), 1e-9);
    EXPECT_NEAR(f.planes[j].at_mm, static_cast<double>(at), 1e-9);
    if (rt > rt_max) {
      rt_max = rt;
      rt_at = j;
    }
    if (at > at_max) {
      at_max = at;
      at_at = j;
    }
  }
  EXPECT_NEAR(f.rt_mm, static_cast<double>(rt_max), 1e-9);
  EXPECT_EQ(f.rt_plane, rt_at);
  EXPECT_NEAR(f.at_mm, static_cast<double>(at_max), 1e-9);
  EXPECT_EQ(f.at_plane, at_at);
  EXPECT_GT(f.rt_mm, 0.1);  // the noise is there: σ = 0.05 mm per axis
}

TEST(Iso9283Path, CyclesThatStrayOrStopShortAreLeftOutOfThosePlanes) {
  const Eigen::Vector3d a(0, 0, 0), b(300.5, 0, 0), side(0, 25, 0);
  // Planes at s = 31, 32, …, 270 (30.05 mm left out at either end). Cycle 0 follows the path; cycle
  // 1 leaves it by 25 mm (beyond the 10 mm reach) from s = 100.25 to 150.25, so it misses planes
  // 101…150; cycle 2 stops at s = 180.4 and misses planes 181…270.
  const Eigen::Vector3d x1(100.25, 0, 0), x2(150.25, 0, 0), stop(180.4, 0, 0);
  const std::vector<AttainedCycle> cycles = {
      PathWalk({a, b}, 0.5, 100.0), PathWalk({a, x1, x1 + side, x2 + side, x2, b}, 0.5, 100.0),
      PathWalk({a, stop}, 0.5, 100.0)};
  const PathFigures f = EvaluatePath({{a, b}, 100.0}, cycles);
  ASSERT_EQ(f.planes.size(), 240u);
  int missed = 0;
  for (const auto& plane : f.planes) {
    const int expected = 3 - (plane.s_mm >= 101 && plane.s_mm <= 150) - (plane.s_mm > 180.4);
    EXPECT_EQ(plane.n, expected) << "plane at " << plane.s_mm << " mm";
    missed += 3 - expected;
    EXPECT_NEAR(plane.at_mm, 0.0, 1e-9);
  }
  EXPECT_EQ(missed, 50 + 90);
  EXPECT_EQ(f.missed_crossings, missed);
  EXPECT_EQ(f.planes_used, 240);
  EXPECT_EQ(f.planes_skipped, 0);
}

TEST(Iso9283Path, ALoopingCycleCountsItsCrossingNearestTheCommand) {
  // 0.2 mm beside the path along x, with two loops that cross planes 50…52 and 150…152
  // three times each: at 50 the nearest crossing (0.2 mm) is the first, later passes cross
  // 0.4…3 mm away; at 150 the first passes cross 0.4…2.4 mm away and the nearest is the
  // last. Every plane's crossing is then 0.2 mm beside its commanded point.
  auto at = [](double x, double y) { return Eigen::Vector3d(x, y, 0); };
  const std::vector<Eigen::Vector3d> walk = {
      at(0, 0.2),     at(49.6, 0.2),  at(52.6, 0.2),  at(49.6, 3.0),  at(52.9, 0.2),
      at(149.6, 0.2), at(152.6, 2.0), at(149.3, 2.5), at(149.6, 0.2), at(300.5, 0.2)};
  const std::vector<AttainedCycle> cycles(2, PathWalk(walk, 0.5, 100.0));
  const PathFigures f = EvaluatePath({{at(0, 0), at(300.5, 0)}, 100.0}, cycles);
  ASSERT_EQ(f.planes.size(), 240u);
  EXPECT_EQ(f.missed_crossings, 0);
  for (const auto& plane : f.planes)
    EXPECT_NEAR(plane.at_mm, 0.2, 1e-9) << "plane at " << plane.s_mm << " mm";
  EXPECT_NEAR(f.at_mm, 0.2, 1e-9);
  EXPECT_NEAR(f.rt_mm, 0.0, 1e-9);
}

TEST(Iso9283Path, ConcentricCircleGivesItsRadialOffsetWithinTheChordSag) {
  const TestCube cube{{600.0, -150.0, 400.0}, 300.0};
  const TestPaths paths = BuildTestPaths(cube);
  const Eigen::Vector3d centre = TestPoints(cube)[0].position_mm;
  const double r = 0.4 * cube.edge_mm, delta = 0.25;
  const double sag = r * (1.0 - std::cos(kPi / 360.0));  // 4.6 µm
  // The attained circle, 3,600 chords at r + δ, in the same plane and sense.
  std::vector<Eigen::Vector3d> attained;
  for (int k = 0; k <= 3600; ++k) {
    const Eigen::Vector3d on = paths.large_circle_mm[(k / 10) % 360] - centre;
    const Eigen::Vector3d next = paths.large_circle_mm[(k / 10) % 360 + 1] - centre;
    const double w = (k % 10) / 10.0;  // between two commanded vertices, on the arc
    const double angle = std::atan2(on.cross(next).norm(), on.dot(next)) * w;
    const Eigen::Vector3d axis = on.cross(next).normalized();
    attained.push_back(centre + (r + delta) / r * (Eigen::AngleAxisd(angle, axis) * on));
  }
  const std::vector<AttainedCycle> cycles = {PathWalk(attained, 1.0, 200.0),
                                             PathWalk(attained, 1.0, 200.0)};
  const PathFigures f = EvaluatePath({paths.large_circle_mm, 200.0}, cycles);
  EXPECT_TRUE(f.corners.empty());
  EXPECT_EQ(f.missed_crossings, 0);
  EXPECT_GE(f.planes_used, 20);
  EXPECT_NEAR(f.at_mm, delta, sag + 1e-4);
  EXPECT_GT(f.at_mm, delta - 1e-4);
  EXPECT_NEAR(f.rt_mm, 0.0, 1e-9);
}

TEST(Iso9283Path, CornerCutAndOvershootBumpOfARectangle) {
  const TestCube cube{{600.0, -150.0, 400.0}, 300.0};
  const std::vector<Eigen::Vector3d> rectangle = BuildTestPaths(cube).rectangle_mm;
  // At P3 (vertex 2, a right angle) cycle c cuts the corner from cut[c] mm before it to
  // cut[c] mm after it: a chamfer at cut / √2 from the corner (CR). Past it, from 10 to
  // 30 mm along the outgoing side, a bump outwards (along the incoming direction,
  // perpendicular to the outgoing side) bump[c] mm high at 20 mm (CO). The chamfer's own
  // points past the corner lie within cut / 2 of the outgoing side, under the bump.
  const double cut[3] = {2.0, 1.0, 0.0}, bump[3] = {1.5, 1.2, 0.9};
  const Eigen::Vector3d& p3 = rectangle[2];
  const Eigen::Vector3d in = (rectangle[2] - rectangle[1]).normalized();
  const Eigen::Vector3d out = (rectangle[3] - rectangle[2]).normalized();
  ASSERT_NEAR(in.dot(out), 0.0, 1e-12);
  std::vector<AttainedCycle> cycles;
  for (int c = 0; c < 3; ++c) {
    std::vector<Eigen::Vector3d> walk = {rectangle[0], rectangle[1]};
    if (cut[c] > 0) {
      walk.push_back(p3 - cut[c] * in);
      walk.push_back(p3 + cut[c] * out);
    } else {
      walk.push_back(p3);
    }
    walk.push_back(p3 + 10.0 * out);
    walk.push_back(p3 + 20.0 * out + bump[c] * in);
    walk.push_back(p3 + 30.0 * out);
    walk.insert(walk.end(), rectangle.begin() + 3, rectangle.end());
    cycles.push_back(PathWalk(walk, 0.5, 100.0));
  }
  const PathFigures f = EvaluatePath({rectangle, 100.0}, cycles);
  ASSERT_EQ(f.corners.size(), 4u);
  for (int k = 0; k < 4; ++k) {
    const CornerFigures& corner = f.corners[k];
    EXPECT_EQ(corner.vertex, k + 1);
    EXPECT_NEAR(corner.turn_rad, kPi / 2, 1e-9);
    ASSERT_EQ(corner.cr_mm.size(), 3u);
    ASSERT_EQ(corner.co_mm.size(), 3u);
    for (int c = 0; c < 3; ++c) {
      const bool planted = k == 1;
      EXPECT_NEAR(corner.cr_mm[c], planted ? cut[c] / std::sqrt(2.0) : 0.0, 1e-9)
          << "corner " << k << " cycle " << c;
      EXPECT_NEAR(corner.co_mm[c], planted ? bump[c] : 0.0, 1e-9)
          << "corner " << k << " cycle " << c;
    }
  }
  EXPECT_NEAR(f.corners[1].cr_max_mm, std::sqrt(2.0), 1e-9);
  EXPECT_NEAR(f.corners[1].co_max_mm, 1.5, 1e-9);
  EXPECT_NEAR((f.corners[1].corner_mm - p3).norm(), 0.0, 1e-12);
}

// The rectangle walked at uniform 0.5 mm steps, each step's time at `fast` mm/s but at
// `slow` within 15 mm of a vertex (the corners and the ends), where the robot brakes.
AttainedCycle PathRectangleAtSpeed(const std::vector<Eigen::Vector3d>& rectangle, double fast,
                                   double slow) {
  AttainedCycle cycle;
  double t = 0.0;
  cycle.samples.push_back({t, rectangle.front()});
  for (size_t k = 0; k + 1 < rectangle.size(); ++k) {
    const Eigen::Vector3d step = rectangle[k + 1] - rectangle[k];
    const double length = step.norm();
    const int pieces = static_cast<int>(std::ceil(length / 0.5));
    for (int i = 1; i <= pieces; ++i) {
      const double middle = (i - 0.5) * length / pieces;
      const bool braking = middle < 15.0 || length - middle < 15.0;
      t += length / pieces / (braking ? slow : fast);
      cycle.samples.push_back({t, rectangle[k] + (static_cast<double>(i) / pieces) * step});
    }
  }
  return cycle;
}

TEST(Iso9283Path, SpeedAccuracyOfAPlantedSteadySpeedLeavesOutTheBraking) {
  const TestCube cube{{600.0, -150.0, 400.0}, 300.0};
  const std::vector<Eigen::Vector3d> rectangle = BuildTestPaths(cube).rectangle_mm;
  const double vc = 200.0;
  // The corners' margins are 24 mm (10 % of the 240 mm sides), the ends' 116 mm: every
  // braking step lies in them.
  const std::vector<AttainedCycle> cycles(3, PathRectangleAtSpeed(rectangle, 1.02 * vc, 0.3 * vc));
  const PathFigures f = EvaluatePath({rectangle, vc}, cycles);
  EXPECT_NEAR(f.mean_speed_mm_s, 1.02 * vc, 1e-9);
  EXPECT_NEAR(f.av_percent, 2.0, 1e-9);
  EXPECT_NEAR(f.rv_percent, 0.0, 1e-9);
  EXPECT_NEAR(f.fv_mm_s, 0.0, 1e-9);
  ASSERT_EQ(f.speeds.size(), 3u);
  EXPECT_GT(f.speeds[0].count, 1000);
  EXPECT_NEAR(f.speeds[0].min_mm_s, 1.02 * vc, 1e-9);
  // Without the margins the braking counts: slower, and 0.72 v_c of fluctuation.
  PathOptions all;
  all.margins = {0.0, 0.0};
  const PathFigures g = EvaluatePath({rectangle, vc}, cycles, all);
  EXPECT_LT(g.av_percent, 0.0);
  EXPECT_NEAR(g.fv_mm_s, 0.72 * vc, 1e-9);
}

TEST(Iso9283Path, SpeedRepeatabilityAndFluctuationOfTwoCyclesByHand) {
  // Along x, 401 mm in 0.5 mm steps: samples 81…721 (s = 40.5…360.5 mm) are the steady
  // part (40.1…360.9 mm), 640 steps in each cycle. Cycle 0 at 99 mm/s; cycle 1 alternately
  // at 101 and 105 mm/s (its mean 103, its fluctuation 4). v_c = 100 mm/s.
  const double vc = 100.0;
  std::vector<AttainedCycle> cycles(2);
  for (int c = 0; c < 2; ++c) {
    double t = 0.0;
    for (int k = 0; k <= 802; ++k) {
      cycles[c].samples.push_back({t, Eigen::Vector3d(0.5 * k, 0, 0)});
      t += 0.5 / (c == 0 ? 99.0 : (k % 2 == 0 ? 105.0 : 101.0));
    }
  }
  const PathFigures f = EvaluatePath({{{0, 0, 0}, {401, 0, 0}}, vc}, cycles);
  ASSERT_EQ(f.speeds.size(), 2u);
  EXPECT_EQ(f.speeds[0].count, 640);
  EXPECT_EQ(f.speeds[1].count, 640);
  EXPECT_NEAR(f.speeds[0].mean_mm_s, 99.0, 1e-9);
  EXPECT_NEAR(f.speeds[1].mean_mm_s, 103.0, 1e-9);
  EXPECT_NEAR(f.mean_speed_mm_s, 101.0, 1e-9);
  EXPECT_NEAR(f.av_percent, 1.0, 1e-9);
  // S_v of {99, 103} on n − 1: 4 / √2; RV = 3 S_v / v_c.
  EXPECT_NEAR(f.s_v_mm_s, 4.0 / std::sqrt(2.0), 1e-9);
  EXPECT_NEAR(f.rv_percent, 3.0 * 4.0 / std::sqrt(2.0) / vc * 100.0, 1e-9);
  EXPECT_NEAR(f.fv_mm_s, 4.0, 1e-9);
  // One cycle: no RV.
  const PathFigures one = EvaluatePath({{{0, 0, 0}, {401, 0, 0}}, vc}, {cycles[0]});
  EXPECT_TRUE(std::isnan(one.rv_percent));
  EXPECT_TRUE(std::isnan(one.rt_mm));
  EXPECT_NEAR(one.av_percent, -1.0, 1e-9);
}

TEST(Iso9283Path, WithoutASteadyPartTheFiguresAreNaNNotZero) {
  // A V of two 100 mm legs: the ends' margins (49 %) leave 196…204 mm, the corner's (10 %
  // of a leg on either side) 190…210 mm: no plane, no speed, but the corner is measured.
  const std::vector<Eigen::Vector3d> v = {{0, 0, 0}, {100, 0, 0}, {100, 100, 0}};
  PathOptions options;
  options.margins.ends_fraction = 0.49;
  const PathFigures f = EvaluatePath({v, 100.0}, {PathWalk(v, 1.0, 100.0)}, options);
  EXPECT_TRUE(f.planes.empty());
  EXPECT_TRUE(std::isnan(f.plane_spacing_mm));
  EXPECT_EQ(f.planes_used, 0);
  EXPECT_TRUE(std::isnan(f.at_mm));
  EXPECT_EQ(f.at_plane, -1);
  EXPECT_TRUE(std::isnan(f.mean_at_mm));
  EXPECT_TRUE(std::isnan(f.rt_mm));
  EXPECT_EQ(f.speeds[0].count, 0);
  EXPECT_TRUE(std::isnan(f.av_percent));
  EXPECT_TRUE(std::isnan(f.fv_mm_s));
  ASSERT_EQ(f.corners.size(), 1u);
  EXPECT_NEAR(f.corners[0].cr_max_mm, 0.0, 1e-12);
  EXPECT_NEAR(f.corners[0].co_max_mm, 0.0, 1e-12);  // over 2 mm: 100 − 98 mm of end margin
}

TEST(Iso9283Path, DegenerateCommandsAndBadSamplesThrow) {
  const Eigen::Vector3d a(0, 0, 0), b(100, 0, 0);
  const std::vector<AttainedCycle> good = {PathWalk({a, b}, 1.0, 100.0)};
  EXPECT_THROW(EvaluatePath({{a, a, a}, 100.0}, good), std::invalid_argument);
  EXPECT_THROW(EvaluatePath({{a}, 100.0}, good), std::invalid_argument);
  EXPECT_THROW(EvaluatePath({{}, 100.0}, good), std::invalid_argument);
  EXPECT_THROW(EvaluatePath({{a, Eigen::Vector3d(NAN, 0, 0)}, 100.0}, good), std::invalid_argument);
  EXPECT_THROW(EvaluatePath({{a, b}, 0.0}, good), std::invalid_argument);
  EXPECT_THROW(EvaluatePath({{a, b}, 100.0}, {}), std::invalid_argument);
  EXPECT_NO_THROW(EvaluatePath({{a, a, b}, 100.0}, good));  // a repeated vertex is dropped

  AttainedCycle standing = good[0];
  standing.samples[5].t_s = standing.samples[4].t_s;
  try {
    EvaluatePath({{a, b}, 100.0}, {good[0], standing});
    ADD_FAILURE() << "a time that does not increase was taken";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("attained cycle 1, sample 5"), std::string::npos)
        << e.what();
  }
  AttainedCycle backwards = good[0];
  backwards.samples[3].t_s = -1.0;
  EXPECT_THROW(EvaluatePath({{a, b}, 100.0}, {backwards}), std::invalid_argument);
  AttainedCycle lost = good[0];
  lost.samples[2].position_mm.y() = NAN;
  EXPECT_THROW(EvaluatePath({{a, b}, 100.0}, {lost}), std::invalid_argument);
  AttainedCycle timeless = good[0];
  timeless.samples[2].t_s = INFINITY;
  EXPECT_THROW(EvaluatePath({{a, b}, 100.0}, {timeless}), std::invalid_argument);
  AttainedCycle single;
  single.samples.push_back({0.0, a});
  EXPECT_THROW(EvaluatePath({{a, b}, 100.0}, {single}), std::invalid_argument);
  PathOptions options;
  options.plane_spacing_mm = 0.0;
  EXPECT_THROW(EvaluatePath({{a, b}, 100.0}, good, options), std::invalid_argument);
}

TEST(Iso9283TestPaths, RectangleInTheDiagonalPlaneAndCirclesAtTheirRadii) {
  const TestCube cube{{600.0, -150.0, 400.0}, 500.0};
  const TestPaths paths = BuildTestPaths(cube);
  const auto c = CubeCorners(cube);
  const auto p = TestPoints(cube);
  const Eigen::Vector3d normal = (c[1] - c[0]).cross(c[7] - c[0]).normalized();
  auto in_plane = [&](const Eigen::Vector3d& x) { return std::abs(normal.dot(x - c[0])); };

  // The line: P2 → P4, 80 % of the space diagonal.
  ASSERT_EQ(paths.line_mm.size(), 2u);
  EXPECT_NEAR((paths.line_mm[0] - p[1].position_mm).norm(), 0.0, 1e-12);
  EXPECT_NEAR((paths.line_mm[1] - p[3].position_mm).norm(), 0.0, 1e-12);
  EXPECT_NEAR((paths.line_mm[1] - paths.line_mm[0]).norm(), 0.8 * 500.0 * std::sqrt(3.0), 1e-9);

  // The rectangle: closed, from the middle of P5–P2 through P2, P3, P4, P5, right angles,
  // sides 80 % of the plane's (500 and 500 √2 mm), every vertex in the plane.
  const auto& r = paths.rectangle_mm;
  ASSERT_EQ(r.size(), 6u);
  EXPECT_NEAR((r.front() - r.back()).norm(), 0.0, 1e-12);
  EXPECT_NEAR((r[0] - 0.5 * (p[4].position_mm + p[1].position_mm)).norm(), 0.0, 1e-12);
  for (int k = 1; k <= 4; ++k) {
    EXPECT_NEAR((r[k] - p[k].position_mm).norm(), 0.0, 1e-12);
    EXPECT_NEAR((r[k] - r[k - 1]).normalized().dot((r[k + 1] - r[k]).normalized()), 0.0, 1e-12);
  }
  for (const auto& x : r) EXPECT_NEAR(in_plane(x), 0.0, 1e-9);
  EXPECT_NEAR((r[2] - r[1]).norm(), 400.0, 1e-9);
  EXPECT_NEAR((r[3] - r[2]).norm(), 400.0 * std::sqrt(2.0), 1e-9);

  // The circles: centre P1, diameters 400 mm and 40 mm, 360 chords, closed, in the plane.
  const double radius[2] = {200.0, 20.0};
  const std::vector<Eigen::Vector3d>* circle[2] = {&paths.large_circle_mm, &paths.small_circle_mm};
  for (int i = 0; i < 2; ++i) {
    ASSERT_EQ(circle[i]->size(), 361u);
    EXPECT_NEAR((circle[i]->front() - circle[i]->back()).norm(), 0.0, 1e-9);
    for (const auto& x : *circle[i]) {
      EXPECT_NEAR((x - p[0].position_mm).norm(), radius[i], 1e-9);
      EXPECT_NEAR(in_plane(x), 0.0, 1e-9);
    }
  }
  EXPECT_EQ(BuildTestPaths(cube, 720).large_circle_mm.size(), 721u);
  EXPECT_THROW(BuildTestPaths(cube, 90), std::invalid_argument);
  EXPECT_THROW(BuildTestPaths({cube.centre_mm, 0.0}), std::invalid_argument);

  // As commands: four right-angled corners at P2…P5, none on the circles.
  const std::vector<AttainedCycle> still = {PathWalk(r, 5.0, 100.0)};
  const PathFigures rect = EvaluatePath({r, 100.0}, still);
  ASSERT_EQ(rect.corners.size(), 4u);
  for (int k = 0; k < 4; ++k) EXPECT_EQ(rect.corners[k].vertex, k + 1);
  const PathFigures round =
      EvaluatePath({paths.small_circle_mm, 10.0}, {PathWalk(paths.small_circle_mm, 0.1, 10.0)});
  EXPECT_TRUE(round.corners.empty());
  EXPECT_NEAR(round.at_mm, 0.0, 1e-9);
}

// A circular move's arc from its three points: a circle of radius 120 mm about a centre in a
// tilted plane, from 10° through 100° to 250° (a 240° arc), and the half circle of the
// standard's large circle; three points on a line have no arc.
TEST(Iso9283Arc, ThroughThreePointsIsTheCircleTheyLieOn) {
  const Eigen::Vector3d centre(400.0, -50.0, 700.0);
  const Eigen::Matrix3d turn =
      (Eigen::AngleAxisd(0.4, Eigen::Vector3d::UnitX()) * Eigen::AngleAxisd(-0.7, Eigen::Vector3d::UnitZ()))
          .toRotationMatrix();
  const auto at = [&](double degrees) {
    const double a = degrees * kRadPerDeg;
    return Eigen::Vector3d(centre + turn * Eigen::Vector3d(120.0 * std::cos(a), 120.0 * std::sin(a), 0.0));
  };
  const auto arc = ArcThrough(at(10), at(100), at(250));
  ASSERT_TRUE(arc);
  EXPECT_LT((arc->centre_mm - centre).norm(), 1e-9);
  EXPECT_NEAR(arc->radius_mm, 120.0, 1e-9);
  EXPECT_NEAR(arc->angle_rad, 240.0 * kRadPerDeg, 1e-12);
  EXPECT_NEAR(arc->length_mm(), 120.0 * 240.0 * kRadPerDeg, 1e-9);
  for (double f : {0.0, 0.25, 0.375, 0.5, 1.0})
    EXPECT_LT((arc->At(f) - at(10 + 240 * f)).norm(), 1e-9) << f;
  const auto chords = ArcPolyline(*arc, kRadPerDeg);
  ASSERT_EQ(chords.size(), 240u);
  EXPECT_LT((chords.front() - at(11)).norm(), 1e-9);
  EXPECT_LT((chords.back() - at(250)).norm(), 1e-9);
  // Backwards (through 100° from 250° to 10°): the other way round, the same 240°.
  const auto back = ArcThrough(at(250), at(100), at(10));
  ASSERT_TRUE(back);
  EXPECT_NEAR(back->angle_rad, 240.0 * kRadPerDeg, 1e-12);
  EXPECT_LT((back->At(0.5) - at(130)).norm(), 1e-9);
  // The standard's large circle, halved as `iso9283 plan --path circle-large` moves it.
  const TestPaths paths = BuildTestPaths({Eigen::Vector3d(500, 0, 600), 300.0});
  const auto half = ArcThrough(paths.large_circle_mm[0], paths.large_circle_mm[90],
                               paths.large_circle_mm[180]);
  ASSERT_TRUE(half);
  EXPECT_NEAR(half->angle_rad, kPi, 1e-12);
  const auto half_chords = ArcPolyline(*half, kRadPerDeg);
  for (size_t k = 0; k < half_chords.size(); ++k)
    EXPECT_LT((half_chords[k] - paths.large_circle_mm[k + 1]).norm(), 1e-9) << k;
  EXPECT_FALSE(ArcThrough(at(10), 0.5 * (at(10) + at(100)), at(100)));
  EXPECT_FALSE(ArcThrough(at(10), at(10), at(100)));
}

}  // namespace
}  // namespace armsig::calibration::iso9283
