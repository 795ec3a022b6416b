#include "calibration/iso9283_cube.h"

#include <stdexcept>

namespace armsig::calibration::iso9283 {

std::array<Eigen::Vector3d, 8> CubeCorners(const TestCube& cube) {
  const double h = cube.edge_mm / 2.0;
  // (sign x, sign y) around the top face from (−x, −y), counter-clockwise seen from +z.
  const double ring[4][2] = {{-1, -1}, {+1, -1}, {+1, +1}, {-1, +1}};
  std::array<Eigen::Vector3d, 8> c;
  for (int k = 0; k < 4; ++k) {
    c[k] = cube.centre_mm + h * Eigen::Vector3d(ring[k][0], ring[k][1], +1.0);
    c[k + 4] = cube.centre_mm + h * Eigen::Vector3d(ring[k][0], ring[k][1], -1.0);
  }
  return c;
}

std::array<TestPoint, 5> TestPoints(const TestCube& cube) {
  const auto c = CubeCorners(cube);
  // Each of P2…P5 with its corner and the corner at the other end of its diagonal.
  const Eigen::Vector3d& c1 = c[0];
  const Eigen::Vector3d& c2 = c[1];
  const Eigen::Vector3d& c7 = c[6];
  const Eigen::Vector3d& c8 = c[7];
  auto near = [](const Eigen::Vector3d& corner, const Eigen::Vector3d& opposite) {
    return Eigen::Vector3d(corner + kCornerFraction * (opposite - corner));
  };
  return {{{"P1", cube.centre_mm},
           {"P2", near(c1, c7)},
           {"P3", near(c2, c8)},
           {"P4", near(c7, c1)},
           {"P5", near(c8, c2)}}};
}

Eigen::Vector3d ApproachSide(int k) {
  if (k < 0 || k > 2) throw std::out_of_range("approach direction index");
  return Eigen::Vector3d::Unit(k);
}

std::string ApproachName(int k) {
  if (k < 0 || k > 2) throw std::out_of_range("approach direction index");
  return std::string(1, "xyz"[k]);
}

double LargestCubeEdge(const Eigen::Vector3d& centre_mm,
                       const std::function<bool(const TestCube&)>& reachable, double smallest_mm,
                       double largest_mm, double tolerance_mm) {
  if (!(smallest_mm > 0) || !(largest_mm >= smallest_mm) || !(tolerance_mm > 0))
    throw std::invalid_argument("LargestCubeEdge: invalid range");
  if (!reachable({centre_mm, smallest_mm})) return 0.0;
  if (reachable({centre_mm, largest_mm})) return largest_mm;
  double good = smallest_mm, bad = largest_mm;
  while (bad - good > tolerance_mm) {
    const double middle = 0.5 * (good + bad);
    (reachable({centre_mm, middle}) ? good : bad) = middle;
  }
  return good;
}

}  // namespace armsig::calibration::iso9283
