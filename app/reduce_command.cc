// armsig reduce [--session ID]: batch reduction of stored raw observations into reduced
// points, one transaction per session, idempotent (a rerun replaces the points).
#include <iostream>

#include "app/command.h"
#include "workflows/reduce.h"

namespace armsig::app {

void SetupReduceCommand(CLI::App& parent, const GlobalOptions& global, Runner& run) {
  auto session = std::make_shared<int64_t>(0);
  auto no_reject = std::make_shared<bool>(false);
  auto* sub = parent.add_subcommand(
      "reduce", "Reduce stored raw observations into points (per session, idempotent)");
  NumberOption(sub->add_option("--session", *session, "Session id (default: every session)"), 1,
               kMaxId);
  sub->add_flag("--no-reject", *no_reject, "Report blunders but keep every ray");
  OnExistingDatabase(sub, global, run, [session, no_reject](db::Database& database) {
    const auto summaries = workflows::ReduceSessions(database, *session, !*no_reject);
    std::cout << workflows::FormatReduceSummaries(summaries, database.path());
    return kOk;
  });
}

}  // namespace armsig::app
