#include "db/sqlite_connection.h"

#include <SQLiteCpp/Statement.h>
#include <sqlite3.h>

#include <cmath>

namespace armsig::db {

void ThrowSqliteError(const std::string& name, const std::exception& e) {
  if (const auto* s = dynamic_cast<const SQLite::Exception*>(&e)) {
    const int code = s->getErrorCode();
    throw DatabaseError(name + ": " + s->what() + " (SQLite code " + std::to_string(code) + ")",
                        std::to_string(code), code == SQLITE_BUSY || code == SQLITE_LOCKED);
  }
  throw DatabaseError(name + ": " + e.what(), "", false);
}

namespace {

class SqliteStatement : public Statement {
 public:
  SqliteStatement(SQLite::Database& db, std::string_view sql, const std::string& name)
      : name_(name) {
    try {
      s_.emplace(db, std::string(sql));
    } catch (const std::exception& e) {
      ThrowSqliteError(name_, e);
    }
  }

  void BindNull(int index) override {
    Ready();
    s_->bind(index);
  }
  void Bind(int index, int64_t value) override {
    Ready();
    s_->bind(index, static_cast<int64_t>(value));
  }
  void Bind(int index, double value) override {
    Ready();
    if (std::isfinite(value))
      s_->bind(index, value);
    else
      s_->bind(index);
  }
  void Bind(int index, std::string_view text) override {
    Ready();
    s_->bind(index, std::string(text));
  }
  void BindBlob(int index, std::string_view bytes) override {
    Ready();
    s_->bind(index, bytes.data(), static_cast<int>(bytes.size()));
  }

  bool Step() override {
    try {
      ran_ = true;
      return s_->executeStep();
    } catch (const std::exception& e) {
      ThrowSqliteError(name_, e);
    }
  }
  int64_t Execute() override {
    try {
      ran_ = true;
      while (s_->executeStep()) {
      }
      return s_->getChanges();
    } catch (const std::exception& e) {
      ThrowSqliteError(name_, e);
    }
  }

  int Columns() const override { return s_->getColumnCount(); }
  std::string ColumnName(int column) const override { return s_->getColumnName(column); }
  Type ColumnType(int column) const override {
    const auto c = s_->getColumn(column);
    if (c.isNull()) return Type::kNull;
    if (c.isInteger()) return Type::kInteger;
    if (c.isFloat()) return Type::kReal;
    if (c.isBlob()) return Type::kBlob;
    return Type::kText;
  }
  bool IsNull(int column) const override { return s_->isColumnNull(column); }
  int64_t Int(int column) const override { return s_->getColumn(column).getInt64(); }
  double Double(int column) const override { return s_->getColumn(column).getDouble(); }
  std::string Text(int column) const override { return s_->getColumn(column).getString(); }
  std::string Blob(int column) const override {
    const auto c = s_->getColumn(column);
    const auto* data = static_cast<const char*>(c.getBlob());
    return data ? std::string(data, static_cast<size_t>(c.getBytes())) : std::string();
  }

 private:
  // Binding after a run starts the next run.
  void Ready() {
    if (ran_) {
      s_->reset();
      ran_ = false;
    }
  }

  std::string name_;
  std::optional<SQLite::Statement> s_;
  bool ran_ = false;
};

}  // namespace

std::unique_ptr<Statement> SqliteConnection::Prepare(std::string_view sql) {
  return std::make_unique<SqliteStatement>(db_, sql, name_);
}

void SqliteConnection::Exec(std::string_view sql) {
  try {
    db_.exec(std::string(sql));
  } catch (const std::exception& e) {
    ThrowSqliteError(name_, e);
  }
}

void SqliteConnection::Begin(TransactionKind kind) {
  // IMMEDIATE takes the write lock at once, so a second writer waits its turn under the
  // busy timeout (a deferred transaction that read first could not wait when it writes).
  Exec(kind == TransactionKind::kWrite ? "BEGIN IMMEDIATE" : "BEGIN");
}

void SqliteConnection::Commit() { Exec("COMMIT"); }

void SqliteConnection::Rollback() { Exec("ROLLBACK"); }

}  // namespace armsig::db
