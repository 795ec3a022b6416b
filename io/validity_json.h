// Where a parameter set holds (calibration/validity.h) as JSON, stored with the set
// (calibrations.validity_json) and exported with it:
//   {"term_arcs_rad": [[start, length], …] (one per joint; length 2π: the whole turn),
//    "sigma": {"inside_mm": 0.05, "outside_mm": 0.21, "coverage_inside": 0.95,
//              "coverage_outside": 0.94, "outside_folds": "5 joint-space blocks held out in turn"}}
// Numbers that cannot be null are null when unknown (NaN).
#pragma once

#include <nlohmann/json.hpp>
#include <string>

#include "calibration/validity.h"

namespace armsig::io {

nlohmann::json ValidityToJson(const calibration::SetValidity& validity);

// Every number bounded as a file's would be (an arc within two turns, a length in (0, 2π], a
// σ from 0 to 1 m, a coverage in [0, 1]); `num_joints` arcs. InputError naming `source` and
// the field otherwise.
calibration::SetValidity ValidityFromJson(const nlohmann::json& json, int num_joints,
                                          const std::string& source);

}  // namespace armsig::io
