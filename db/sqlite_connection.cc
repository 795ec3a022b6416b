#include "db/sqlite_connection.h"

#include <SQLiteCpp/Statement.h>
#include <sqlite3.h>

#include <cerrno>
#include <cmath>
#include <cstring>

namespace armsig::db {

std::string SqliteSystemReason(sqlite3* handle, int code) {
  const int primary = code & 0xff;
  if (handle == nullptr || (primary != SQLITE_FULL && primary != SQLITE_IOERR &&
                            primary != SQLITE_CANTOPEN && primary != SQLITE_READONLY)) {
    return "";
  }
  const int error = sqlite3_system_errno(handle);
  if (error != 0) return std::strerror(error);
  // SQLite reports a short write as SQLITE_FULL and clears the errno it came with.
  return primary == SQLITE_FULL ? std::strerror(ENOSPC) : "";
}

void ThrowSqliteError(const std::string& name, const std::exception& e, sqlite3* handle) {
  if (const auto* s = dynamic_cast<const SQLite::Exception*>(&e)) {
    const int code = s->getErrorCode();
    std::string text = name + ": " + s->what();
    if (const std::string reason = SqliteSystemReason(handle, s->getExtendedErrorCode());
        !reason.empty()) {
      text += " (" + reason + ")";
    }
    text += " (SQLite code " + std::to_string(code) + ")";
    if (handle != nullptr && (code == SQLITE_FULL || code == SQLITE_IOERR) &&
        sqlite3_get_autocommit(handle) != 0) {
      text += "; the transaction was rolled back, nothing of it was stored";
    }
    throw DatabaseError(text, std::to_string(code), code == SQLITE_BUSY || code == SQLITE_LOCKED);
  }
  throw DatabaseError(name + ": " + e.what(), "", false);
}

namespace {

class SqliteStatement : public Statement {
 public:
  SqliteStatement(SQLite::Database& db, std::string_view sql, const std::string& name)
      : name_(name), handle_(db.getHandle()) {
    try {
      s_.emplace(db, std::string(sql));
    } catch (const std::exception& e) {
      ThrowSqliteError(name_, e, handle_);
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
      ThrowSqliteError(name_, e, handle_);
    }
  }
  int64_t Execute() override {
    try {
      ran_ = true;
      while (s_->executeStep()) {
      }
      return s_->getChanges();
    } catch (const std::exception& e) {
      ThrowSqliteError(name_, e, handle_);
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
  sqlite3* handle_;
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
    ThrowSqliteError(name_, e, db_.getHandle());
  }
}

void SqliteConnection::Begin(TransactionKind kind) {
  // IMMEDIATE takes the write lock at once, so a second writer waits its turn under the
  // busy timeout (a deferred transaction that read first could not wait when it writes).
  Exec(kind == TransactionKind::kWrite ? "BEGIN IMMEDIATE" : "BEGIN");
}

void SqliteConnection::Commit() { Exec("COMMIT"); }

void SqliteConnection::Rollback() {
  // After SQLITE_FULL or an I/O error SQLite may have rolled the transaction back itself: a
  // ROLLBACK then fails ("no transaction is active"), which is no news.
  if (sqlite3_get_autocommit(db_.getHandle()) != 0) return;
  Exec("ROLLBACK");
}

}  // namespace armsig::db
