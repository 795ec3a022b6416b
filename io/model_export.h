// Exports of a (corrected) robot model: armsig's own model YAML and a URDF.
#pragma once

#include <string>

#include "calibration/model.h"

namespace armsig::io {

// A model YAML armsig loads back (links as 4×4, base as 4×4, h-terms with value_rad).
std::string FormatRobotModelYaml(const calibration::RobotModel& model, const std::string& comment);

// URDF (metres, radians): base_link, one revolute joint per robot joint with its
// origin from the (corrected) link transforms, a fixed joint to the tool point.
// Non-geometric terms have no place in URDF: `warning` says so when they are not zero.
std::string FormatUrdf(const calibration::RobotModel& model, std::string* warning = nullptr);

}  // namespace armsig::io
