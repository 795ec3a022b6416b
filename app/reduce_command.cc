// armsig reduce [--session ID]: batch reduction of stored raw observations into reduced
// points, one transaction per session, idempotent (a rerun replaces the points).
// armsig import observations OBS.csv --stations STATIONS.yaml: a file into a new session.
#include "app/reduce_command.h"

#include <fmt/format.h>

#include <iostream>

#include "workflows/reduce.h"

namespace armsig::app {

void SetupReduceCommand(CLI::App& parent, const GlobalOptions& global, Runner& run) {
  auto session = std::make_shared<int64_t>(0);
  auto no_reject = std::make_shared<bool>(false);
  auto* sub = parent.add_subcommand(
      "reduce", "Reduce stored raw observations into points (per session, idempotent)");
  sub->add_option("--session", *session, "Session id (default: every session)")
      ->check(CLI::PositiveNumber);
  sub->add_flag("--no-reject", *no_reject, "Report blunders but keep every ray");
  sub->callback([&run, &global, session, no_reject] {
    run = [&global, session, no_reject] {
      db::Database database(global.DbPath(), db::OpenMode::kMustExist);
      const auto summaries = workflows::ReduceSessions(database, *session, !*no_reject);
      std::cout << workflows::FormatReduceSummaries(summaries, database.path());
      return kOk;
    };
  });
}

void SetupImportObservations(CLI::App& import, const GlobalOptions& global, Runner& run) {
  auto o = std::make_shared<workflows::ImportObservationsOptions>();
  auto* sub = import.add_subcommand(
      "observations",
      "Angle observations CSV (optional 'pose' column) into a new session, with "
      "the stations' set-ups");
  sub->add_option("file", o->file, "Observations CSV")->required();
  sub->add_option("--stations", o->stations, "Stations YAML")->required();
  NameOption(sub->add_option("--robot", o->robot, "Robot name"))->capture_default_str();
  NoteOption(sub->add_option("--note", o->note, "Session note"));
  sub->callback([&run, &global, o] {
    run = [&global, o] {
      db::Database database(global.DbPath());
      const auto r = workflows::ImportObservations(database, *o);
      std::cout << fmt::format(
          "session {}: {} observations, {} stations, {} poses imported into {}\n", r.session,
          r.observations, r.stations, r.poses, database.path());
      return kOk;
    };
  });
}

}  // namespace armsig::app
