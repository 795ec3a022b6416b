// The armsig SQLite file: WAL mode, foreign keys on, a busy timeout, and the schema
// brought to the latest version on open. Every SQLite error surfaces as
// SQLite::Exception (code + message); callers group related writes in one
// WriteTransaction (BEGIN IMMEDIATE).
//
// A file is looked at read-only before anything is written to it: armsig's own databases
// carry PRAGMA application_id = kApplicationId (older armsig files, without it, are
// recognised by their user_version and tables and get it in their migration); another
// application's SQLite file, a schema newer than this program and a file that fails
// PRAGMA quick_check are refused as input errors and left byte for byte as they were
// (no -wal or -shm file is created next to them: a WAL-mode file with a -wal but no -shm,
// a copied one, is looked at in a private copy).
#pragma once

#include <SQLiteCpp/SQLiteCpp.h>
#include <SQLiteCpp/Transaction.h>

#include <cstdint>
#include <string>
#include <vector>

namespace armsig::db {

enum class OpenMode {
  kCreate,     // a missing file becomes a new, empty database (commands that write)
  kMustExist,  // a missing file is an input error (commands that add to what is there)
  // Commands that only read: a missing or empty file (0 bytes, or SQLite without tables) is
  // an input error, nothing is created, initialised or written (the connection is
  // read-only; a file of an older schema is migrated in a private in-memory copy).
  kReadOnly,
};

struct OpenOptions {
  OpenMode mode = OpenMode::kCreate;
  bool migrate = true;          // apply forward migrations (kReadOnly: in the in-memory copy)
  int busy_timeout_ms = 10000;  // wait this long for another writer's lock
};

// PRAGMA application_id of an armsig database: "ARMS" in ASCII.
inline constexpr int32_t kApplicationId = 0x41524D53;

class Database {
 public:
  // Opens (and creates/migrates) the file. Throws armsig::InputError when the path
  // cannot be opened, does not exist under OpenMode::kMustExist (nothing is created), is
  // not an SQLite file or another application's (application_id), holds a schema newer
  // than this program understands, or fails its integrity check (PRAGMA quick_check;
  // the message names the recovery command). A refused file is not written to.
  explicit Database(const std::string& path, OpenOptions options = {});
  Database(const std::string& path, OpenMode mode) : Database(path, OpenOptions{mode}) {}

  SQLite::Database& sql() { return db_; }
  const std::string& path() const { return path_; }
  // Whether this process created the file (it was missing or empty when opened).
  bool created() const { return created_; }
  bool read_only() const { return read_only_; }
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
  void MigrateOnce();

  std::string path_;
  int busy_timeout_ms_ = 0;
  bool created_ = false;
  bool read_only_ = false;
  SQLite::Database db_;
};

// A write transaction. BEGIN IMMEDIATE takes the write lock at its start, so a second
// writer waits its turn under the busy timeout; a deferred transaction that has read first
// cannot wait when it comes to write (SQLite refuses it at once with "database is locked"
// to avoid a deadlock). Every write transaction of armsig is one of these.
class WriteTransaction : public SQLite::Transaction {
 public:
  explicit WriteTransaction(Database& database)
      : SQLite::Transaction(database.sql(), SQLite::TransactionBehavior::IMMEDIATE) {}
};

}  // namespace armsig::db
