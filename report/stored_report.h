// The report of a stored parameter set, rebuilt from the store alone: what `armsig report
// --robot R [--set N]` writes, and what the nightly job writes again when the report of
// the set it stored could not be written at the time.
#pragma once

#include <optional>
#include <string>

#include "db/database.h"

namespace armsig::report {

struct StoredReport {
  int version = 0;
  std::string path;           // DIR/index.html
  int missing_poses = 0;      // residual rows whose configuration is no longer stored
};

// Writes DIR/index.html (and its figures) for version `version` of the robot (the active
// one when nullopt): its parameters and sigmas, the configurations it was fitted and
// validated on with their stored residuals, its gates and decision as recorded, the change
// against the set active before it, and the robot's history. InputError for an unknown
// robot or version, or a set with no recorded residuals.
StoredReport WriteStoredReport(db::Database& database, const std::string& robot,
                               std::optional<int> version, const std::string& dir);

// Whether DIR holds the report of this robot's version (its index.html says so).
bool HasReportOf(const std::string& dir, const std::string& robot, int version);

}  // namespace armsig::report
