// The recalibration report: one self-contained HTML page (figures drawn with OpenCV,
// embedded as PNG data URIs) a technician would rather look at than read.
#pragma once

#include <string>
#include <vector>

#include "workflows/calibration_run.h"
#include "calibration/compensation.h"

namespace armsig::workflows {

struct ReportHistoryPoint {
  int version = 0;
  std::string created_at;
  double validation_mean_mm = 0.0;
};

struct ReportInput {
  std::string robot;
  int version = 0;                 // 0 when nothing was stored
  std::string decision;            // "stored as version 4" / "rejected: …"
  std::vector<std::string> gates;  // one line per gate with its figures
  const calibration::RobotModel* model = nullptr;
  const CalibrationRun* run = nullptr;
  std::vector<MeasuredPose> validation;  // same order as run->validation_residuals
  std::vector<ReportHistoryPoint> history;
  std::vector<calibration::ParameterChange> changes;  // against the previous active set
  bool drift = false;
};

// Writes DIR/index.html and DIR/*.png; returns the HTML path. Throws on I/O failure.
std::string WriteReport(const std::string& dir, const ReportInput& input);

}  // namespace armsig::workflows
