// Robot model files (docs/reference/file-formats.md). Two ways to give the links:
//   links: [4x4 row-major, …]            N2…Nn, the paper's form
//   dh: [{d_mm, a_mm, alpha_deg|_rad|_gon}, …]   standard Denavit–Hartenberg, one row per
//       joint, mapped as N(i+1) = Tz(d_i)·Tx(a_i)·Rx(α_i) and the last row folded into x̄.
#pragma once

#include <Eigen/Geometry>
#include <string>

#include "calibration/model.h"
#include "core/plausibility.h"
#include "io/yaml_reader.h"

namespace armsig::io {

// Throws InputError with file, line and column of the offending node; unknown keys are
// refused at every level (naming the nearest valid key), so a misspelt tool_mm is an error.
calibration::RobotModel LoadRobotModel(const std::string& path);
calibration::RobotModel ParseRobotModel(const std::string& yaml_text, const std::string& source);

// A 4x4 row-major homogeneous transform with a rotation in its upper-left 3x3 (orthonormal,
// det +1, last row 0 0 0 1); its translation a plausible `translation` (kLength for a
// link, kCoordinate for a base in a measuring frame). Refused at the node otherwise.
Eigen::Isometry3d ReadRigidTransform(const YamlValue& value, plausible::Quantity translation);

}  // namespace armsig::io
