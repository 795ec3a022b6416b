#include "support/postgres_server.h"

#include <pwd.h>
#include <sys/wait.h>
#include <unistd.h>

#include <array>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>
#include <stdexcept>

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

std::string ReadFile(const std::string& path) {
  std::ifstream in(path);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

}  // namespace

PostgresServer& PostgresServer::Shared() {
  static PostgresServer server;
  return server;
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

PostgresServer::PostgresServer() {
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
  std::string dir_template = "/tmp/armsig-pg-XXXXXX";
  if (!::mkdtemp(dir_template.data()))
    throw std::runtime_error("PostgreSQL test server: cannot make a temporary directory");
  dir_ = dir_template;
  if (!run_as_.empty()) {
    const passwd* pw = ::getpwnam(run_as_.c_str());
    if (::chown(dir_.c_str(), pw->pw_uid, pw->pw_gid) != 0)
      throw std::runtime_error("PostgreSQL test server: cannot give " + dir_ + " to " + run_as_);
  }
  std::random_device rd;
  port_ = 20000 + static_cast<int>(rd() % 20000);  // names the socket file only (no TCP)
  const std::string data = dir_ + "/data";
  Run(Quote(bin_ + "/initdb") + " -D " + Quote(data) + " -U " + superuser_ +
      " -A trust -E UTF8 --no-sync --no-instructions");
  try {
    Run(Quote(bin_ + "/pg_ctl") + " -D " + Quote(data) + " -l " + Quote(dir_ + "/server.log") +
        " -w -t 60 -o " +
        Quote("-k " + dir_ + " -p " + std::to_string(port_) +
              " -c listen_addresses= -c fsync=off -c max_connections=200") +
        " start");
  } catch (const std::exception& e) {
    throw std::runtime_error(std::string(e.what()) + "\nserver log:\n" +
                             ReadFile(dir_ + "/server.log"));
  }
  started_ = true;
}

PostgresServer::~PostgresServer() {
  if (started_) {
    try {
      Run(Quote(bin_ + "/pg_ctl") + " -D " + Quote(dir_ + "/data") + " -m immediate -w stop");
    } catch (...) {
    }
  }
  std::error_code ec;
  if (!dir_.empty()) std::filesystem::remove_all(dir_, ec);
}

std::string PostgresServer::Uri(const std::string& database) const {
  return "postgresql:///" + database + "?host=" + dir_ + "&port=" + std::to_string(port_) +
         "&user=" + superuser_;
}

std::string PostgresServer::Psql(const std::string& database, const std::string& sql) const {
  return Run("psql -X -q -At -v ON_ERROR_STOP=1 -h " + Quote(dir_) + " -p " +
             std::to_string(port_) + " -U " + superuser_ + " -d " + Quote(database) + " -c " +
             Quote(sql));
}

std::string PostgresServer::NewDatabase(const std::string& name) {
  Psql("postgres", "CREATE DATABASE \"" + name + "\"");
  return Uri(name);
}

}  // namespace armsig::testing
