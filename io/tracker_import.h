// What laser-tracker software exports, made into measured poses: a point table
// (`name, X, Y, Z` with optional sigmas and time stamps, as SpatialAnalyzer, Leica, Metrolog
// or PolyWorks write their ASCII/CSV point exports) joined with the robot's joint log by
// point/pose id or by time stamp (`armsig import poses --points PTS --joints LOG`).
//
// The point table reader detects what these exports vary in:
// - the delimiter: tab, ';', ',' or white space (from the data rows, not the title lines);
// - a decimal comma (with any delimiter but ',');
// - the header row, wherever it is: lines before it (titles, job and date lines, `//` and
//   `#` comments) are skipped, a units line right after it ("[mm] [mm] [mm]") is read;
//   without a header the columns are positional: leading names (SpatialAnalyzer's
//   "Collection Group Target": the last one is the point name), then x y z, then optionally
//   their three sigmas;
// - the length unit: from the header ("X [mm]", "X (m)", "x_mm"), a units line, or a
//   comment or title line ("// Units: Millimeters"); mm, m or inch. Given nowhere, the
//   option must say it (a metre file read as mm is a factor 1000, never guessed); said in
//   two places differently, the file is refused.
// Every refusal names file:line:column and what was expected.
#pragma once

#include <Eigen/Core>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "core/types.h"
#include "core/units.h"

namespace armsig::io {

enum class LengthUnit { kMm, kM, kInch };
double MillimetresPer(LengthUnit unit);
const char* ToString(LengthUnit unit);  // "mm", "m", "inch"
// "mm", "millimeter(s)", "millimetre(s)", "m", "meter(s)", "metre(s)", "in", "inch",
// "inches" (any case); nullopt otherwise.
std::optional<LengthUnit> LengthUnitFromText(std::string_view text);

// A time stamp as written: an ISO 8601 date-time ("2024-03-05T10:15:30.25", a space for the
// T, optional Z or ±hh:mm) is absolute (seconds since 1970-01-01 UTC; no zone = as written);
// a plain number is seconds on the writer's own clock. Only stamps of one kind compare.
struct TimeStamp {
  double seconds = 0.0;
  bool absolute = false;
};
std::optional<TimeStamp> ParseTimeStamp(std::string_view text);

struct TablePoint {
  std::string name;
  Eigen::Vector3d position_mm = Eigen::Vector3d::Zero();
  std::optional<Eigen::Vector3d> sigma_mm;
  std::optional<TimeStamp> time;
  int line = 0;
};

struct PointTableOptions {
  // The file's length unit when it names none (--points-unit); a file that names another
  // one is refused.
  std::optional<LengthUnit> unit;
};

struct PointTable {
  std::string source;
  std::vector<TablePoint> points;  // in file order
  std::string delimiter;           // "tab", "semicolon", "comma" or "whitespace"
  bool decimal_comma = false;
  int header_line = 0;  // 0: no header (positional columns)
  LengthUnit unit = LengthUnit::kMm;
  std::string unit_from;  // where the unit was read: "header", "units line 4", …
  bool has_sigmas = false, has_times = false;
};

// Throws InputError (file:line:column) for a file that cannot be read, no data rows, a row
// that is neither, columns that cannot be told apart, no unit or conflicting units, a
// number that is no number or not plausible, a duplicate point name.
PointTable ReadPointTable(const std::string& path, const PointTableOptions& options = {});
PointTable ParsePointTable(std::string_view text, const std::string& source,
                           const PointTableOptions& options = {});

// The robot's joint log: a CSV (io/csv.h: ',', ';' or tab, decimal comma with ';' or tab)
// with a pose id column (`pose`, `point`, `id`, `name` or `label`) and/or a time column
// (`time`, `timestamp`, `time_stamp`, `datetime`, `time_s`), and the joints: `q1_deg` …
// (any angle unit suffix, as in the poses CSV), or the named columns in `joint_columns` in
// `joint_unit`.
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
JointLog ReadJointLog(const std::string& path, const JointLogOptions& options = {});

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
