// The folder of device claims against another user of the machine: a symbolic link in its
// place, a folder another user owns, a folder others can write into without the sticky bit,
// a claim file that is a symbolic link, and another user's process holding a claim. Another
// user is `nobody`, when the tests run as root (chown, setuid); otherwise those cases are
// skipped with the reason printed.
#include "acquisition/device_claims.h"

#include <gtest/gtest.h>
#include <pwd.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <filesystem>
#include <string>

#include "test_support.h"

namespace armsig::acquisition {
namespace {

using testing::ReadText;
using testing::TempDir;
using testing::WriteText;

io::LabConfig TwoDeviceLab() {
  io::LabConfig lab;
  lab.source = "lab.yaml";
  io::InstrumentConfig tracker;
  tracker.station = "LT1";
  tracker.protocol = io::InstrumentProtocol::kEmScon;
  tracker.tcp = io::HostPort{"127.0.0.1", 7000};
  lab.instruments.push_back(tracker);
  lab.controller.protocol = io::ControllerProtocol::kValII;
  lab.controller.port = "/dev/ttyS47";
  return lab;
}

// The message of ClaimDevices(lab, …, dir), or "" when it claimed.
std::string Refusal(const std::string& dir) {
  try {
    const DeviceClaims claims = ClaimDevices(TwoDeviceLab(), "test capture", dir);
    return "";
  } catch (const std::runtime_error& e) {
    return e.what();
  }
}

const passwd* Nobody() { return ::getpwnam("nobody"); }

TEST(DeviceClaims, AFolderOfOurOwnClaimsAndASecondClaimIsRefused) {
  TempDir dir;
  const std::string claims = dir.File("claims");
  const DeviceClaims first = ClaimDevices(TwoDeviceLab(), "first capture", claims);
  EXPECT_EQ(first.devices().size(), 2u);
  struct stat st {};
  ASSERT_EQ(::stat(claims.c_str(), &st), 0);
  EXPECT_EQ(st.st_mode & 07777, 0700u);  // made private
  const std::string why = Refusal(claims);
  EXPECT_NE(why.find("in use by another armsig process (pid " + std::to_string(::getpid())),
            std::string::npos)
      << why;
  EXPECT_NE(why.find("first capture"), std::string::npos) << why;
}

TEST(DeviceClaims, ASymbolicLinkInPlaceOfTheFolderIsRefused) {
  TempDir dir;
  const std::string target = dir.File("elsewhere");
  std::filesystem::create_directories(target);
  std::filesystem::create_directory_symlink(target, dir.File("claims"));
  const std::string why = Refusal(dir.File("claims"));
  EXPECT_NE(why.find("is a symbolic link, not a folder; refused"), std::string::npos) << why;
  EXPECT_TRUE(std::filesystem::is_empty(target));  // nothing written where it points
}

TEST(DeviceClaims, AFolderOthersCanWriteWithoutTheStickyBitIsRefused) {
  TempDir dir;
  const std::string claims = dir.File("claims");
  std::filesystem::create_directories(claims);
  ::chmod(claims.c_str(), 0777);
  std::string why = Refusal(claims);
  EXPECT_NE(why.find("writable by every user without the sticky bit (mode 0777)"),
            std::string::npos)
      << why;
  ::chmod(claims.c_str(), 0770);
  why = Refusal(claims);
  EXPECT_NE(why.find("writable by its group without the sticky bit (mode 0770)"), std::string::npos)
      << why;
  // Shared and sticky, like /tmp and /run/lock: nobody removes another's claim there.
  ::chmod(claims.c_str(), 01777);
  EXPECT_EQ(Refusal(claims), "");
  // A folder inside one that others can write into: they could swap it.
  const std::string open = dir.File("open");
  std::filesystem::create_directories(open + "/claims");
  ::chmod(open.c_str(), 0777);
  why = Refusal(open + "/claims");
  EXPECT_NE(why.find("lies in " + open + ", which is writable by every user"), std::string::npos)
      << why;
}

TEST(DeviceClaims, AClaimFileThatIsASymbolicLinkIsRefusedAndItsTargetUntouched) {
  TempDir dir;
  const std::string claims = dir.File("claims");
  std::filesystem::create_directories(claims);
  const std::string victim = dir.File("victim");
  WriteText(victim, "root's file\n");
  std::filesystem::create_symlink(victim, claims + "/tcp%20127.0.0.1%3A7000.lock");
  const std::string why = Refusal(claims);
  EXPECT_NE(why.find("a symbolic link, refused"), std::string::npos) << why;
  EXPECT_EQ(ReadText(victim), "root's file\n");
}

TEST(DeviceClaims, AFolderAnotherUserOwnsIsRefused) {
  const passwd* nobody = Nobody();
  if (::geteuid() != 0 || nobody == nullptr) {
    GTEST_SKIP() << "needs root and a user nobody to make a folder another user owns";
  }
  TempDir dir;
  const std::string claims = dir.File("claims");
  std::filesystem::create_directories(claims);
  ::chmod(claims.c_str(), 0700);
  ASSERT_EQ(::chown(claims.c_str(), nobody->pw_uid, nobody->pw_gid), 0);
  const std::string why = Refusal(claims);
  EXPECT_NE(why.find("owned by another user (nobody)"), std::string::npos) << why;
  EXPECT_TRUE(std::filesystem::is_empty(claims));
}

// Another user's process holds a claim in a shared (1777) folder, where an earlier capture
// of ours left its note: the refusal names the live holder, its user, and says that the note
// is an earlier holder's (not the stale pid of that earlier capture).
TEST(DeviceClaims, AnotherUsersLockIsNamedWithItsLiveHolder) {
  const passwd* nobody = Nobody();
  if (::geteuid() != 0 || nobody == nullptr) {
    GTEST_SKIP() << "needs root and a user nobody to hold a claim as another user";
  }
  TempDir dir;
  const std::string claims = dir.File("claims");
  std::filesystem::create_directories(claims);
  ::chmod(dir.path().c_str(), 0755);
  ::chmod(claims.c_str(), 01777);
  { const DeviceClaims earlier = ClaimDevices(TwoDeviceLab(), "an earlier capture", claims); }
  const std::string file = claims + "/tcp%20127.0.0.1%3A7000.lock";
  ASSERT_NE(ReadText(file).find("an earlier capture"), std::string::npos);
  int ready[2];
  ASSERT_EQ(::pipe(ready), 0);
  const pid_t child = ::fork();
  ASSERT_GE(child, 0);
  if (child == 0) {
    // The other user: opens the claim (read-only: it is root's file) and locks it.
    if (::setgid(nobody->pw_gid) != 0 || ::setuid(nobody->pw_uid) != 0) ::_exit(2);
    const int fd = ::open(file.c_str(), O_RDONLY);
    if (fd < 0 || ::flock(fd, LOCK_EX) != 0) ::_exit(3);
    [[maybe_unused]] const ssize_t w = ::write(ready[1], "x", 1);
    ::pause();
    ::_exit(0);
  }
  ::close(ready[1]);
  char byte = 0;
  ASSERT_EQ(::read(ready[0], &byte, 1), 1) << "the other user's process did not lock the claim";
  ::close(ready[0]);
  const std::string why = Refusal(claims);
  ::kill(child, SIGKILL);
  ::waitpid(child, nullptr, 0);
  EXPECT_NE(why.find("in use by another process (pid " + std::to_string(child)), std::string::npos)
      << why;
  EXPECT_NE(why.find("of another user, nobody"), std::string::npos) << why;
  EXPECT_NE(why.find("the note in the claim is an earlier holder's"), std::string::npos) << why;
  EXPECT_EQ(why.find("an earlier capture"), std::string::npos) << why;
  // The holder gone, the claim is ours again.
  EXPECT_EQ(Refusal(claims), "");
}

}  // namespace
}  // namespace armsig::acquisition
