// A tracker's point table joined with the robot's joint log into measured poses (`armsig
// import poses --points PTS --joints LOG [--match id|time]`): each point takes the joint
// reading with its name, or the one taken at its time, and refusals name the lines of both
// files.
#pragma once

#include <Eigen/Core>
#include <vector>

#include "core/types.h"
#include "io/joint_log.h"
#include "io/point_table.h"

namespace armsig::io {

enum class JoinBy { kId, kTime };
struct JoinOptions {
  JoinBy by = JoinBy::kId;
  double time_tolerance_s = 0.5;  // a point takes the nearest joint reading within this
  // Another joint reading within the tolerance that differs from the nearest by more than
  // this (any joint) makes the match ambiguous: the robot moved, or two configurations
  // fall in the window.
  double moving_rad = 1e-3;
};
struct JoinedPoses {
  std::vector<MeasuredPose> poses;  // one per point, in the point table's order, id = name
  // Per pose: the point's covariance from its sigmas (diagonal), NaN when it has none.
  std::vector<Eigen::Matrix3d> covariances_mm2;
  int unused_joint_rows = 0;
  double max_time_gap_s = 0.0;  // time join: the largest |point time − joint time|
};
// Every point must find exactly one joint reading (by id: the same id; by time: the
// nearest within the tolerance, unambiguous), and no joint reading may serve two points.
// Throws InputError naming the point table's line (and the joint log's) of the first
// refused point, with the others listed.
JoinedPoses JoinPointsAndJoints(const PointTable& points, const JointLog& joints,
                                const JoinOptions& options = {});

}  // namespace armsig::io
