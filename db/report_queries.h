// Reads for the recalibration report: when the sessions behind a parameter set ran, and
// the instruments the database knows them by. Plain statements, no writes.
#pragma once

#include <cmath>
#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "db/database.h"
#include "db/sessions.h"

namespace armsig::db {

using ReportSession = SessionRow;
// The sessions with these ids, by id; ids without a session are left out.
std::vector<ReportSession> LoadReportSessions(Database& db,
                                                const std::vector<int64_t>& session_ids);

// The mean air temperature (°C) of each measured pose's readings that carry one (laser
// trackers), by "<session>:<label>" as db::LoadRobotPoses names the poses; poses without
// a temperature are left out.
std::map<std::string, double> PoseTemperatures(Database& db, const std::vector<int64_t>& session_ids);

// A row of the instruments table.
struct InstrumentSummary {
  std::string name, kind, protocol, serial_number, firmware;
  std::optional<double> sigma_hz_arcsec, sigma_v_arcsec, sigma_distance_mm;
  std::vector<std::string> stations;  // the codes of the stations it stood at in the session
};
// The instruments a session's observations name, or whose stations it observed from, with
// the stations each stood at.
std::vector<InstrumentSummary> SessionInstruments(Database& db, int64_t session_id);

// A stored parameter set's residuals (schema: validation_residuals), in stored order:
// each fit and validation configuration's error vector (model − measured, as fitted) and
// the nominal model's error distance there.
struct StoredResidual {
  std::string pose_label, role;  // role: fit | validation
  double dx_mm = 0.0, dy_mm = 0.0, dz_mm = 0.0, distance_mm = 0.0;
  double nominal_distance_mm = NAN;
};
std::vector<StoredResidual> LoadStoredResiduals(Database& db, int64_t calibration_id);

}  // namespace armsig::db
