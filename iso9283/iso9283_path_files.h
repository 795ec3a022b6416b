// ISO 9283 path characteristics from files (`armsig iso9283 evaluate-path`): the commanded
// path and the attained cycles from any source — a tracker's continuous export, a session
// measured on the move — in one frame:
//   commanded  x_mm,y_mm,z_mm             one row per vertex, in path order (corners where it
//                                         turns); an optional `vertex` column names them;
//   attained   cycle,t_s,x_mm,y_mm,z_mm   time-stamped positions, each cycle's in time order.
// The figures are calibration/iso9283_path.h's: AT, RT, the corners' CR and CO, AV, RV, FV.
#pragma once

#include <nlohmann/json.hpp>
#include <string>

#include "calibration/iso9283_path.h"

namespace armsig::iso9283 {

// Throws InputError (file:line:column) for a missing column, a number that is none, fewer
// than two vertices, a cycle number below 1, times that do not increase within a cycle; the
// path figures' own refusals (a degenerate path) as InputError naming the commanded file.
calibration::iso9283::PathFigures EvaluatePathFiles(const std::string& commanded_csv,
                                                    const std::string& attained_csv,
                                                    double speed_mm_s);

// {"cycles", "length_mm", "planes", "AT_mm", "AT_xyz_mm", "mean_AT_mm", "RT_mm",
//  "commanded_speed_mm_s", "mean_speed_mm_s", "AV_percent", "RV_percent", "FV_mm_s",
//  "corners": [{"vertex", "turn_deg", "CR_mm", "CO_mm"}]}; NaN figures are null.
nlohmann::json PathJson(const calibration::iso9283::PathFigures& f);
std::string FormatPathFigures(const calibration::iso9283::PathFigures& f);

}  // namespace armsig::iso9283
