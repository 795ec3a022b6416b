// Where a parameter set was validated: the arc of each joint's angles the set was fitted on
// (stored with the set, calibration/validity.h: its terms are held to them), and the volume
// of the points measured in the sessions it was fitted and validated on. A program target
// whose compensated joints leave an arc, or whose calibration point leaves the volume, is
// outside what the set has been shown to get right.
//
// The volume is the measured points' convex hull as 64 supporting planes (outward normals
// spread evenly over the sphere, each plane touching the points): a polytope a little larger
// than the hull itself (no direction is more than about 14° from one of the normals), exact
// where the hull's faces face one of them, and quick to test.
#pragma once

#include <Eigen/Core>
#include <optional>
#include <string>
#include <vector>

#include "calibration/model.h"

namespace armsig::programs {

class ValidatedVolume {
 public:
  ValidatedVolume() = default;
  // From the arcs of the joints (one per joint) and the calibration point's positions
  // measured (robot frame, mm). `source` names them for messages ("sessions 1, 2: 1,773
  // configurations").
  ValidatedVolume(std::vector<calibration::JointArc> arcs, const std::vector<Eigen::Vector3d>& points_mm,
                  std::string source);

  bool empty() const { return arcs_.empty(); }
  const std::string& source() const { return source_; }
  const std::vector<calibration::JointArc>& arcs() const { return arcs_; }

  // Why joints lie outside the arcs ("joint 3 at 152.100°, outside the arc it was fitted on,
  // -10.000° to 140.200°"), nullopt inside.
  std::optional<std::string> OutsideJoints(const Eigen::VectorXd& joints_rad) const;
  // How far (mm) a point lies outside the measured volume: ≤ 0 inside.
  double DistanceOutside(const Eigen::Vector3d& point_mm) const;
  // The measured points' nearest distance from the robot frame's origin (mm): the hull of
  // points around a robot holds its base, where no target can be.
  double nearest_mm() const { return nearest_mm_; }

 private:
  std::vector<calibration::JointArc> arcs_;
  std::vector<Eigen::Vector3d> normals_;
  std::vector<double> offsets_;  // plane k: normals_[k]·x ≤ offsets_[k]
  std::string source_;
  double nearest_mm_ = 0.0;
};

}  // namespace armsig::programs
