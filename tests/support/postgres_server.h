// A PostgreSQL server of the tests' own (Debian's `postgresql` package): initdb into a
// private temporary directory as an unprivileged user (the `postgres` account when the
// tests run as root, initdb refuses root; else the current user), listening on a Unix
// socket in that directory (and on loopback TCP with TLS, for the security tests). Nothing
// of the machine's own clusters is touched.
//
// Under ctest one server serves every test process: a fixture starts it before the first
// test that needs it (armsig_test_postgres start DIR) and stops it after the last, and the
// tests find it through $ARMSIG_TEST_POSTGRES=DIR. A test program run by hand, without that
// variable, starts a server of its own, stopped and removed when the program ends.
#pragma once

#include <sys/types.h>

#include <memory>
#include <string>
#include <utility>
#include <vector>

namespace armsig::testing {

class PostgresServer {
 public:
  // The process's one server: the fixture's ($ARMSIG_TEST_POSTGRES), else one started on
  // first use. Throws std::runtime_error with a loud message (what is missing, the server
  // log) when it cannot start or the fixture's cannot be found.
  static PostgresServer& Shared();
  // The fixture's two halves: a server in `dir` (made; must not exist) that outlives this
  // process, and its end (stopped, `dir` removed).
  static void StartDetached(const std::string& dir);
  static void StopDetached(const std::string& dir);
  // A server of the calling test's own, stopped and removed with the object: for tests that
  // stop, freeze or restart their server (the shared one serves every other test).
  static std::unique_ptr<PostgresServer> StartPrivate();
  ~PostgresServer();
  PostgresServer(const PostgresServer&) = delete;
  PostgresServer& operator=(const PostgresServer&) = delete;

  // A new, empty database on it, named `base` with this process's id and a count (test
  // processes share the server); returns its libpq URI
  // (postgresql:///NAME?host=SOCKET_DIR&port=PORT&user=SUPERUSER), and its name in `name`.
  std::string NewDatabase(const std::string& base, std::string* name = nullptr);
  // Its URI on the socket, as the superuser or as `user` (any role may log in there).
  std::string Uri(const std::string& database, const std::string& user = "") const;
  // The server also listens on 127.0.0.1:port() with TLS (ssl=on, a self-signed
  // certificate for CN=localhost, certificate_path()). kTlsRole (made with the server, its
  // password kTlsPassword) is admitted only over TLS with its password; its URI:
  // postgresql://armsig_tls@localhost:PORT/DATABASE?sslmode=MODE.
  static constexpr const char* kTlsRole = "armsig_tls";
  static constexpr const char* kTlsPassword = "s3cret-Horse-Battery";
  std::string TlsUri(const std::string& database, const std::string& sslmode) const;
  std::string certificate_path() const { return dir_ + "/data/server.crt"; }
  // Runs `sql` with psql as the superuser in `database`; returns psql's output.
  std::string Psql(const std::string& database, const std::string& sql) const;
  // Stops the server (pg_ctl stop -m fast: every connection ends) and starts it again on
  // the same port and data directory.
  void Stop();
  void Start();
  // Sends `signal` to every process of the server (SIGSTOP freezes it, SIGCONT thaws it).
  void SignalAll(int signal);
  const std::string& socket_dir() const { return dir_; }
  int port() const { return port_; }
  const std::string& superuser() const { return superuser_; }

 private:
  // Starts a server in `dir` (empty: a new temporary directory) or, `attach`, uses the one
  // a fixture started there.
  PostgresServer(std::string dir, bool attach);
  std::string Run(const std::string& command) const;  // as the server's user
  void StartProcess();

  std::string bin_, dir_, run_as_, superuser_ = "armsig_test";
  int port_ = 0;
  bool started_ = false;  // by this object: stopped and removed by it
  // Made by NewDatabase, with the process that made them: dropped with a shared server's handle.
  std::vector<std::pair<pid_t, std::string>> databases_;
};

}  // namespace armsig::testing
