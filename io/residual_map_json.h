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

// The calibrate JSON's `residual_model` object (docs/reference/file-formats.md):
//   {"used": true, "kind": "gaussian_kernel_ridge", "cv_mean_mm_parametric": 0.420,
//    "cv_mean_mm_with_map": 0.311, "decision": "…",
//    "hyperparameters": {"length_scale": 0.5, "regularisation": 0.1, "noise_sigma_mm": 0.086,
//                        "support_radius": 1.61, "centres": 1773},
//    "grid": [{"length_scale", "regularisation", "cv_mean_mm"}, …]}
// `kind` and `hyperparameters` are null when no map could be fitted (too few poses).
nlohmann::json ResidualModelJson(const calibration::ResidualMapFit& fit);

// Throws InputError naming `source` and the offending field (a missing or mistyped field,
// an unknown key, a version this program does not know, data ResidualMap refuses).
calibration::ResidualMapData ResidualMapFromJson(const nlohmann::json& json,
                                                 const std::string& source);

}  // namespace armsig::io
