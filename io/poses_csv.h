// Poses (SPEC "Poses (CSV)"): pose,q1_deg,…,qn_deg,x_mm,y_mm,z_mm (any angle unit
// suffix, extra columns ignored), and the import of foreign pose tables such as the
// IPA UR10 laser-tracker files (';', decimal comma, named columns).
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "core/types.h"
#include "core/units.h"

namespace armsig::io {

// Reads poses for a robot of `num_joints` joints (−1: as many as the header's q1, q2, …
// columns). Throws InputError (file, line, column) for a missing column, a malformed
// number, a duplicate pose id, or no rows.
// `joint_unit`: what the caller was told the joints are in; a q column whose suffix says
// otherwise is refused (InputError naming the column), never read in another unit.
std::vector<MeasuredPose> ReadPosesCsv(const std::string& path, int num_joints,
                                       std::optional<AngleUnit> joint_unit = std::nullopt);

// Writes the SPEC's poses CSV (angles in degrees, full precision). `num_joints`: the q
// columns of the header (−1: as many as the first pose has), so that a file without a
// pose still has the full header.
std::string FormatPosesCsv(const std::vector<MeasuredPose>& poses, int num_joints = -1);

struct PoseImportOptions {
  char delimiter = '\0';  // ',', ';' or '\t'; '\0' = detect (io/csv.h)
  // Decimal commas are read whenever the delimiter is ';' or tab (the one CSV rule);
  // true only asserts it: a comma-separated file is then refused.
  bool decimal_comma = false;
  std::vector<std::string> joint_columns;  // in joint order
  // The joint columns' unit. A column whose name ends in _deg, _gon or _rad is read in that
  // unit; a joint_unit that contradicts it is refused, never applied. Columns without a
  // suffix are read in joint_unit, else in rad.
  std::optional<AngleUnit> joint_unit;
  std::vector<std::string> xyz_columns;  // measured target x, y, z
  double length_scale_to_mm = 1.0;       // e.g. 1000 for metres
  std::string id_column;                 // empty = row number
  // Preset for the IPA UR10 laser-tracker CSVs (../shared/data/ur10-ipa).
  static PoseImportOptions UrIpa();
};

std::vector<MeasuredPose> ImportPoses(const std::string& path, const PoseImportOptions& options);

}  // namespace armsig::io
