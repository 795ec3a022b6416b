// One interface to the two database backends armsig stores into: SQLite (the embedded
// default, one file per lab) and PostgreSQL (a plant's central server). db/ writes every
// statement once, in the SQL both understand, with `?` placeholders; each backend
// prepares it (PostgreSQL: `$1…$n`, a server-side prepared statement cached per
// connection) and maps its errors to DatabaseError.
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

namespace armsig::db {

enum class Backend { kSqlite, kPostgres };

// Any error a backend reports. `transient`: the statement lost a race with another writer
// (SQLite busy/locked after its timeout, PostgreSQL serialization failure or deadlock);
// the caller may retry the whole transaction. `connection_lost`: the server could not be
// reached, went away, restarted or stopped answering (db/postgres_connection.h); what the
// statement did is unknown, and the work may be retried on a new connection.
class DatabaseError : public std::runtime_error {
 public:
  DatabaseError(const std::string& message, std::string code, bool transient,
                bool connection_lost = false)
      : std::runtime_error(message),
        code_(std::move(code)),
        transient_(transient),
        connection_lost_(connection_lost) {}
  const std::string& code() const { return code_; }  // SQLite's result code or a SQLSTATE
  bool transient() const { return transient_; }
  bool connection_lost() const { return connection_lost_; }

 private:
  std::string code_;
  bool transient_;
  bool connection_lost_;
};

// Whether `error` is a fault of the infrastructure rather than of the work: a lost or
// unreachable server (connection_lost) or a lost race (transient). Work that failed so is
// retried, never recorded as failed.
bool IsInfrastructureFault(const std::exception& error);

// A prepared statement: bind (1-based), step through the rows, read columns (0-based).
// Binding again after the last row re-runs it with the new values.
class Statement {
 public:
  virtual ~Statement() = default;
  virtual void BindNull(int index) = 0;
  virtual void Bind(int index, int64_t value) = 0;
  virtual void Bind(int index, double value) = 0;  // NaN and ±inf bind as NULL
  virtual void Bind(int index, std::string_view text) = 0;
  virtual void BindBlob(int index, std::string_view bytes) = 0;
  void Bind(int index, int value) { Bind(index, static_cast<int64_t>(value)); }
  void Bind(int index, const char* text) { Bind(index, std::string_view(text)); }
  void Bind(int index, const std::string& text) { Bind(index, std::string_view(text)); }
  void Bind(int index, const std::optional<double>& value) {
    if (value)
      Bind(index, *value);
    else
      BindNull(index);
  }
  void Bind(int index, const std::optional<int64_t>& value) {
    if (value)
      Bind(index, *value);
    else
      BindNull(index);
  }

  // The next row; false when there is none. The first call runs the statement.
  virtual bool Step() = 0;
  // Runs a statement that returns no rows (or ignores them); returns the rows changed.
  virtual int64_t Execute() = 0;

  virtual int Columns() const = 0;
  // The column's name and the type of its value in the current row (NULL: kNull). Numbers
  // as SQL gives them: an integer column kInteger, a floating one kReal, on both backends.
  enum class Type { kNull, kInteger, kReal, kText, kBlob };
  virtual std::string ColumnName(int column) const = 0;
  virtual Type ColumnType(int column) const = 0;
  virtual bool IsNull(int column) const = 0;
  virtual int64_t Int(int column) const = 0;
  virtual double Double(int column) const = 0;
  virtual std::string Text(int column) const = 0;
  virtual std::string Blob(int column) const = 0;
  std::optional<double> OptionalDouble(int column) const {
    return IsNull(column) ? std::nullopt : std::optional<double>(Double(column));
  }
  std::optional<int64_t> OptionalInt(int column) const {
    return IsNull(column) ? std::nullopt : std::optional<int64_t>(Int(column));
  }
};

enum class TransactionKind {
  kWrite,     // SQLite BEGIN IMMEDIATE (the write lock at once); PostgreSQL READ COMMITTED
  kSnapshot,  // a consistent read: SQLite BEGIN (a read transaction sees one snapshot in
              // WAL mode); PostgreSQL REPEATABLE READ READ ONLY
};

class Connection {
 public:
  virtual ~Connection() = default;
  virtual Backend backend() const = 0;
  // The statement, prepared (cached by its text where the backend benefits).
  virtual std::unique_ptr<Statement> Prepare(std::string_view sql) = 0;
  // SQL without parameters or results (DDL, transaction control).
  virtual void Exec(std::string_view sql) = 0;
  virtual void Begin(TransactionKind kind) = 0;
  virtual void Commit() = 0;
  virtual void Rollback() = 0;
  // What to call it in messages: the file, or the URI without its password.
  virtual const std::string& name() const = 0;

  // Convenience: one value of a one-row query.
  int64_t QueryInt(std::string_view sql);
};

// `?` placeholders as PostgreSQL's `$1…$n` (outside quoted strings and identifiers), by
// SQLite's rules: `?NNN` is parameter NNN, a bare `?` the largest number so far plus one.
std::string NumberedPlaceholders(std::string_view sql);

// The id an `INSERT … RETURNING id` gives, the statement run to its end (SQLite keeps an
// unfinished statement open, and a transaction with one open cannot commit).
int64_t InsertedId(Statement& insert, const std::string& what);

// A transaction that rolls back unless committed.
class Transaction {
 public:
  Transaction(Connection& connection, TransactionKind kind);
  ~Transaction();
  void Commit();
  Transaction(const Transaction&) = delete;
  Transaction& operator=(const Transaction&) = delete;

 private:
  Connection& connection_;
  bool open_ = true;
};

}  // namespace armsig::db
