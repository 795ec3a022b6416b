// The PostgreSQL backend of db::Connection, on libpq (Debian's libpq5): a connection from
// any libpq URI (`postgresql://…`), every statement a server-side prepared statement
// cached per connection. Credentials come from where libpq looks (the environment,
// ~/.pgpass, the service file): a URI that carries a password is refused, so none ever
// stands on a command line, in a log or in a report. TLS as the URI asks (sslmode=…).
#pragma once

#include <map>
#include <memory>
#include <string>

#include "db/connection.h"

struct pg_conn;

namespace armsig::db {

// Whether `text` names a PostgreSQL database (postgresql:// or postgres://).
bool IsPostgresUri(const std::string& text);
// The URI without a password (for messages), e.g. postgresql://job@db.plant/armsig.
std::string RedactedUri(const std::string& uri);
// Throws InputError (naming --db) for a URI that carries a password or that libpq cannot
// parse; connects to nothing. Commands that do work before they open the store check
// their --db with it first.
void CheckPostgresUri(const std::string& uri);

class PostgresConnection : public Connection {
 public:
  // Throws InputError for a URI with a password; DatabaseError when it cannot connect.
  explicit PostgresConnection(const std::string& uri);
  ~PostgresConnection() override;
  PostgresConnection(const PostgresConnection&) = delete;
  PostgresConnection& operator=(const PostgresConnection&) = delete;

  Backend backend() const override { return Backend::kPostgres; }
  std::unique_ptr<Statement> Prepare(std::string_view sql) override;
  void Exec(std::string_view sql) override;
  void Begin(TransactionKind kind) override;
  void Commit() override;
  void Rollback() override;
  const std::string& name() const override { return name_; }

  pg_conn* raw() { return conn_; }
  // The prepared statement's name for `sql` (prepared on first use).
  const std::string& Prepared(const std::string& numbered_sql);

 private:
  pg_conn* conn_ = nullptr;
  std::string name_;
  std::map<std::string, std::string> prepared_;  // numbered SQL → statement name
};

}  // namespace armsig::db
