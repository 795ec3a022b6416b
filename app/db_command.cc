// armsig db info | export TABLE --csv [--out FILE]
#include <iostream>

#include "app/command.h"
#include "db/database.h"
#include "io/atomic_file.h"

namespace armsig::app {

struct DbOptions {
  std::string action;
  std::string table;
  bool csv = true;
  std::string out;
};

// `db info` creates a missing file: it is how a new lab database is made (and shows it).
int RunDbInfo(const GlobalOptions& global) {
  db::Database database(global.DbPath());
  std::cout << "database      " << database.path() << "\n"
            << "schema        v" << database.SchemaVersion() << "\n";
  for (const auto& count : database.RowCounts()) {
    std::cout << "  " << count.table << std::string(24 - count.table.size(), ' ') << count.rows
              << "\n";
  }
  return kOk;
}

int RunDbExport(const DbOptions& options, const GlobalOptions& global) {
  db::Database database(global.DbPath(), db::OpenMode::kMustExist);
  const std::string csv = database.ExportCsv(options.table);
  if (options.out.empty()) {
    std::cout << csv;
  } else {
    io::WriteFileAtomically(options.out, csv);
  }
  return kOk;
}

void SetupDbCommand(CLI::App& parent, const GlobalOptions& global, Runner& run) {
  auto* db = parent.add_subcommand("db", "Inspect or export the database");
  db->require_subcommand(1);
  auto options = std::make_shared<DbOptions>();
  auto* info = db->add_subcommand("info", "Schema version and row counts of every table");
  info->callback([&run, &global] { run = [&global] { return RunDbInfo(global); }; });
  auto* exp = db->add_subcommand("export", "Export one table");
  exp->add_option("table", options->table, "Table name")->required();
  exp->add_flag("--csv", options->csv, "CSV output (the default and only format)");
  OutputFile(exp->add_option("--out", options->out, "Write to this file instead of stdout"));
  exp->callback([&run, &global, options] {
    run = [&global, options] { return RunDbExport(*options, global); };
  });
}

}  // namespace armsig::app
