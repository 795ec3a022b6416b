#include "support/postgres_server.h"

#include <netinet/in.h>
#include <pwd.h>
#include <signal.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <array>
#include <atomic>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <memory>
#include <random>
#include <sstream>
#include <stdexcept>
#include <vector>

namespace armsig::testing {

namespace {

std::string Quote(const std::string& word) {
  std::string out = "'";
  for (char c : word) out += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return out + "'";
}

// Debian installs the server programs under /usr/lib/postgresql/<major>/bin.
std::string FindBinDir() {
  std::string best;
  int best_major = -1;
  std::error_code ec;
  for (const auto& entry : std::filesystem::directory_iterator("/usr/lib/postgresql", ec)) {
    const auto bin = entry.path() / "bin";
    if (!std::filesystem::exists(bin / "initdb") || !std::filesystem::exists(bin / "pg_ctl"))
      continue;
    const int major = std::atoi(entry.path().filename().c_str());
    if (major > best_major) {
      best_major = major;
      best = bin.string();
    }
  }
  return best;
}

// A TCP port nobody listens on now (the kernel's pick for port 0); the server's socket
// file is named after it too.
int FreeTcpPort() {
  const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  socklen_t size = sizeof a;
  int port = 0;
  if (fd >= 0 && ::bind(fd, reinterpret_cast<sockaddr*>(&a), sizeof a) == 0 &&
      ::getsockname(fd, reinterpret_cast<sockaddr*>(&a), &size) == 0)
    port = ntohs(a.sin_port);
  if (fd >= 0) ::close(fd);
  if (port == 0) port = 20000 + static_cast<int>(std::random_device{}() % 20000);
  return port;
}

std::string ReadFile(const std::string& path) {
  std::ifstream in(path);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

}  // namespace

constexpr const char* kFixtureVariable = "ARMSIG_TEST_POSTGRES";

PostgresServer& PostgresServer::Shared() {
  static const std::unique_ptr<PostgresServer> server([] {
    const char* fixture = std::getenv(kFixtureVariable);
    return fixture && *fixture ? new PostgresServer(fixture, /*attach=*/true)
                               : new PostgresServer("", /*attach=*/false);
  }());
  return *server;
}

void PostgresServer::StartDetached(const std::string& dir) {
  PostgresServer server(dir, /*attach=*/false);
  std::ofstream(dir + "/server.env") << server.port_ << "\n";
  server.started_ = false;  // outlives this object: StopDetached ends it
}

void PostgresServer::StopDetached(const std::string& dir) {
  PostgresServer server(dir, /*attach=*/true);
  server.started_ = true;  // stopped and removed by the destructor
}

std::string PostgresServer::Run(const std::string& command) const {
  const std::string full =
      (run_as_.empty() ? command : "runuser -u " + run_as_ + " -- " + command) + " 2>&1";
  std::array<char, 4096> buffer{};
  std::string out;
  FILE* pipe = ::popen(full.c_str(), "r");
  if (!pipe) throw std::runtime_error("cannot run " + full);
  while (size_t n = std::fread(buffer.data(), 1, buffer.size(), pipe)) out.append(buffer.data(), n);
  const int status = ::pclose(pipe);
  if (!WIFEXITED(status) || WEXITSTATUS(status) != 0)
    throw std::runtime_error("PostgreSQL test server: `" + full + "` failed:\n" + out);
  return out;
}

PostgresServer::PostgresServer(std::string dir, bool attach) {
  bin_ = FindBinDir();
  if (bin_.empty()) {
    throw std::runtime_error(
        "PostgreSQL test server: no server programs under /usr/lib/postgresql/*/bin "
        "(install Debian's `postgresql` package: scripts/setup.sh does)");
  }
  if (::geteuid() == 0) {
    // initdb refuses to run as root: the package's own unprivileged account runs it.
    if (!::getpwnam("postgres"))
      throw std::runtime_error("PostgreSQL test server: running as root and no `postgres` user");
    run_as_ = "postgres";
  }
  if (attach) {
    dir_ = dir;
    std::ifstream env(dir_ + "/server.env");
    if (!(env >> port_)) {
      throw std::runtime_error("PostgreSQL test server: $" + std::string(kFixtureVariable) + "=" +
                               dir_ +
                               " names no running server (its fixture, "
                               "armsig_test_postgres start, failed or did not run)");
    }
    return;
  }
  if (dir.empty()) {
    std::string dir_template = "/tmp/armsig-pg-XXXXXX";
    if (!::mkdtemp(dir_template.data()))
      throw std::runtime_error("PostgreSQL test server: cannot make a temporary directory");
    dir_ = dir_template;
  } else {
    dir_ = dir;
    std::error_code ec;
    if (!std::filesystem::create_directory(dir_, ec)) {
      throw std::runtime_error("PostgreSQL test server: cannot make " + dir_ +
                               (ec ? " (" + ec.message() + ")" : " (it exists)"));
    }
  }
  if (!run_as_.empty()) {
    const passwd* pw = ::getpwnam(run_as_.c_str());
    if (::chown(dir_.c_str(), pw->pw_uid, pw->pw_gid) != 0)
      throw std::runtime_error("PostgreSQL test server: cannot give " + dir_ + " to " + run_as_);
  }
  port_ = FreeTcpPort();
  const std::string data = dir_ + "/data";
  Run(Quote(bin_ + "/initdb") + " -D " + Quote(data) + " -U " + superuser_ +
      " -A trust -E UTF8 --no-sync --no-instructions");
  // TLS on loopback TCP for the security tests: a self-signed certificate for localhost,
  // and the role kTlsRole admitted only over TLS with its password (every other role: trust,
  // on the socket as before).
  Run("openssl req -x509 -newkey rsa:2048 -nodes -days 2 -subj /CN=localhost -keyout " +
      Quote(data + "/server.key") + " -out " + Quote(data + "/server.crt"));
  Run("chmod 600 " + Quote(data + "/server.key"));
  const std::string hba = ReadFile(data + "/pg_hba.conf");
  {
    std::ofstream out(dir_ + "/pg_hba.conf");
    out << "hostssl all " << kTlsRole << " 127.0.0.1/32 scram-sha-256\n"
        << "host all " << kTlsRole << " 127.0.0.1/32 reject\n"
        << hba;
  }
  Run("cp " + Quote(dir_ + "/pg_hba.conf") + " " + Quote(data + "/pg_hba.conf"));
  StartProcess();
  started_ = true;
  Psql("postgres",
       std::string("CREATE ROLE ") + kTlsRole + " LOGIN PASSWORD '" + kTlsPassword + "'");
}

void PostgresServer::StartProcess() {
  try {
    Run(Quote(bin_ + "/pg_ctl") + " -D " + Quote(dir_ + "/data") + " -l " +
        Quote(dir_ + "/server.log") + " -w -t 60 -o " +
        Quote("-k " + dir_ + " -p " + std::to_string(port_) +
              " -c listen_addresses=127.0.0.1 -c ssl=on -c fsync=off -c max_connections=200"
              " -c max_wal_size=96MB -c min_wal_size=32MB") +
        " start");
  } catch (const std::exception& e) {
    throw std::runtime_error(std::string(e.what()) + "\nserver log:\n" +
                             ReadFile(dir_ + "/server.log"));
  }
}

std::unique_ptr<PostgresServer> PostgresServer::StartPrivate() {
  return std::unique_ptr<PostgresServer>(new PostgresServer("", /*attach=*/false));
}

void PostgresServer::Stop() {
  Run(Quote(bin_ + "/pg_ctl") + " -D " + Quote(dir_ + "/data") + " -m fast -w stop");
}

void PostgresServer::Start() { StartProcess(); }

void PostgresServer::SignalAll(int signal) {
  // The postmaster's pid is the first line of postmaster.pid; its children are the rest.
  std::ifstream pid_file(dir_ + "/data/postmaster.pid");
  pid_t postmaster = 0;
  if (!(pid_file >> postmaster) || postmaster <= 0)
    throw std::runtime_error("PostgreSQL test server: no postmaster.pid in " + dir_);
  std::vector<pid_t> pids{postmaster};
  for (const auto& entry : std::filesystem::directory_iterator("/proc")) {
    const std::string name = entry.path().filename();
    if (name.find_first_not_of("0123456789") != std::string::npos) continue;
    std::ifstream stat(entry.path() / "stat");
    std::string line;
    std::getline(stat, line);
    const size_t close = line.rfind(')');
    if (close == std::string::npos) continue;
    std::istringstream rest(line.substr(close + 2));
    char state = 0;
    pid_t parent = 0;
    if (rest >> state >> parent && parent == postmaster) pids.push_back(std::stoi(name));
  }
  for (const pid_t pid : pids) ::kill(pid, signal);
}

PostgresServer::~PostgresServer() {
  if (!started_) {  // attached to a fixture's server, or left running for one
    // The shared server outlives this process: the databases it made here go with it (each test's
    // 7.5 MB or more stayed until the suite ended, and a CI machine's disk filled mid-suite). FORCE ends a
    // connection a child process or a leaked handle still holds.
    for (const auto& [pid, name] : databases_) {
      if (pid != ::getpid()) continue;  // a forked child's exit leaves its parent's alone
      try {
        Psql("postgres", "DROP DATABASE IF EXISTS \"" + name + "\" WITH (FORCE)");
      } catch (...) {
      }
    }
    return;
  }
  try {
    Run(Quote(bin_ + "/pg_ctl") + " -D " + Quote(dir_ + "/data") + " -m immediate -w stop");
  } catch (...) {
  }
  std::error_code ec;
  if (!dir_.empty()) std::filesystem::remove_all(dir_, ec);
}

std::string PostgresServer::Uri(const std::string& database, const std::string& user) const {
  return "postgresql:///" + database + "?host=" + dir_ + "&port=" + std::to_string(port_) +
         "&user=" + (user.empty() ? superuser_ : user);
}

std::string PostgresServer::TlsUri(const std::string& database, const std::string& sslmode) const {
  return "postgresql://" + std::string(kTlsRole) + "@localhost:" + std::to_string(port_) + "/" +
         database + "?sslmode=" + sslmode;
}

std::string PostgresServer::Psql(const std::string& database, const std::string& sql) const {
  return Run("psql -X -q -At -v ON_ERROR_STOP=1 -h " + Quote(dir_) + " -p " +
             std::to_string(port_) + " -U " + superuser_ + " -d " + Quote(database) + " -c " +
             Quote(sql));
}

std::string PostgresServer::NewDatabase(const std::string& base, std::string* name) {
  static std::atomic<int> count{0};
  const std::string unique = base + "_" + std::to_string(::getpid()) + "_" + std::to_string(++count);
  Psql("postgres", "CREATE DATABASE \"" + unique + "\"");
  databases_.emplace_back(::getpid(), unique);
  if (name) *name = unique;
  return Uri(unique);
}

}  // namespace armsig::testing
