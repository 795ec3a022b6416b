// The armsig SQLite file: WAL mode, foreign keys on, a busy timeout, and the schema
// brought to the latest version on open. Every SQLite error surfaces as
// SQLite::Exception (code + message); callers group related writes in one
// SQLite::Transaction.
#pragma once

#include <SQLiteCpp/SQLiteCpp.h>

#include <cstdint>
#include <string>
#include <vector>

namespace armsig::db {

struct OpenOptions {
  bool create = true;           // create the file if it does not exist
  bool migrate = true;          // apply forward migrations
  int busy_timeout_ms = 10000;  // wait this long for another writer's lock
};

class Database {
 public:
  // Opens (and creates/migrates) the file. Throws armsig::InputError when the path
  // cannot be opened or holds a schema newer than this program understands.
  explicit Database(const std::string& path, OpenOptions options = {});

  SQLite::Database& sql() { return db_; }
  const std::string& path() const { return path_; }
  int SchemaVersion();

  struct TableCount {
    std::string table;
    int64_t rows = 0;
  };
  std::vector<TableCount> RowCounts();

  // Whole table as CSV (header + rows), in primary-key order.
  // Throws armsig::InputError for an unknown table.
  std::string ExportCsv(const std::string& table);

 private:
  void Migrate();

  std::string path_;
  SQLite::Database db_;
};

}  // namespace armsig::db
