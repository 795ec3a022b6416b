// A calibration run as text on a 100-column terminal: what `armsig calibrate` prints and
// the demo prints per stage. The parameter table in the paper's layout (Table 1-3: a, b, c
// in mm, α, β, γ in 1e-3 rad, one column per link), its sigmas, the non-geometric terms,
// what is not identifiable and why, and the error distances.
#pragma once

#include <string>

#include "calibration/model.h"
#include "workflows/calibration_run.h"

namespace armsig::workflows {

// Every line at most kTextWidth columns (a longer path or name excepted).
inline constexpr int kTextWidth = 100;

std::string FormatCalibrationReport(const calibration::RobotModel& model,
                                    const CalibrationRun& run);

// The parts, in the order the report prints them.
// Values (`sigmas` false: three decimals) or their sigmas (two significant digits): a
// block per group of links that fits the width. "—": not identifiable from these data,
// "off": not asked for (--params); the last column (the tool) has lengths only.
std::string ParameterTableText(const calibration::RobotModel& model, const CalibrationRun& run,
                               bool sigmas);
// One line per non-geometric term asked for: "h1 = -0.185 × 10⁻³ rad (σ 0.0021)".
std::string NonGeometricText(const calibration::RobotModel& model, const CalibrationRun& run);
// Rank warnings, frozen joints, the parameters left out and what each depends on, the
// condition number, the selection, the F-tests of --params auto, blunders, convergence.
std::string IdentifiabilityText(const calibration::RobotModel& model, const CalibrationRun& run);
// The error distances (nominal, calibrated; fit, validation) and the residual map's
// decision, said once.
std::string ErrorDistanceText(const CalibrationRun& run);

}  // namespace armsig::workflows
