// Shared fixtures: a temporary directory, the shipped models, running the CLI.
#pragma once

#include <fcntl.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cctype>
#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>
#include <stdexcept>
#include <string>
#include <string_view>
#include <thread>
#include <vector>

#include "calibration/model.h"
#include "io/model_yaml.h"

namespace armsig::testing {

// RFC 4648 base64, written here independently of the product's encoder.
inline std::vector<unsigned char> DecodeBase64(const std::string& text) {
  auto value = [](char c) -> int {
    if (c >= 'A' && c <= 'Z') return c - 'A';
    if (c >= 'a' && c <= 'z') return c - 'a' + 26;
    if (c >= '0' && c <= '9') return c - '0' + 52;
    if (c == '+') return 62;
    if (c == '/') return 63;
    return -1;
  };
  std::vector<unsigned char> out;
  int bits = 0, buffer = 0;
  for (char c : text) {
    const int v = value(c);
    if (v < 0) continue;  // '=' padding
    buffer = (buffer << 6) | v;
    bits += 6;
    if (bits >= 8) {
      bits -= 8;
      out.push_back(static_cast<unsigned char>((buffer >> bits) & 0xff));
    }
  }
  return out;
}

class TempDir {
 public:
  TempDir() {
    std::random_device rd;
    path_ = std::filesystem::temp_directory_path() /
            ("armsig-test-" + std::to_string(::getpid()) + "-" + std::to_string(rd()));
    std::filesystem::create_directories(path_);
  }
  ~TempDir() { std::filesystem::remove_all(path_); }
  std::string File(const std::string& name) const { return (path_ / name).string(); }
  const std::filesystem::path& path() const { return path_; }

 private:
  std::filesystem::path path_;
};

// The lines of `text`, without their line breaks.
inline std::vector<std::string> Lines(const std::string& text) {
  std::vector<std::string> out;
  std::istringstream in(text);
  for (std::string line; std::getline(in, line);) out.push_back(line);
  return out;
}

inline void WriteText(const std::string& path, const std::string& text) {
  std::ofstream out(path, std::ios::binary);
  out << text;
}

inline std::string ReadText(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

// "0C 00 …" (spaces, line breaks and comments between bytes are ignored) → bytes: protocol
// vectors written out by hand.
inline std::string Hex(std::string_view text) {
  std::string out;
  int high = -1;
  for (char c : text) {
    if (!std::isxdigit(static_cast<unsigned char>(c))) continue;
    const int v =
        std::isdigit(static_cast<unsigned char>(c)) ? c - '0' : std::toupper(c) - 'A' + 10;
    if (high < 0) {
      high = v;
    } else {
      out += static_cast<char>(high * 16 + v);
      high = -1;
    }
  }
  if (high >= 0) throw std::invalid_argument("odd number of hex digits");
  return out;
}

inline std::string SourcePath(const std::string& relative) {
  return std::string(ARMSIG_SOURCE_DIR) + "/" + relative;
}
inline std::string DataPath(const std::string& relative) {
  return std::string(ARMSIG_TEST_DATA) + "/" + relative;
}

// `path` in single quotes, for a command line RunArmsig hands to the shell.
inline std::string Quoted(const std::string& path) { return "'" + path + "'"; }

// A robot program of tests/data/programs/.
inline std::string ProgramData(const std::string& relative) {
  return ReadText(DataPath("programs/" + relative));
}

// Whether an unprivileged user may mount in a private namespace here (unshare -rm): the
// full-disk and read-only tests mount a small tmpfs there.
inline bool PrivateMountsWork() {
  return std::system("unshare -rm sh -c 'mount -t tmpfs -o size=4k tmpfs /mnt' >/dev/null 2>&1") ==
         0;
}

// Starts args[0] with `args`, its output thrown away; the child's pid.
inline pid_t SpawnQuietly(std::vector<std::string> args) {
  const pid_t child = ::fork();
  if (child == 0) {
    std::vector<char*> argv;
    for (auto& a : args) argv.push_back(a.data());
    argv.push_back(nullptr);
    const int null = ::open("/dev/null", O_WRONLY);
    ::dup2(null, 1);
    ::dup2(null, 2);
    ::execv(argv[0], argv.data());
    _exit(127);
  }
  return child;
}

// Starts args[0] with `args`, its stdout and stderr into the files `out` and `err` (TMPDIR
// set to `tmpdir` when given); the child's pid.
inline pid_t Spawn(std::vector<std::string> args, const std::string& out, const std::string& err,
                   const std::string& tmpdir = "") {
  std::fflush(nullptr);  // nothing buffered is written twice
  const pid_t child = ::fork();
  if (child == 0) {
    std::vector<char*> argv;
    for (auto& a : args) argv.push_back(a.data());
    argv.push_back(nullptr);
    ::dup2(::open(out.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0600), 1);
    ::dup2(::open(err.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0600), 2);
    if (!tmpdir.empty()) ::setenv("TMPDIR", tmpdir.c_str(), 1);
    ::execv(argv[0], argv.data());
    _exit(127);
  }
  return child;
}
// The same for the armsig binary: `args` are its arguments.
inline pid_t SpawnArmsig(std::vector<std::string> args, const std::string& out,
                         const std::string& err, const std::string& tmpdir = "") {
  args.insert(args.begin(), ARMSIG_BINARY);
  return Spawn(std::move(args), out, err, tmpdir);
}

inline calibration::RobotModel Puma() {
  return io::LoadRobotModel(SourcePath("models/puma760.yaml"));
}
inline calibration::RobotModel Ur10() { return io::LoadRobotModel(SourcePath("models/ur10.yaml")); }

struct CommandResult {
  int exit_code = -1;
  std::string out, err;
};

// Runs build/armsig with `args` (a shell-quoted string) in `cwd`.
// Runs armsig (`binary`) with `args` in `cwd` (through `launcher` when given: e.g. setpriv, to
// run it as another user); its exit code and output.
inline CommandResult RunArmsigThrough(const std::string& launcher, const std::string& args,
                                      const std::string& cwd = ".",
                                      const std::string& binary = ARMSIG_BINARY) {
  TempDir capture;
  const std::string out = capture.File("out"), err = capture.File("err");
  const std::string command = "cd '" + cwd + "' && " + launcher + " '" + binary + "' " + args +
                              " >'" + out + "' 2>'" + err + "'";
  const int status = std::system(command.c_str());
  CommandResult result;
  result.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  result.out = ReadText(out);
  result.err = ReadText(err);
  return result;
}
inline CommandResult RunArmsig(const std::string& args, const std::string& cwd = ".") {
  return RunArmsigThrough("", args, cwd);
}

// Waits for an event that `ready` observes (a session row, a line in a log), polling every
// 2 ms. `limit` only guards against a hang: a slow or loaded machine makes a test slower,
// never wrong. False when the limit passed first.
template <class Predicate>
bool WaitUntil(Predicate ready, std::chrono::milliseconds limit = std::chrono::minutes(3)) {
  const auto until = std::chrono::steady_clock::now() + limit;
  while (!ready()) {
    if (std::chrono::steady_clock::now() > until) return false;
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  }
  return true;
}

// A child process: waits until `ready` or until the child has ended (then `*status` holds
// its wait status and the result is false, so the caller does not signal a reaped pid).
template <class Predicate>
bool WaitForChildOr(pid_t child, int* status, Predicate ready,
                    std::chrono::milliseconds limit = std::chrono::minutes(3)) {
  bool ended = false;
  const bool happened = WaitUntil(
      [&] {
        if (ready()) return true;
        ended = ::waitpid(child, status, WNOHANG) == child;
        return ended;
      },
      limit);
  return happened && !ended;
}

// The virtual lab `armsig demo --serve DIR/folder --time-scale 0` keeps up (with `options`:
// its robot, a planted --change, another day's --setup), its output in DIR/folder.out and
// .err; ready once it says so. Stop() ends it by SIGINT as a technician's Ctrl-C and gives the
// wait status; the destructor stops it too.
class ServedLab {
 public:
  ServedLab(const TempDir& dir, const std::string& folder, std::vector<std::string> options = {})
      : folder_(dir.File(folder)), out_(dir.File(folder + ".out")), err_(dir.File(folder + ".err")) {
    std::vector<std::string> args = {"--db", dir.File("unused.db"), "demo", "--serve", folder_,
                                     "--time-scale", "0", "--seconds", "900"};
    args.insert(args.end(), options.begin(), options.end());
    pid_ = SpawnArmsig(args, out_, err_, dir.path().string());
    int status = 0;
    ready_ = pid_ > 0 && WaitForChildOr(pid_, &status, [&] {
               return ReadText(out_).find("virtual lab ready") != std::string::npos;
             });
    if (!ready_ && pid_ > 0 && ::waitpid(pid_, &status, WNOHANG) != 0) pid_ = -1;  // reaped
  }
  ServedLab(const ServedLab&) = delete;
  ServedLab& operator=(const ServedLab&) = delete;
  ~ServedLab() { Stop(); }
  int Stop() {
    int status = -1;
    if (pid_ <= 0) return status;
    ::kill(pid_, SIGINT);
    ::waitpid(pid_, &status, 0);
    pid_ = -1;
    return status;
  }
  bool ready() const { return ready_; }
  const std::string& folder() const { return folder_; }
  std::string lab() const { return folder_ + "/lab.yaml"; }
  std::string errors() const { return ReadText(err_); }

 private:
  std::string folder_, out_, err_;
  pid_t pid_ = -1;
  bool ready_ = false;
};

}  // namespace armsig::testing
