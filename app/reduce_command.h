#pragma once

#include <cstdint>

#include "app/command.h"
#include "db/database.h"
#include "reduction/intersection.h"

namespace armsig::app {

struct ReduceSummary {
  int64_t session = 0;
  int64_t observations = 0;
  int64_t reduced = 0, failed = 0, rejected_rays = 0;
};

// Reduces one session's observations into its points table (one transaction).
ReduceSummary ReduceSession(db::Database& database, int64_t session_id,
                            const reduction::IntersectionOptions& options);

void SetupImportObservations(CLI::App& import, const GlobalOptions& global, Runner& run);

}  // namespace armsig::app
