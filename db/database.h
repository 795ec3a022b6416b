// The armsig store: an SQLite file (the embedded default, one per lab) or a PostgreSQL
// database (a plant's central server, `postgresql://…` or `host=… dbname=…`), behind one
// interface. Every statement of db/ runs through connection() (db/connection.h); the schema
// is brought to the latest version on open, by the same migrations on both backends.
//
// SQLite: WAL mode, foreign keys on, a busy timeout. A file is looked at read-only before
// anything is written to it: armsig's own databases carry PRAGMA application_id =
// kApplicationId (older armsig files, without it, are recognised by their user_version and
// tables and get it in their migration); another application's SQLite file, a schema newer
// than this program and a file that fails PRAGMA quick_check are refused as input errors and
// left byte for byte as they were (no -wal or -shm file is created next to them: a WAL-mode
// file with a -wal but no -shm, a copied one, is looked at in a private copy).
//
// PostgreSQL: the schema lives in the connection's current schema (search_path; a URI's
// `options=-csearch_path=NAME` puts it elsewhere), its version and armsig's mark in the
// table armsig_schema (the PRAGMAs' counterpart). A database that holds tables of armsig's
// names without that mark is refused, untouched. Migrations run in one transaction under an
// advisory lock, so that two processes opening a new store at once cannot both migrate.
// Credentials only from libpq's own places (db/postgres_connection.h).
#pragma once

#include <SQLiteCpp/SQLiteCpp.h>

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "db/connection.h"

namespace armsig::db {

enum class OpenMode {
  kCreate,     // a missing file becomes a new, empty database (commands that write)
  kMustExist,  // a missing file is an input error (commands that add to what is there)
  // Commands that only read: a missing or empty file (0 bytes, or SQLite without tables) is
  // an input error, nothing is created, initialised or written (the connection is
  // read-only; a file of an older schema is migrated in a private in-memory copy; a
  // PostgreSQL store of an older schema is refused: a writing command migrates it).
  kReadOnly,
};

struct OpenOptions {
  OpenMode mode = OpenMode::kCreate;
  bool migrate = true;          // apply forward migrations (kReadOnly: in the in-memory copy)
  int busy_timeout_ms = 10000;  // wait this long for another writer's lock
  // PostgreSQL: the longest a statement may run (statement_timeout) unless the address sets
  // one (db/postgres_connection.h); the client waits no longer for an answer. 0: by the
  // mode, 10 min for a command that only reads (a whole table exported), 60 s otherwise.
  int statement_timeout_ms = 0;
};

// PRAGMA application_id of an armsig database: "ARMS" in ASCII.
inline constexpr int32_t kApplicationId = 0x41524D53;

class Database {
 public:
  // Opens (and creates/migrates) the store: a file path, or a postgresql:// (postgres://)
  // URI. Throws armsig::InputError when the path cannot be opened, does not exist under
  // OpenMode::kMustExist (nothing is created), is not an SQLite file or another
  // application's (application_id), holds a schema newer than this program understands,
  // or fails its integrity check (PRAGMA quick_check; the message names the recovery
  // command); for a URI, when it carries a password, the database holds no armsig store
  // (kMustExist, kReadOnly) or tables of armsig's names it did not make. A refused store is
  // not written to. DatabaseError when the server cannot be reached.
  explicit Database(const std::string& location, OpenOptions options = {});
  Database(const std::string& location, OpenMode mode) : Database(location, OpenOptions{mode}) {}
  ~Database();
  Database(const Database&) = delete;
  Database& operator=(const Database&) = delete;

  // Every statement of db/ runs here.
  Connection& connection() { return *connection_; }
  Backend backend() const { return connection_->backend(); }
  // The SQLite handle, for what only SQLite has (PRAGMAs, the file's own checks and tests
  // that look at them). Throws std::logic_error for a PostgreSQL store.
  SQLite::Database& sql();
  // The file, or the URI without a password: what messages call the store.
  const std::string& path() const { return path_; }
  // Whether this process created the store (the file was missing or empty; the server
  // database had no armsig schema).
  bool created() const { return created_; }
  bool read_only() const { return read_only_; }
  // A command that only reads reads a file no connection has open immutable (nothing is
  // made beside it, so it works on read-only folders and mounts), under SQLite's shared
  // lock so that a writer that opens it meanwhile does not checkpoint into it when it
  // closes. Only a writer that fills its -wal past the checkpoint size (4 MB) while this
  // reads still changes the file: then this is true, and what was read may mix two states.
  bool ChangedWhileRead() const;
  int SchemaVersion();

  struct TableCount {
    std::string table;
    int64_t rows = 0;
  };
  std::vector<TableCount> RowCounts();

  // Whole table as CSV (header + rows), in insertion (primary-key) order; numbers as
  // %.17g, the same text from both backends. Throws armsig::InputError for an unknown table.
  std::string ExportCsv(const std::string& table);

 private:
  void OpenSqlite(const OpenOptions& options);
  void OpenPostgres(const std::string& uri, const OpenOptions& options);
  void Migrate();
  void MigrateOnce();
  void MigratePostgres(const OpenOptions& options);

  struct UnlockedRead;

  std::string path_;
  int busy_timeout_ms_ = 0;
  bool created_ = false;
  bool read_only_ = false;
  std::unique_ptr<UnlockedRead> unlocked_read_;  // a file read immutable: its lock, its state
  std::unique_ptr<SQLite::Database> sqlite_;     // SQLite only
  std::unique_ptr<Connection> connection_;       // declared after sqlite_: closed before it
};

// A write transaction; every write transaction of armsig is one of these. SQLite: BEGIN
// IMMEDIATE takes the write lock at its start, so a second writer waits its turn under the
// busy timeout (a deferred transaction that has read first cannot wait when it comes to
// write: SQLite refuses it at once with "database is locked" to avoid a deadlock).
// PostgreSQL: READ COMMITTED; writers of different rows go on at once, and what must not
// interleave takes a lock of its own (LockRobotForWrite). Rolled back unless committed.
class WriteTransaction {
 public:
  explicit WriteTransaction(Database& database)
      : tx_(database.connection(), TransactionKind::kWrite) {}
  void commit() { tx_.Commit(); }

 private:
  Transaction tx_;
};

// A consistent read of several statements while others write: one snapshot (SQLite: a
// read transaction in WAL mode; PostgreSQL: REPEATABLE READ READ ONLY). Reports and the
// readers of a whole session or robot use it.
class ReadSnapshot {
 public:
  explicit ReadSnapshot(Database& database)
      : tx_(database.connection(), TransactionKind::kSnapshot) {}
  void commit() { tx_.Commit(); }

 private:
  Transaction tx_;
};

// Inside a write transaction: waits until no other transaction writes the robot's
// versioned rows (parameter sets, the active set), until this one ends. PostgreSQL: a
// transaction advisory lock; SQLite: nothing (BEGIN IMMEDIATE already serialises writers).
void LockRobotForWrite(Connection& connection, int64_t robot_id);
// Inside a write transaction: waits until no other transaction writes the session's rows,
// and keeps writers of it (a capture's next configuration) waiting until this one ends.
// PostgreSQL: the session's row FOR UPDATE; SQLite: nothing (BEGIN IMMEDIATE).
void LockSessionForWrite(Database& database, int64_t session_id);
inline void LockRobotForWrite(Database& database, int64_t robot_id) {
  LockRobotForWrite(database.connection(), robot_id);
}

}  // namespace armsig::db
