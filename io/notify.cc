#include "io/notify.h"

#include <signal.h>
#include <sys/mman.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <thread>

namespace armsig::io {

namespace {

// The input as a file in memory, positioned at its start; -1 with errno on failure.
int InputFile(const std::string& input) {
  const int fd = ::memfd_create("armsig-notify", MFD_CLOEXEC);
  if (fd < 0) return -1;
  size_t written = 0;
  while (written < input.size()) {
    const ssize_t n = ::write(fd, input.data() + written, input.size() - written);
    if (n < 0) {
      if (errno == EINTR) continue;
      const int saved = errno;
      ::close(fd);
      errno = saved;
      return -1;
    }
    written += static_cast<size_t>(n);
  }
  ::lseek(fd, 0, SEEK_SET);
  return fd;
}

int StatusCode(int status) {
  if (WIFEXITED(status)) return WEXITSTATUS(status);
  if (WIFSIGNALED(status)) return 128 + WTERMSIG(status);
  return -1;
}

}  // namespace

NotifyResult RunNotifyCommand(const std::string& command, const std::string& input,
                              const std::vector<std::pair<std::string, std::string>>& environment,
                              std::chrono::milliseconds limit) {
  NotifyResult result;
  const int in = InputFile(input);
  if (in < 0) {
    result.error = std::string("cannot hold its input: ") + std::strerror(errno);
    return result;
  }
  const pid_t child = ::fork();
  if (child < 0) {
    result.error = std::string("cannot start it: ") + std::strerror(errno);
    ::close(in);
    return result;
  }
  if (child == 0) {
    // Its own process group, so that a time-out ends whatever it started too.
    ::setpgid(0, 0);
    ::dup2(in, STDIN_FILENO);
    for (const auto& [name, value] : environment) ::setenv(name.c_str(), value.c_str(), 1);
    ::signal(SIGPIPE, SIG_DFL);
    ::execl("/bin/sh", "sh", "-c", command.c_str(), static_cast<char*>(nullptr));
    ::_exit(127);
  }
  ::close(in);
  ::setpgid(child, child);  // also from here: no race with the child's own call
  result.started = true;
  const auto until = std::chrono::steady_clock::now() + limit;
  int status = 0;
  while (true) {
    const pid_t done = ::waitpid(child, &status, WNOHANG);
    if (done == child) {
      result.exit_code = StatusCode(status);
      return result;
    }
    if (done < 0 && errno != EINTR) {
      result.error = std::string("lost it: ") + std::strerror(errno);
      return result;
    }
    if (std::chrono::steady_clock::now() >= until) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  result.timed_out = true;
  ::kill(-child, SIGTERM);
  const auto grace = std::chrono::steady_clock::now() + std::chrono::seconds(2);
  while (::waitpid(child, &status, WNOHANG) == 0) {
    if (std::chrono::steady_clock::now() >= grace) {
      ::kill(-child, SIGKILL);
      ::waitpid(child, &status, 0);
      break;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  return result;
}

}  // namespace armsig::io
