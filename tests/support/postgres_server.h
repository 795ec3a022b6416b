// A PostgreSQL server of the tests' own (Debian's `postgresql` package): initdb into a
// private temporary directory as an unprivileged user (the `postgres` account when the
// tests run as root, initdb refuses root; else the current user), listening on a Unix
// socket in that directory (and on loopback TCP with TLS, for the security tests), stopped
// and removed when the test process ends. Nothing of the machine's own clusters is touched.
#pragma once

#include <memory>
#include <string>

namespace armsig::testing {

class PostgresServer {
 public:
  // The process's one server, started on first use. Throws std::runtime_error with a
  // loud message (what is missing, the server log) when it cannot start.
  static PostgresServer& Shared();
  ~PostgresServer();
  PostgresServer(const PostgresServer&) = delete;
  PostgresServer& operator=(const PostgresServer&) = delete;

  // A new, empty database on it; returns its libpq URI
  // (postgresql:///NAME?host=SOCKET_DIR&port=PORT&user=SUPERUSER).
  std::string NewDatabase(const std::string& name);
  std::string Uri(const std::string& database) const;
  // The server also listens on 127.0.0.1:port() with TLS (ssl=on, a self-signed
  // certificate for CN=localhost, certificate_path()). kTlsRole (created by the test that
  // uses it, with a password) is admitted only over TLS with its password; its URI:
  // postgresql://armsig_tls@localhost:PORT/DATABASE?sslmode=MODE.
  static constexpr const char* kTlsRole = "armsig_tls";
  std::string TlsUri(const std::string& database, const std::string& sslmode) const;
  std::string certificate_path() const { return dir_ + "/data/server.crt"; }
  // Runs `sql` with psql as the superuser in `database`; returns psql's output.
  std::string Psql(const std::string& database, const std::string& sql) const;
  const std::string& socket_dir() const { return dir_; }
  int port() const { return port_; }
  const std::string& superuser() const { return superuser_; }

 private:
  PostgresServer();
  std::string Run(const std::string& command) const;  // as the server's user

  std::string bin_, dir_, run_as_, superuser_ = "armsig_test";
  int port_ = 0;
  bool started_ = false;
};

}  // namespace armsig::testing
