#include "io/atomic_file.h"

#include <gtest/gtest.h>
#include <sys/stat.h>

#include <filesystem>
#include <string>
#include <thread>
#include <vector>

#include "core/error.h"
#include "test_support.h"

namespace armsig::io {
namespace {

std::vector<std::string> Entries(const std::filesystem::path& dir) {
  std::vector<std::string> names;
  for (const auto& e : std::filesystem::directory_iterator(dir))
    names.push_back(e.path().filename().string());
  return names;
}

// What a signal handler calls before ending the process at once: every living writer's
// temporary file is removed, the targets are untouched, and a writer whose file was removed
// can no longer put it in place (its target stays as it was).
TEST(PreparedFile, LiveTemporariesAreRemovedForAStoppedProcess) {
  testing::TempDir dir;
  const std::string kept = dir.File("kept.csv"), fresh = dir.File("fresh.csv");
  WriteFileAtomically(kept, "old\n");
  PreparedFile a(kept), b(fresh);
  a.Write("new\n");
  b.Write("first\n");
  EXPECT_EQ(Entries(dir.path()).size(), 3u);  // kept.csv and two temporaries
  RemoveLiveTemporaries();
  EXPECT_EQ(Entries(dir.path()), std::vector<std::string>{"kept.csv"});
  EXPECT_THROW(a.Commit(), OutputError);
  EXPECT_EQ(testing::ReadText(kept), "old\n");
  EXPECT_FALSE(std::filesystem::exists(fresh));
}

// A committed or destroyed writer leaves the table: removing the live temporaries later
// touches nothing of theirs.
TEST(PreparedFile, AFinishedWriterIsNoLongerLive) {
  testing::TempDir dir;
  const std::string target = dir.File("out.txt");
  {
    PreparedFile done(target, "whole\n");
    done.Commit();
    PreparedFile dropped(dir.File("dropped.txt"));
    dropped.Write("never\n");
  }
  RemoveLiveTemporaries();
  EXPECT_EQ(Entries(dir.path()), std::vector<std::string>{"out.txt"});
  EXPECT_EQ(testing::ReadText(target), "whole\n");
}

}  // namespace
}  // namespace armsig::io

namespace armsig::io {
namespace {

// An output path that is a FIFO or a character device is written through (it stays what it
// is, a reader gets the content); a symbolic link is refused before any work and by the
// writer, the link and its target left as they were.
TEST(PreparedFile, WritesThroughAFifoOrADeviceAndRefusesASymbolicLink) {
  testing::TempDir dir;
  const std::string fifo = dir.File("pipe");
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  std::string received;
  std::thread reader([&] { received = testing::ReadText(fifo); });
  {
    PreparedFile out(fifo);
    out.Write("through the pipe\n");
    out.Commit();
  }
  reader.join();
  EXPECT_EQ(received, "through the pipe\n");
  struct stat st {};
  ASSERT_EQ(::lstat(fifo.c_str(), &st), 0);
  EXPECT_TRUE(S_ISFIFO(st.st_mode));
  EXPECT_NO_THROW(CheckOutputFile(fifo, "--out"));

  EXPECT_NO_THROW(CheckOutputFile("/dev/null", "--poses"));
  WriteFileAtomically("/dev/null", "nothing\n");
  ASSERT_EQ(::lstat("/dev/null", &st), 0);
  EXPECT_TRUE(S_ISCHR(st.st_mode));

  const std::string target = dir.File("dated.csv"), link = dir.File("latest.csv");
  WriteFileAtomically(target, "kept\n");
  std::filesystem::create_symlink(target, link);
  try {
    CheckOutputFile(link, "--out");
    ADD_FAILURE() << "a symbolic link was accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("is a symbolic link to " + target), std::string::npos)
        << e.what();
    EXPECT_NE(std::string(e.what()).find("--out"), std::string::npos) << e.what();
  }
  EXPECT_THROW(WriteFileAtomically(link, "new\n"), OutputError);
  EXPECT_TRUE(std::filesystem::is_symlink(link));
  EXPECT_EQ(testing::ReadText(target), "kept\n");
  EXPECT_EQ(Entries(dir.path()).size(), 3u);  // pipe, dated.csv, latest.csv: no temporary
}

}  // namespace
}  // namespace armsig::io
