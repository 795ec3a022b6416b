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

// SQLiteCpp's exception as a DatabaseError (busy and locked are transient).
[[noreturn]] void ThrowSqliteError(const std::string& name, const std::exception& e);

}  // namespace armsig::db
