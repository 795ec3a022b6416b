// Servers that stall or restart, through the binary as a plant meets them: an address that
// accepts TCP and never answers, a private PostgreSQL server stopped, frozen (SIGSTOP) and
// started again under a polling worker, a store that goes away under a SQLite queue.
#include <arpa/inet.h>
#include <fcntl.h>
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <signal.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <nlohmann/json.hpp>

#include "calibration/synthetic.h"
#include "db/database.h"
#include "support/postgres_server.h"
#include "support/simulated_sessions.h"
#include "test_support.h"

namespace armsig::testing {
namespace {

using Clock = std::chrono::steady_clock;
using namespace std::chrono_literals;

// A TCP port on 127.0.0.1 that accepts connections (the kernel completes the handshake
// into the listen backlog) and never reads or answers: a server that hangs.
class SilentListener {
 public:
  SilentListener() {
    fd_ = ::socket(AF_INET, SOCK_STREAM, 0);
    sockaddr_in a{};
    a.sin_family = AF_INET;
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    socklen_t size = sizeof a;
    EXPECT_EQ(::bind(fd_, reinterpret_cast<sockaddr*>(&a), sizeof a), 0);
    EXPECT_EQ(::listen(fd_, 64), 0);
    EXPECT_EQ(::getsockname(fd_, reinterpret_cast<sockaddr*>(&a), &size), 0);
    port_ = ntohs(a.sin_port);
  }
  ~SilentListener() { ::close(fd_); }
  int port() const { return port_; }

 private:
  int fd_ = -1;
  int port_ = 0;
};

struct Timed {
  int exit_code = -1;
  double seconds = 0;
  std::string err;
};

// Runs the binary and waits at most `limit` for it (killed after, exit_code −1).
Timed RunWithin(const std::vector<std::string>& args, std::chrono::seconds limit) {
  TempDir dir;
  const auto start = Clock::now();
  const pid_t pid = SpawnArmsig(args, dir.File("out"), dir.File("err"));
  int status = 0;
  const bool waited = WaitUntil([&] { return ::waitpid(pid, &status, WNOHANG) == pid; }, limit);
  Timed t;
  t.seconds = std::chrono::duration<double>(Clock::now() - start).count();
  if (!waited) {
    ::kill(pid, SIGKILL);
    ::waitpid(pid, &status, 0);
  } else if (WIFEXITED(status)) {
    t.exit_code = WEXITSTATUS(status);
  }
  t.err = ReadText(dir.File("err"));
  return t;
}

// A server address that accepts TCP and never answers ends `db info` within the connect
// timeout (10 s by default, `connect_timeout` in the address), naming the server: before,
// nothing ended the wait.
TEST(ServerOutage, AListenerThatNeverAnswersEndsDbInfoWithinTheConnectTimeout) {
  SilentListener silent;
  const std::string port = std::to_string(silent.port());
  const std::string uri = "postgresql://armsig@127.0.0.1:" + port + "/armsig";
  Timed t = RunWithin({"--db", uri, "db", "info"}, 60s);
  std::cout << "silent listener: db info returned after " << t.seconds << " s (default)\n";
  EXPECT_EQ(t.exit_code, 1) << t.err;
  EXPECT_GE(t.seconds, 9.5);  // the default connect timeout, 10 s
  EXPECT_LT(t.seconds, 30.0);
  EXPECT_NE(t.err.find(uri + ": cannot connect"), std::string::npos) << t.err;
  EXPECT_NE(t.err.find("timeout expired"), std::string::npos) << t.err;

  // The address sets its own; a key/value string is a server address too.
  for (const std::string& address :
       {uri + "?connect_timeout=2",
        "host=127.0.0.1 port=" + port + " dbname=armsig connect_timeout=2"}) {
    t = RunWithin({"--db", address, "db", "info"}, 60s);
    EXPECT_EQ(t.exit_code, 1) << t.err;
    EXPECT_GE(t.seconds, 1.5) << address;
    EXPECT_LT(t.seconds, 9.0) << address;
    EXPECT_NE(t.err.find(address + ": cannot connect"), std::string::npos) << t.err;
  }
}

// The worker's job listing, read from the worker's stdout ("job 2: puma: done — …").
bool Printed(const std::string& file, const std::string& text) {
  return ReadText(file).find(text) != std::string::npos;
}

// The private server is thawed and can stop whatever the test did to it.
struct Thaw {
  PostgresServer& server;
  ~Thaw() { server.SignalAll(SIGCONT); }
};

// One polling worker through a server restart and a frozen server (SIGSTOP): it waits
// them out and goes on with the next job each time; before, a restart ended it (exit 1)
// and a frozen server held it for good.
TEST(ServerOutage, APollingWorkerRidesOutARestartAndAFrozenServer) {
  TempDir dir;
  const auto server = PostgresServer::StartPrivate();
  Thaw thaw{*server};
  // Short limits in the address: statements 2 s (the client gives up after 3 s), connects 2 s.
  const std::string uri =
      server->NewDatabase("outage") + "&connect_timeout=2&options=-c%20statement_timeout%3D2000";
  {
    db::Database database(uri);
    AddSession(database, calibration::PaperTable3Parameters(), 60, 5);
  }
  auto schedule = [&] {
    const auto r = RunArmsig("--db '" + uri +
                             "' schedule recalibrate --robot puma "
                             "--residual-model off --force");
    ASSERT_EQ(r.exit_code, 0) << r.err;
  };
  schedule();
  const std::string out = dir.File("out"), log = dir.File("log");
  const pid_t worker = SpawnArmsig({"--db", uri, "worker", "--poll-s", "0.2"}, out, log);
  int status = 0;
  auto stop_worker = [&] {
    ::kill(worker, SIGKILL);
    ::waitpid(worker, &status, 0);
  };
  if (!WaitForChildOr(worker, &status, [&] { return Printed(out, "job 1: puma: done"); })) {
    stop_worker();
    FAIL() << ReadText(log);
  }

  server->Stop();  // every connection ends; the worker's next look finds no server
  if (!WaitForChildOr(worker, &status, [&] { return Printed(log, "went away"); })) {
    stop_worker();
    FAIL() << "the worker ended or waited on: " << ReadText(log);
  }
  server->Start();
  schedule();
  if (!WaitForChildOr(worker, &status, [&] { return Printed(out, "job 2: puma: done"); })) {
    stop_worker();
    FAIL() << ReadText(log);
  }
  EXPECT_TRUE(Printed(log, "answers again")) << ReadText(log);

  server->SignalAll(SIGSTOP);  // frozen: the sockets accept, nothing answers
  if (!WaitForChildOr(worker, &status, [&] { return Printed(log, "did not answer within"); })) {
    stop_worker();
    FAIL() << "the worker ended or waited on: " << ReadText(log);
  }
  server->SignalAll(SIGCONT);
  schedule();
  if (!WaitForChildOr(worker, &status, [&] { return Printed(out, "job 3: puma: done"); })) {
    stop_worker();
    FAIL() << ReadText(log);
  }
  ::kill(worker, SIGTERM);
  ::waitpid(worker, &status, 0);
  ASSERT_TRUE(WIFEXITED(status)) << status;
  EXPECT_EQ(WEXITSTATUS(status), 130) << ReadText(log);
  const auto r = RunArmsig("--db '" + uri + "' jobs --json");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto jobs = nlohmann::json::parse(r.out);
  ASSERT_EQ(jobs.size(), 3u);
  for (const auto& j : jobs) {
    EXPECT_EQ(j["state"], "done") << j.dump();
    EXPECT_EQ(j["attempts"], 1) << j.dump();
  }
}

// The queue in a SQLite file, the store on a server that is down when the job runs: the
// attempt is handed back to the queue (not counted, the reason kept) and the job is done
// once the server is back; before, it was failed on attempt 1 and never retried.
TEST(ServerOutage, AStoreOutageUnderASqliteQueueFailsNoJob) {
  TempDir dir;
  const auto server = PostgresServer::StartPrivate();
  const std::string uri = server->NewDatabase("store") + "&connect_timeout=2";
  {
    db::Database database(uri);
    AddSession(database, calibration::PaperTable3Parameters(), 60, 6);
  }
  const std::string queue = dir.File("queue.db");
  ASSERT_EQ(RunArmsig("--db '" + queue + "' db init").exit_code, 0);
  auto r = RunArmsig("--db '" + uri +
                     "' schedule recalibrate --robot puma --residual-model off "
                     "--queue '" +
                     queue + "'");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  server->Stop();
  const std::string out = dir.File("out"), log = dir.File("log");
  const pid_t worker =
      SpawnArmsig({"--db", uri, "worker", "--poll-s", "0.2", "--queue", queue}, out, log);
  int status = 0;
  auto stop_worker = [&] {
    ::kill(worker, SIGKILL);
    ::waitpid(worker, &status, 0);
  };
  if (!WaitForChildOr(worker, &status,
                      [&] { return Printed(log, "interrupted by the infrastructure"); })) {
    stop_worker();
    FAIL() << "the job was not handed back: " << ReadText(log) << ReadText(out);
  }
  r = RunArmsig("--db '" + queue + "' jobs --json");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  auto jobs = nlohmann::json::parse(r.out);
  ASSERT_EQ(jobs.size(), 1u);
  EXPECT_NE(jobs[0]["state"], "failed") << jobs.dump();
  server->Start();
  if (!WaitForChildOr(worker, &status, [&] { return Printed(out, "job 1: puma: done"); })) {
    stop_worker();
    FAIL() << ReadText(log);
  }
  ::kill(worker, SIGTERM);
  ::waitpid(worker, &status, 0);
  EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 130) << status << ReadText(log);
  r = RunArmsig("--db '" + queue + "' jobs --json");
  jobs = nlohmann::json::parse(r.out);
  ASSERT_EQ(jobs.size(), 1u);
  EXPECT_EQ(jobs[0]["state"], "done") << jobs.dump();
  EXPECT_EQ(jobs[0]["attempts"], 1) << "interrupted attempts are not counted";
  EXPECT_EQ(jobs[0]["version"], 1);
  EXPECT_TRUE(jobs[0]["error"].is_null()) << jobs.dump();
}

}  // namespace
}  // namespace armsig::testing
