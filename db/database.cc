#include "db/database.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "core/error.h"
#include "db/schema.h"

namespace armsig::db {

namespace {

int OpenFlags(const OpenOptions& options) {
  return SQLite::OPEN_READWRITE | (options.create ? SQLite::OPEN_CREATE : 0) |
         SQLite::OPEN_FULLMUTEX;
}

SQLite::Database OpenOrExplain(const std::string& path, const OpenOptions& options) {
  try {
    return SQLite::Database(path, OpenFlags(options), options.busy_timeout_ms);
  } catch (const SQLite::Exception& e) {
    throw InputError({path, 0, 0, ""}, std::string("cannot open database (") + e.what() + ")");
  }
}

std::string CsvField(const SQLite::Column& column) {
  if (column.isNull()) return "";
  if (column.isInteger()) return std::to_string(column.getInt64());
  if (column.isFloat()) {
    char buffer[40];
    std::snprintf(buffer, sizeof buffer, "%.17g", column.getDouble());
    return buffer;
  }
  std::string text = column.getString();
  if (text.find_first_of(",\"\r\n") == std::string::npos) return text;
  std::string quoted = "\"";
  for (char c : text) {
    if (c == '"') quoted += '"';
    quoted += c;
  }
  return quoted + '"';
}

}  // namespace

Database::Database(const std::string& path, OpenOptions options)
    : path_(path), db_(OpenOrExplain(path, options)) {
  try {
    // WAL: readers never block the writer, and a killed writer leaves the last
    // committed state. synchronous=FULL so a commit also survives a power cut.
    db_.exec("PRAGMA journal_mode=WAL");
    db_.exec("PRAGMA synchronous=FULL");
    db_.exec("PRAGMA foreign_keys=ON");
  } catch (const SQLite::Exception& e) {
    throw InputError({path, 0, 0, ""},
                     std::string("not a usable SQLite database (") + e.what() + ")");
  }
  if (options.migrate) Migrate();
}

int Database::SchemaVersion() { return db_.execAndGet("PRAGMA user_version").getInt(); }

void Database::Migrate() {
  const int current = SchemaVersion();
  const int latest = LatestSchemaVersion();
  if (current > latest) {
    throw InputError({path_, 0, 0, ""}, "schema version " + std::to_string(current) +
                                            " is newer than this armsig understands (" +
                                            std::to_string(latest) + ")");
  }
  if (current == latest) return;
  // BEGIN IMMEDIATE takes the write lock first, so two processes opening a fresh
  // file at once cannot both migrate; the loser waits, then sees the new version.
  db_.exec("BEGIN IMMEDIATE");
  try {
    const int now = SchemaVersion();
    for (int v = now; v < latest; ++v) {
      db_.exec(std::string(Migrations()[v]));
    }
    db_.exec("PRAGMA user_version=" + std::to_string(latest));
    db_.exec("COMMIT");
  } catch (...) {
    db_.exec("ROLLBACK");
    throw;
  }
}

std::vector<Database::TableCount> Database::RowCounts() {
  std::vector<TableCount> counts;
  for (std::string_view table : TableNames()) {
    const std::string name(table);
    counts.push_back({name, db_.execAndGet("SELECT count(*) FROM " + name).getInt64()});
  }
  return counts;
}

std::string Database::ExportCsv(const std::string& table) {
  const auto tables = TableNames();
  if (std::find(tables.begin(), tables.end(), table) == tables.end()) {
    std::string known;
    for (std::string_view t : tables) known += (known.empty() ? "" : ", ") + std::string(t);
    throw InputError("unknown table '" + table + "' (expected one of: " + known + ")");
  }
  SQLite::Statement query(db_, "SELECT * FROM " + table + " ORDER BY rowid");
  std::string out;
  for (int c = 0; c < query.getColumnCount(); ++c) {
    out += (c ? "," : "") + std::string(query.getColumnName(c));
  }
  out += '\n';
  while (query.executeStep()) {
    for (int c = 0; c < query.getColumnCount(); ++c) {
      if (c) out += ',';
      out += CsvField(query.getColumn(c));
    }
    out += '\n';
  }
  return out;
}

}  // namespace armsig::db
