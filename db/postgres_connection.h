// The PostgreSQL backend of db::Connection, on libpq (Debian's libpq5): a connection to any
// server address db/postgres_address.h accepts (a URI or a key/value string; one with a
// password is refused), every statement a server-side prepared statement cached per
// connection. TLS as the address asks (sslmode=…).
//
// A server that stalls or goes away never holds a command indefinitely:
// - connecting gives up after connect_timeout (default 10 s; `connect_timeout=` in the
//   address or PGCONNECT_TIMEOUT set it); TCP keepalives are on (idle 30 s, every 10 s,
//   3 probes) and unacknowledged data is given up after tcp_user_timeout (60 s);
// - every statement runs under the command's statement_timeout and lock_timeout
//   (ServerTimeouts), set on the session unless the address (`options=-c
//   statement_timeout=…`), PGOPTIONS, the role or the database already set one;
// - the client waits for an answer no longer than that statement_timeout and a grace (a
//   quarter of it, 1 to 10 s): a server that accepts the statement and never answers (a
//   stopped process, a cut link) ends the wait with DatabaseError::connection_lost() and
//   the connection is closed. A statement_timeout of 0 (set by the user) waits without end.
// Each such failure, a lost connection and a server that cannot be reached are
// connection_lost(): the work may be retried once the server is back (nightly/worker.h).
#pragma once

#include <chrono>
#include <map>
#include <memory>
#include <string>

#include "db/connection.h"
#include "db/postgres_address.h"

struct pg_conn;
struct pg_result;

namespace armsig::db {

// A command's limits on a server (defaults: what most commands need).
struct ServerTimeouts {
  int connect_s = 10;        // libpq connect_timeout, unless the address or the environment sets it
  int statement_ms = 60000;  // statement_timeout
  int lock_ms = 10000;       // lock_timeout: the same 10 s as SQLite's busy timeout
};

class PostgresConnection : public Connection {
 public:
  // Throws InputError for an address with a password or one libpq cannot read;
  // DatabaseError (connection_lost) when it cannot connect.
  explicit PostgresConnection(const std::string& address, ServerTimeouts timeouts = {});
  ~PostgresConnection() override;
  PostgresConnection(const PostgresConnection&) = delete;
  PostgresConnection& operator=(const PostgresConnection&) = delete;

  Backend backend() const override { return Backend::kPostgres; }
  std::unique_ptr<Statement> Prepare(std::string_view sql) override;
  void Exec(std::string_view sql) override;
  void Begin(TransactionKind kind) override;
  void Commit() override;
  void Rollback() override;  // nothing to do on a lost connection: the server rolled back
  const std::string& name() const override { return name_; }

  // The session's statement_timeout from now on (0: none), and the client's wait with it;
  // a migration raises it for its own transaction. Does nothing when the user set the
  // statement timeout (the address, PGOPTIONS, the role or the database).
  void SetStatementTimeout(int ms);
  // The statement_timeout in force (ms; 0 = none) and whether armsig set it.
  int statement_timeout_ms() const { return statement_ms_; }
  bool timeouts_from_user() const { return !statement_timeout_ours_; }

  // Runs a prepared statement; the result (status checked) or DatabaseError.
  pg_result* ExecPrepared(const std::string& statement, int count, const char* const* values,
                          const int* lengths, const int* formats, const std::string& sql);
  // The prepared statement's name for `sql` (prepared on first use).
  const std::string& Prepared(const std::string& numbered_sql);

 private:
  void Connect(const std::string& address, const ServerTimeouts& timeouts);
  void ApplyTimeouts(const ServerTimeouts& timeouts);
  // After a PQsend…: waits (by the client deadline) for every result of the command and
  // returns the last one (or the first error), status checked against `what`.
  pg_result* Await(std::string_view what);
  void WaitForSocket(bool write, std::chrono::steady_clock::time_point deadline,
                     std::string_view what);
  [[noreturn]] void Lost(const std::string& why, std::string_view what);
  [[noreturn]] void ThrowResult(pg_result* result, std::string_view what);
  std::chrono::milliseconds ClientWait() const;

  pg_conn* conn_ = nullptr;
  std::string name_;
  std::map<std::string, std::string> prepared_;  // numbered SQL → statement name
  int statement_ms_ = 0;
  bool statement_timeout_ours_ = false;
  int prepared_count_ = 0;
};

}  // namespace armsig::db
