#include "programs/volume.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "core/units.h"

namespace armsig::programs {

namespace {

// n directions spread evenly over the sphere (the Fibonacci lattice).
std::vector<Eigen::Vector3d> SphereDirections(int n) {
  std::vector<Eigen::Vector3d> out;
  const double golden = kPi * (3.0 - std::sqrt(5.0));
  for (int k = 0; k < n; ++k) {
    const double z = 1.0 - (2.0 * k + 1.0) / n;
    const double r = std::sqrt(std::max(0.0, 1.0 - z * z));
    out.emplace_back(r * std::cos(golden * k), r * std::sin(golden * k), z);
  }
  return out;
}

}  // namespace

ValidatedVolume::ValidatedVolume(const std::vector<Eigen::VectorXd>& joints,
                                 const std::vector<Eigen::Vector3d>& points, std::string source)
    : source_(std::move(source)) {
  if (joints.empty() || points.empty()) throw std::invalid_argument("a validated volume of no configurations");
  const Eigen::Index n = joints.front().size();
  joint_min_rad_.assign(static_cast<std::size_t>(n), INFINITY);
  joint_max_rad_.assign(static_cast<std::size_t>(n), -INFINITY);
  for (const auto& q : joints) {
    if (q.size() != n) throw std::invalid_argument("configurations of different joint counts");
    for (Eigen::Index i = 0; i < n; ++i) {
      joint_min_rad_[static_cast<std::size_t>(i)] = std::min(joint_min_rad_[static_cast<std::size_t>(i)], q(i));
      joint_max_rad_[static_cast<std::size_t>(i)] = std::max(joint_max_rad_[static_cast<std::size_t>(i)], q(i));
    }
  }
  normals_ = SphereDirections(64);
  for (const auto& normal : normals_) {
    double offset = -INFINITY;
    for (const auto& p : points) offset = std::max(offset, normal.dot(p));
    offsets_.push_back(offset);
  }
}

std::optional<std::string> ValidatedVolume::OutsideJoints(const Eigen::VectorXd& q) const {
  for (std::size_t i = 0; i < joint_min_rad_.size() && static_cast<Eigen::Index>(i) < q.size(); ++i) {
    const double v = q(static_cast<Eigen::Index>(i));
    // 1e-9 rad: a configuration of the sessions themselves is inside.
    if (v < joint_min_rad_[i] - 1e-9 || v > joint_max_rad_[i] + 1e-9) {
      return fmt::format("joint {} at {:.3f}°, its validated range {:.3f}° to {:.3f}°", i + 1,
                         v / kRadPerDeg, joint_min_rad_[i] / kRadPerDeg, joint_max_rad_[i] / kRadPerDeg);
    }
  }
  return std::nullopt;
}

double ValidatedVolume::DistanceOutside(const Eigen::Vector3d& p) const {
  double worst = -INFINITY;
  for (std::size_t k = 0; k < normals_.size(); ++k) worst = std::max(worst, normals_[k].dot(p) - offsets_[k]);
  return worst;
}

}  // namespace armsig::programs
