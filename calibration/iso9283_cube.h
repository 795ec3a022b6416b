// The test cube of ISO 9283 (manipulating industrial robots: performance criteria and
// related test methods): an axis-aligned cube in the robot's working space, its
// measuring plane C1–C2–C7–C8, the five test points P1–P5 on it, the order a cycle
// visits them, the point pairs of the distance test and the approach directions of the
// multi-directional test. Geometry only, in the robot's base frame (mm).
//
// Corners: C1…C4 the top face (+z) counter-clockwise seen from above, starting at
// (−x, −y); C5…C8 the bottom face, C(k+4) below Ck:
//
//          C4 ─────── C3          the measuring plane C1–C2–C7–C8 holds the top edge
//         ╱│         ╱│           C1–C2 (at −y) and the bottom edge C7–C8 (at +y): a
//       C1 ─────── C2 │           diagonal plane of the cube, whose diagonals C1–C7 and
//        │ C8 ──────│ C7          C2–C8 are the cube's space diagonals.
//        │╱         │╱
//       C5 ─────── C6             z up, x to the right, y away from the viewer
//
// P1 is the centre; P2, P3, P4 and P5 lie on the plane's diagonals at 10 % of the
// diagonal's length from C1, C2, C7 and C8, so P2–P4 and P3–P5 are the two diagonals.
#pragma once

#include <Eigen/Core>
#include <array>
#include <functional>
#include <string>

namespace armsig::calibration::iso9283 {

struct TestCube {
  Eigen::Vector3d centre_mm = Eigen::Vector3d::Zero();
  double edge_mm = 0.0;
};

// The smallest edge a test cube may have. The standard's cube is the largest the working
// space holds; P2…P5 of a cube under 10 mm sit within a few millimetres of P1, closer than a
// small desktop arm's own pose errors, and test nothing of its working space.
inline constexpr double kMinCubeEdgeMm = 10.0;

// C1…C8 in the order above.
std::array<Eigen::Vector3d, 8> CubeCorners(const TestCube& cube);

// Where P2…P5 sit on the diagonals, as a fraction of the diagonal from their corner.
inline constexpr double kCornerFraction = 0.10;

struct TestPoint {
  std::string name;  // "P1" … "P5"
  Eigen::Vector3d position_mm = Eigen::Vector3d::Zero();
};
// P1…P5 (index 0 … 4).
std::array<TestPoint, 5> TestPoints(const TestCube& cube);

// One cycle visits P1 → P5 → P4 → P3 → P2 (indices into TestPoints).
inline constexpr std::array<int, 5> kCycleOrder = {0, 4, 3, 2, 1};

// The distance test's pairs: the two diagonals P2–P4 (the standard's pair, first) and P3–P5.
struct PointPair {
  int from = 0, to = 0;  // indices into TestPoints
};
inline constexpr std::array<PointPair, 2> kDistancePairs = {{{1, 3}, {2, 4}}};

// The multi-directional test approaches each point moving along −x, −y and −z of the base
// frame, from a via point on the +x, +y and +z side. Index k (0…2) is approach k + 1.
Eigen::Vector3d ApproachSide(int k);
std::string ApproachName(int k);  // "x", "y", "z"

// The largest edge in [smallest_mm, largest_mm] (to `tolerance_mm`) for which
// `reachable(cube)` holds, around `centre_mm`, by bisection (reachability is taken to
// shrink as the cube grows). 0 when not even the smallest cube is reachable.
double LargestCubeEdge(const Eigen::Vector3d& centre_mm,
                       const std::function<bool(const TestCube&)>& reachable, double smallest_mm,
                       double largest_mm, double tolerance_mm);

}  // namespace armsig::calibration::iso9283
