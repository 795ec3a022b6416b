// The SQLite backend of db::Connection, on SQLiteCpp (the file is opened and checked by
// db::Database; this wraps the open handle).
#pragma once

#include <SQLiteCpp/Database.h>

#include "db/connection.h"

namespace armsig::db {

class SqliteConnection : public Connection {
 public:
  SqliteConnection(SQLite::Database& db, std::string name) : db_(db), name_(std::move(name)) {}
  Backend backend() const override { return Backend::kSqlite; }
  std::unique_ptr<Statement> Prepare(std::string_view sql) override;
  void Exec(std::string_view sql) override;
  void Begin(TransactionKind kind) override;
  void Commit() override;
  void Rollback() override;
  const std::string& name() const override { return name_; }

 private:
  SQLite::Database& db_;
  std::string name_;
};

// SQLiteCpp's exception as a DatabaseError (busy and locked are transient). With the
// connection's handle, a failed system call behind it is named ("database or disk is full
// (No space left on device); the transaction was rolled back, nothing of it was stored").
[[noreturn]] void ThrowSqliteError(const std::string& name, const std::exception& e,
                                   sqlite3* handle = nullptr);
// The system's reason behind an SQLite error code, when there is one: "No space left on
// device" for SQLITE_FULL or an I/O error from ENOSPC; "" otherwise.
std::string SqliteSystemReason(sqlite3* handle, int code);

}  // namespace armsig::db
