// Reducing stored sessions, and bringing angle observations from a file into a session.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "db/database.h"
#include "io/csv.h"
#include "reduction/intersection.h"

namespace armsig::workflows {

struct ReduceSummary {
  int64_t session = 0;
  int64_t observations = 0;
  int64_t reduced = 0, failed = 0, rejected_rays = 0;
  // A session without observations: its stored points (measured, not reduced), kept.
  std::size_t kept_points = 0;
};

// The checks a session's points are flagged against: the tolerances of the lab file
// stored with it; none when it has none (an imported session), and then capture's
// flags are kept rather than re-derived. A stored lab file that no longer parses is an
// InputError naming the session.
reduction::PointChecks SessionChecks(db::Database& database, int64_t session_id);

// Reduces one session's observations into its points table (one transaction): every
// (pose, point) intersected by reduction::IntersectPoint with `options`. Flags the
// stored rays cannot give again (repeat_exceeded; miss_exceeded without a miss
// tolerance) are kept from the session's previously stored points
// (reduction::CarriedOverFlags). Mutual pointings at stations are not targets.
ReduceSummary ReduceSession(db::Database& database, int64_t session_id,
                            const reduction::PointOptions& options);

// `armsig reduce`: one session (`session` > 0; an InputError when it does not exist) or
// every session, each with its own stored checks.
std::vector<ReduceSummary> ReduceSessions(db::Database& database, int64_t session,
                                          bool reject_blunders);
// "session N: … observations -> … points reduced, … not (… rays rejected as blunders)".
std::string FormatReduceSummaries(const std::vector<ReduceSummary>& summaries,
                                  const std::string& db_path);

struct ImportObservationsOptions {
  std::string file;      // observations CSV (docs/reference/file-formats.md), `pose` optional
  std::string stations;  // stations YAML
  std::string robot = "unassigned";
  std::string note;
  io::ReadProgressFn progress;  // how far the file has been read
};

struct ImportObservationsResult {
  int64_t session = 0;
  size_t observations = 0, stations = 0, poses = 0;
};

// Reads and checks both files completely, then stores them as one new completed session
// in one transaction (nothing is stored when a file is refused).
ImportObservationsResult ImportObservations(db::Database& database,
                                            const ImportObservationsOptions& options);

}  // namespace armsig::workflows
