// Where a parameter set was validated: the range of each joint over the configurations it
// was fitted and validated on, and the volume of the points measured there. A program target
// whose compensated joints leave a range, or whose calibration point leaves the volume, is
// outside what the set has been shown to get right.
//
// The volume is the measured points' convex hull as 64 supporting planes (outward normals
// spread evenly over the sphere, each plane touching the points): a polytope a little larger
// than the hull itself (by at most 1 − cos 14° ≈ 3 % of the points' extent near its corners),
// exact where the hull's faces face one of the normals, and quick to test.
#pragma once

#include <Eigen/Core>
#include <optional>
#include <string>
#include <vector>

namespace armsig::programs {

class ValidatedVolume {
 public:
  ValidatedVolume() = default;
  // From the joints of the configurations and the calibration point's position at each
  // (robot frame, mm). `source` names them for messages ("sessions 1, 2: 1,773 configurations").
  ValidatedVolume(const std::vector<Eigen::VectorXd>& joints_rad, const std::vector<Eigen::Vector3d>& points_mm,
                  std::string source);

  bool empty() const { return joint_min_rad_.empty(); }
  const std::string& source() const { return source_; }
  const std::vector<double>& joint_min_rad() const { return joint_min_rad_; }
  const std::vector<double>& joint_max_rad() const { return joint_max_rad_; }

  // Why joints lie outside the ranges ("joint 3 at 152.1°, its validated range -10.0° to
  // 140.2°"), nullopt inside.
  std::optional<std::string> OutsideJoints(const Eigen::VectorXd& joints_rad) const;
  // How far (mm) a point lies outside the measured volume: ≤ 0 inside.
  double DistanceOutside(const Eigen::Vector3d& point_mm) const;

 private:
  std::vector<double> joint_min_rad_, joint_max_rad_;
  std::vector<Eigen::Vector3d> normals_;
  std::vector<double> offsets_;  // plane k: normals_[k]·x ≤ offsets_[k]
  std::string source_;
};

}  // namespace armsig::programs
