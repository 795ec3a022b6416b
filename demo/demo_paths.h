// ISO 9283 path characteristics on the demo's virtual UR10 (`demo --robot ur10 --on-the-move`):
// the standard's line (10 cycles) and rectangle (3 cycles) in a 300 mm cube around the arm's
// home target, each leg a linear move at 250 mm/s and 1.2 m/s² (URScript's movel defaults)
// computed by the controller's own inverse kinematics (simulation/path_motion.h), measured
// continuously by the virtual tracker through the emScon driver, before and after compensation
// of the vertices by a fitted set; the attained paths in the robot frame by that set's base.
#pragma once

#include <atomic>
#include <nlohmann/json.hpp>
#include <string>

#include "calibration/estimation.h"
#include "demo/demo_lab.h"
#include "io/lab_file.h"

namespace armsig::demo {

struct DemoPathFigures {
  // {"line": {"original": {...}, "compensated": {...}}, "rectangle": {...}}: cycles, AT_mm,
  // mean_AT_mm, RT_mm, AV_percent, RV_percent, FV_mm_s, planes (and CR_mm, CO_mm with corners).
  nlohmann::json json = nlohmann::json::object();
  std::string table;     // one line per path and program, for the narrative
  bool stopped = false;  // Ctrl-C between the runs
};

// Throws std::runtime_error when a vertex is out of reach or a leg has no joints.
DemoPathFigures MeasureIso9283Paths(const DemoLab& lab, const calibration::RobotModel& model,
                                    const calibration::EstimationResult& fit,
                                    const io::LabConfig& lab_config, const std::atomic<bool>* stop);

}  // namespace armsig::demo
