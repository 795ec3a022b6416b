// `armsig import`: foreign files into armsig's formats or into the database.
#pragma once

#include <cstdint>
#include <string>

#include "db/sessions.h"
#include "io/csv.h"

namespace armsig::workflows {

// `import poses`: a pose table with named columns (a preset, or columns named on the
// command line) converted to armsig's poses CSV (`out`) and/or stored as a new session of
// a registered robot (`robot`, in the database at `db_path`, which must exist).
struct ImportPosesRequest {
  std::string file, out, robot, db_path;
  // Or a tracker's point table joined with the robot's joint log (io/point_joint_join.h).
  std::string points, joints;
  std::string match = "id";         // id | time
  double time_tolerance_s = 0.5;    // --match time: nearest joint reading within this
  std::string points_unit;          // mm | m | inch: the point table's unit when it names none
  std::string preset;                      // "ur-ipa" or empty
  std::string joint_columns, xyz_columns;  // comma-separated column names
  std::string id_column, delimiter;        // delimiter: one character or "tab"
  // deg | gon | rad; "" = the columns' unit suffixes (_deg, _gon, _rad), else rad (a pose
  // table) or deg (a joint log). A suffix it contradicts is refused.
  std::string joint_unit;
  // The measured orientation (a 6-DoF probe): three angle columns rx, ry, rz
  // (core/rotation.h) and optionally their sigma columns, comma-separated; their unit
  // (deg | gon | rad) unless the names carry a suffix.
  std::string rotation_columns, rotation_sigma_columns, rotation_unit;
  bool decimal_comma = false;
  double length_scale = 1.0;     // factor to mm
  bool allow_duplicate = false;  // store a copy of poses a session of the robot already holds
  // What the stored session is for: calibration data, an ISO 9283 test, or a check of a set
  // where it was not fitted.
  db::SessionKind kind = db::SessionKind::kCalibration;
  io::ReadProgressFn progress;   // how far a pose table has been read
};
struct ImportPosesResult {
  size_t poses = 0;
  int64_t session = 0;         // 0 when not stored
  bool duplicate = false;      // nothing stored: `session` already holds exactly these poses
  int unused_joint_rows = 0;   // --points/--joints: joint readings no point took
  std::string db_path;         // where it was stored
};
// Reads and checks the whole file before anything is kept: a pose table is read row by row
// into the store's transaction and the --out file (memory does not grow with it), both
// kept only when the whole file was read; a tracker's point table and joint log whole.
ImportPosesResult ImportPosesFile(const ImportPosesRequest& request);

// `import gsi`: a Leica GSI-8/16 file to the observations CSV; returns a one-line summary.
std::string ImportGsiFile(const std::string& file, const std::string& station,
                          const std::string& out);

}  // namespace armsig::workflows
