// What a point table's header and preamble say (internal to io/point_table.cc): the role
// of each named column (the point's name, x, y, z, their sigmas, the time) and the length
// units an export writes into column names ("X [mm]", "x_m"), onto a units line under the
// header ("[mm] [mm] [mm]") or into a title or comment line ("// Units: Millimeters").
#pragma once

#include <cstddef>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "io/point_table.h"

namespace armsig::io::point_table {

// What std::isspace calls white space: a tracker export's fields and lines are trimmed of it.
inline constexpr std::string_view kBlank = " \t\n\v\f\r";

std::string Lower(std::string_view s);

enum class Role { kOther, kName, kX, kY, kZ, kSx, kSy, kSz, kTime };

struct ColumnName {
  Role role = Role::kOther;
  std::optional<LengthUnit> unit;
  bool unit_is_seconds = false;
};

// "X [mm]" → x, mm; "x_m" → x, m; "Sigma X (mm)" → sigmax, mm; "σX" → sigmax; "Point Name" →
// pointname; "Date/Time" → datetime.
ColumnName Classify(std::string_view raw);

// Header words white space split apart: a unit annotation ("X", "[mm]") and two-word names
// ("Point", "Name"; "Time", "Stamp") become one field while the count exceeds `wanted`.
std::vector<std::string> MergeHeaderWords(std::vector<std::string> fields, size_t wanted);

// Which field holds what (-1: none), and the units the header gives.
struct Layout {
  int name = -1, time = -1;
  int xyz[3] = {-1, -1, -1};
  int sigma[3] = {-1, -1, -1};
  std::optional<LengthUnit> coordinate_unit, sigma_unit;
  bool time_in_seconds = false;
};

// The roles of a header's fields; nullopt when x, y and z are not all named. Throws
// InputError (`source`:`line`) when x, y and z are given different units, or sigmas for
// some of them only.
std::optional<Layout> HeaderLayout(const std::vector<std::string>& fields,
                                   const std::string& source, int line);

// "Units: Millimeters", "// Length unit = m", "UNITS mm" in a title or comment line.
std::optional<LengthUnit> DeclaredUnit(const std::string& text);

// A units line: every field a length unit (bracketed or not), "s", "-" or empty; the unit
// of each field (none for the others); nullopt when the line is no units line or names no
// length unit.
std::optional<std::vector<std::optional<LengthUnit>>> UnitsLine(
    const std::vector<std::string>& fields);

}  // namespace armsig::io::point_table
