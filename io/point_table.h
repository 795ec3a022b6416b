// A laser tracker's point table: `name, X, Y, Z` with optional sigmas and time stamps, as
// SpatialAnalyzer, Leica, Metrolog or PolyWorks write their ASCII/CSV point exports
// (`armsig import poses --points PTS`; joined with the robot's joint log in
// io/point_joint_join.h).
//
// The reader detects what these exports vary in:
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

#include "io/time_stamp.h"

namespace armsig::io {

enum class LengthUnit { kMm, kM, kInch };
double MillimetresPer(LengthUnit unit);
const char* ToString(LengthUnit unit);  // "mm", "m", "inch"
// "mm", "millimeter(s)", "millimetre(s)", "m", "meter(s)", "metre(s)", "in", "inch",
// "inches" (any case); nullopt otherwise.
std::optional<LengthUnit> LengthUnitFromText(std::string_view text);

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

}  // namespace armsig::io
