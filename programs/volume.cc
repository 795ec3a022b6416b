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

ValidatedVolume::ValidatedVolume(std::vector<calibration::JointArc> arcs, const std::vector<Eigen::Vector3d>& points,
                                 std::string source)
    : arcs_(std::move(arcs)), source_(std::move(source)) {
  if (arcs_.empty() || points.empty()) throw std::invalid_argument("a validated volume of no configurations");
  nearest_mm_ = INFINITY;
  for (const auto& p : points) nearest_mm_ = std::min(nearest_mm_, p.norm());
  normals_ = SphereDirections(64);
  for (const auto& normal : normals_) {
    double offset = -INFINITY;
    for (const auto& p : points) offset = std::max(offset, normal.dot(p));
    offsets_.push_back(offset);
  }
}

std::optional<std::string> ValidatedVolume::OutsideJoints(const Eigen::VectorXd& q) const {
  for (std::size_t i = 0; i < arcs_.size() && static_cast<Eigen::Index>(i) < q.size(); ++i) {
    const double v = q(static_cast<Eigen::Index>(i));
    // 1e-9 rad: a configuration of the fit itself is inside.
    if (std::abs(arcs_[i].Clamp(v) - v) > 1e-9) {
      return fmt::format("joint {} at {:.3f}°, outside the arc it was fitted on, {:.3f}° to {:.3f}°", i + 1,
                         v / kRadPerDeg, arcs_[i].start_rad / kRadPerDeg,
                         (arcs_[i].start_rad + arcs_[i].length_rad) / kRadPerDeg);
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
