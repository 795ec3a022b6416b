// armsig reduce [--session ID]: batch reduction of stored raw observations into reduced
// points, one transaction per session, idempotent (a rerun replaces the points).
// armsig import observations OBS.csv --stations STATIONS.yaml: a file into a new session.
#include "app/reduce_command.h"

#include <fmt/format.h>

#include <iostream>

#include "core/error.h"
#include "db/store.h"
#include "workflows/reduce.h"

namespace armsig::app {

namespace {

struct ReduceOptions {
  int64_t session = 0;  // 0 = every session
  bool no_reject = false;
};

int RunReduce(const ReduceOptions& options, const GlobalOptions& global) {
  db::Database database(global.DbPath(), db::OpenMode::kMustExist);
  std::vector<int64_t> sessions;
  if (options.session > 0) {
    if (!db::SessionExists(database, options.session)) {
      throw InputError({database.path(), 0, 0, ""},
                       "no session " + std::to_string(options.session) + " in the database");
    }
    sessions.push_back(options.session);
  } else {
    sessions = db::SessionIds(database);
  }
  for (int64_t id : sessions) {
    reduction::PointOptions point_options;
    point_options.intersection.reject_blunders = !options.no_reject;
    point_options.checks = workflows::SessionChecks(database, id);
    const auto s = workflows::ReduceSession(database, id, point_options);
    std::cout << fmt::format(
        "session {}: {} observations -> {} points reduced, {} not ({} rays "
        "rejected as blunders)\n",
        id, s.observations, s.reduced, s.failed, s.rejected_rays);
  }
  if (sessions.empty()) std::cout << "no sessions in " << database.path() << "\n";
  return kOk;
}

}  // namespace

void SetupReduceCommand(CLI::App& parent, const GlobalOptions& global, Runner& run) {
  auto o = std::make_shared<ReduceOptions>();
  auto* sub = parent.add_subcommand(
      "reduce", "Reduce stored raw observations into points (per session, idempotent)");
  sub->add_option("--session", o->session, "Session id (default: every session)");
  sub->add_flag("--no-reject", o->no_reject, "Report blunders but keep every ray");
  sub->callback([&run, &global, o] { run = [&global, o] { return RunReduce(*o, global); }; });
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
