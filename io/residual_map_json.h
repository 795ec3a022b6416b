// The residual map (calibration/residual_map.h) as JSON, for the stored parameter set and
// the exported signature. Lengths in mm, angles in rad:
//   {"version": 1, "kind": "gaussian_kernel_ridge", "output_frame": "base",
//    "num_joints": 6, "joints": [1, 2, 3, 4, 5],            (1-based, like every joint number)
//    "feature_scale": [a1, b1, …] (sin, cos per joint), "length_scale": 0.7, "regularisation":
//    0.01, "noise_sigma_mm": 0.2, "support_radius": 0.9, "centres_rad": [[q, …], …], "weights_mm":
//    [[x, y, z], …]}
#pragma once

#include <nlohmann/json.hpp>
#include <string>

#include "calibration/residual_map.h"

namespace armsig::io {

nlohmann::json ResidualMapToJson(const calibration::ResidualMapData& map);

// Throws InputError naming `source` and the offending field (a missing or mistyped field,
// an unknown key, a version this program does not know, data ResidualMap refuses).
calibration::ResidualMapData ResidualMapFromJson(const nlohmann::json& json,
                                                 const std::string& source);

}  // namespace armsig::io
