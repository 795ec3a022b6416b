// What the report reads from the store: the sessions behind a run with their instruments
// and orientations, the robot's versions with their activations, and how far each version
// moved the arm against the one before it.
#pragma once

#include <cstdint>
#include <vector>

#include "calibration/model.h"
#include "db/database.h"
#include "workflows/calibration_run.h"
#include "report/report_input.h"

namespace armsig::report {

// Every stored version of the robot with its drift flag and activations (schema v4).
std::vector<ReportHistoryPoint> ReportHistoryOf(db::Database& db, int64_t robot_id);

// The configurations spread over the work volume two sets are compared on (as the
// nightly job compares them).
inline constexpr int kReportDriftConfigurations = 50;
// Every stored version against the set its drift decision was taken against (the one
// active before it), else the version before it (DriftPointOf); `tolerance_mm` the drift
// gate to draw. A version of another model than `model` is left out.
ReportDrift ReportDriftOf(db::Database& db, const calibration::RobotModel& model, int64_t robot_id,
                          double tolerance_mm);

// The sessions behind the run's pose ids ("<session>:<label>", as db::LoadRobotPoses
// names them), with their dates, the instruments of their stored lab files and of the
// instruments table, and their stations' latest orientation.
ReportSources LoadReportSources(db::Database& db, const workflows::CalibrationRun& run);
// The same for sessions given by id (no pose counts): what the ISO 9283 page names.
ReportSources LoadReportSources(db::Database& db, const std::vector<int64_t>& session_ids);

}  // namespace armsig::report
