// The lock beside a database: one holder at a time, in this process or another; a second
// holder is refused after the wait it was given, and gets the lock once the holder is gone,
// however it went (a child process killed with SIGKILL runs no destructor).
#include "io/file_lock.h"

#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <filesystem>
#include <stdexcept>
#include <string>
#include <thread>

#include "test_support.h"

namespace armsig::io {
namespace {

// The message FileLock(path, wait_s) throws, or "(locked)" when it took the lock (and let
// it go again).
std::string LockRefusal(const std::string& path, int wait_s) {
  try {
    FileLock lock(path, wait_s);
  } catch (const std::runtime_error& e) {
    return e.what();
  }
  return "(locked)";
}

// A child process that takes the lock, says so on a pipe and holds it until it is killed.
class HolderProcess {
 public:
  explicit HolderProcess(const std::string& path) {
    int fds[2];
    if (::pipe(fds) != 0) throw std::runtime_error("pipe");
    pid_ = ::fork();
    if (pid_ == 0) {
      ::close(fds[0]);
      try {
        FileLock lock(path, 0);
        if (::write(fds[1], "H", 1) != 1) ::_exit(3);
        for (;;) ::pause();
      } catch (...) {
        ::_exit(2);
      }
    }
    ::close(fds[1]);
    char c = 0;
    holds_ = ::read(fds[0], &c, 1) == 1 && c == 'H';  // blocks until it holds the lock
    ::close(fds[0]);
  }
  ~HolderProcess() { Kill(); }
  bool holds() const { return holds_; }
  // SIGKILL: the process ends without unlocking or closing anything itself.
  void Kill() {
    if (pid_ <= 0) return;
    ::kill(pid_, SIGKILL);
    int status = 0;
    ::waitpid(pid_, &status, 0);
    pid_ = -1;
  }

 private:
  pid_t pid_ = -1;
  bool holds_ = false;
};

}  // namespace

TEST(FileLock, ASecondHolderInTheSameProcessIsRefusedUntilTheFirstLetsGo) {
  testing::TempDir dir;
  const std::string path = dir.File("lab.db.lock");
  {
    FileLock first(path, 0);
    EXPECT_TRUE(std::filesystem::exists(path));
    EXPECT_EQ(LockRefusal(path, 0), "another process holds " + path + "; gave up after 0 s");
  }
  EXPECT_EQ(LockRefusal(path, 0), "(locked)");
  EXPECT_EQ(LockRefusal(path, 0), "(locked)");  // and let go again by the destructor
}

// A holder in another process: a second one waits the seconds it was given (no less), then
// gives up naming the file; one that waits longer gets the lock as soon as the holder is
// killed.
TEST(FileLock, AWaitingHolderGetsTheLockWhenTheHolderProcessDies) {
  testing::TempDir dir;
  const std::string path = dir.File("lab.db.lock");
  HolderProcess holder(path);
  ASSERT_TRUE(holder.holds());
  const auto start = std::chrono::steady_clock::now();
  EXPECT_EQ(LockRefusal(path, 1), "another process holds " + path + "; gave up after 1 s");
  EXPECT_GE(std::chrono::steady_clock::now() - start, std::chrono::seconds(1));

  std::atomic<bool> locked{false}, failed{false};
  std::thread waiter([&] {
    try {
      FileLock lock(path, 600);
      locked = true;
    } catch (const std::exception&) {
      failed = true;
    }
  });
  EXPECT_FALSE(locked.load());  // the holder lives: nobody else has it
  holder.Kill();
  EXPECT_TRUE(testing::WaitUntil([&] { return locked.load() || failed.load(); }));
  waiter.join();
  EXPECT_TRUE(locked.load());
  EXPECT_FALSE(failed.load());
}

// A lock file that cannot be made, or a symbolic link put where it goes (which would have
// the lock create or lock another file), is refused naming the path.
TEST(FileLock, RefusesAPathItCannotCreateOrASymbolicLink) {
  testing::TempDir dir;
  const std::string missing = dir.File("no-such-dir/lab.db.lock");
  EXPECT_EQ(LockRefusal(missing, 0), missing + ": cannot create the lock file");
  const std::string link = dir.File("lab.db.lock");
  std::filesystem::create_symlink(dir.File("elsewhere"), link);
  EXPECT_EQ(LockRefusal(link, 0), link + ": cannot create the lock file");
  EXPECT_FALSE(std::filesystem::exists(dir.File("elsewhere")));
}

}  // namespace armsig::io
