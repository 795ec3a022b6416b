// The robot's joint log: the joints the controller reported, with the pose id and/or the
// time of each reading, to be joined with a tracker's point table (io/point_joint_join.h;
// `armsig import poses --points PTS --joints LOG`).
//
// A CSV (io/csv.h: ',', ';' or tab, decimal comma with ';' or tab) with a pose id column
// (`pose`, `point`, `id`, `name` or `label`) and/or a time column (`time`, `timestamp`,
// `time_stamp`, `datetime`, `time_s`), and the joints: `q1_deg` … (any angle unit suffix,
// as in the poses CSV), or the named columns in `joint_columns` in `joint_unit`.
#pragma once

#include <Eigen/Core>
#include <optional>
#include <string>
#include <vector>

#include "core/units.h"
#include "io/time_stamp.h"

namespace armsig::io {

struct JointLogOptions {
  int num_joints = 0;  // 0: as many q1, q2, … columns as there are
  std::vector<std::string> joint_columns;
  AngleUnit joint_unit = AngleUnit::kDeg;
};
struct JointLogRow {
  std::optional<std::string> id;
  std::optional<TimeStamp> time;
  Eigen::VectorXd joints_rad;
  int line = 0;
};
struct JointLog {
  std::string source;
  std::vector<JointLogRow> rows;
  bool has_ids = false, has_times = false;
};
// Throws InputError (file:line:column) for a log without an id or time column, without
// joint columns (or with more q columns than the robot has joints), a row without an id
// and a time, a time stamp or joint angle that cannot be read or is not plausible, or no
// rows.
JointLog ReadJointLog(const std::string& path, const JointLogOptions& options = {});

}  // namespace armsig::io
