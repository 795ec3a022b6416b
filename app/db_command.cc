// armsig db init | info | export TABLE --csv [--out FILE] | push --to TARGET
#include <fmt/format.h>

#include <iostream>

#include "app/command.h"
#include "core/wording.h"
#include "core/text.h"
#include "db/push.h"
#include "io/atomic_file.h"

namespace armsig::app {

void SetupDbCommand(CLI::App& parent, const GlobalOptions& global, Runner& run) {
  auto* db = parent.add_subcommand("db", "Inspect or export the database");
  db->require_subcommand(1);
  // `init` makes a new, empty lab database (or says the file already is one); `info` and
  // `export` only read: a missing file is refused, never created.
  auto* init = db->add_subcommand("init", "Create an empty lab database (schema of this armsig)");
  init->callback([&run, &global] {
    run = [&global] {
      db::Database database(global.DbPath());
      std::cout << Printable(database.path())
                << (database.created() ? ": new armsig database, schema v"
                                       : ": already an armsig database, schema v")
                << database.SchemaVersion() << "\n";
      return kOk;
    };
  });
  auto* info = db->add_subcommand("info", "Schema version and row counts of every table");
  OnDatabaseToRead(info, global, run, [](db::Database& database) {
    std::cout << "database      " << Printable(database.path()) << "\n"
              << "schema        v" << database.SchemaVersion() << "\n";
    for (const auto& count : database.RowCounts()) {
      std::cout << "  " << count.table << std::string(24 - count.table.size(), ' ') << count.rows
                << "\n";
    }
    return kOk;
  });
  auto table = std::make_shared<std::string>(), out = std::make_shared<std::string>();
  auto* exp = db->add_subcommand("export", "Export one table as CSV");
  exp->add_option("table", *table, "Table name")->required();
  exp->add_flag("--csv")->description("CSV output (the default and only format)");
  OutputFile(exp->add_option("--out", *out, "Write to this file instead of stdout"));
  OnDatabaseToRead(exp, global, run, [table, out](db::Database& database) {
    const std::string csv = database.ExportCsv(*table);
    if (out->empty())
      std::cout << csv;
    else
      io::WriteFileAtomically(*out, csv);
    return kOk;
  });

  // push: the cell's finished sessions and parameter sets into a central store.
  auto to = std::make_shared<std::string>();
  auto* push = db->add_subcommand(
      "push",
      "Copy this database's finished sessions and parameter sets into another store "
      "(idempotent: run it again, nothing doubles; an interrupted push resumes)");
  StoreOption(push->add_option(
                  "--to", *to,
                  "The central store: a PostgreSQL URI or key/value string, or an SQLite file"))
      ->required();
  OnExistingDatabase(push, global, run, [to](db::Database& source) {
    db::Database target(*to, db::OpenMode::kCreate);
    db::Connection& into = target.connection();
    db::PushOptions options;
    options.source_name = source.path();
    options.stop = &StopRequested();
    const db::PushSummary s = db::Push(source.connection(), into, options);
    std::cout << fmt::format(
        "pushed {} ({}, {}, {}) and {} to {}; {} and {} were there already\n",
        Count(s.sessions_pushed, "session"), Count(s.poses, "pose"),
        Count(s.observations, "observation"), Count(s.points, "point"),
        Count(s.sets_pushed, "parameter set"), Printable(into.name()),
        Count(s.sessions_present, "session"), Count(s.sets_present, "set"));
    if (s.stream_rows)
      std::cout << fmt::format("with the raw streams of the sessions measured on the move: {} rows\n",
                               s.stream_rows);
    if (s.robots_created) std::cout << fmt::format("new robots there: {}\n", s.robots_created);
    for (const auto& v : s.versions) std::cout << "  parameter set " << Printable(v) << " there\n";
    if (s.activations_pushed)
      std::cout << fmt::format("activations (the history of active sets) pushed: {}\n",
                               s.activations_pushed);
    if (s.activated) std::cout << fmt::format("active sets made active there: {}\n", s.activated);
    for (const auto& open : s.open_sessions)
      std::cout << "  not pushed, still open: " << Printable(open) << " (pushed once finished)\n";
    if (s.stopped) {
      std::cout << "stopped: what was pushed is complete; run it again to push the rest\n";
      return kStopped;
    }
    return kOk;
  });
}

}  // namespace armsig::app
