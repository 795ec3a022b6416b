// armsig db info | export TABLE --csv [--out FILE]
#include <iostream>

#include "app/command.h"
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
      std::cout << database.path()
                << (database.created() ? ": new armsig database, schema v"
                                       : ": already an armsig database, schema v")
                << database.SchemaVersion() << "\n";
      return kOk;
    };
  });
  auto* info = db->add_subcommand("info", "Schema version and row counts of every table");
  OnDatabaseToRead(info, global, run, [](db::Database& database) {
    std::cout << "database      " << database.path() << "\n"
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
}

}  // namespace armsig::app
