// A full file system (a tmpfs of a few kB in a private mount namespace, `unshare -rm`) under
// standard output, an output file and the database: each is named as "No space left on
// device", with what was and was not done; the store stays as it was, and no temporary file
// is left behind.
#include <gtest/gtest.h>

#include <filesystem>
#include <string>

#include "support/lab_database.h"
#include "test_support.h"

namespace armsig::testing {
namespace {

// Runs `script` (sh) in a private mount namespace.
void RunPrivately(const TempDir& dir, const std::string& script) {
  WriteText(dir.File("script.sh"), script + "\n");
  ASSERT_EQ(std::system(("unshare -rm sh " + Quoted(dir.File("script.sh"))).c_str()), 0);
}

// Standard output into a file on a full file system (a tmpfs of 8 kB): the export is cut at
// 8 kB, and the command says so (exit 1) instead of exit 0 with a third of the rows. An
// output file (--out) on the same full file system is not written at all, and no temporary
// file is left behind.
TEST(FullDisk, StandardOutputAndAnOutputFileOnAFullFileSystemAreNamed) {
  if (!PrivateMountsWork()) GTEST_SKIP() << "no private mount namespace here (unshare -rm)";
  TempDir dir;
  const LabDatabase lab = CopyLabDatabase(dir.path().string());
  const std::string full = dir.File("full");
  std::filesystem::create_directories(full);
  // The messages and exit codes go beside the tmpfs, which has no room for them.
  const std::string binary = Quoted(ARMSIG_BINARY), at = dir.path().string() + "/";
  const std::string script =
      "mount -t tmpfs -o size=8k tmpfs " + Quoted(full) + " && cd " + Quoted(full) + " && " +
      binary + " --db " + Quoted(lab.path) + " db export poses --csv > poses.csv 2> " +
      Quoted(at + "err1") + "; echo $? > " + Quoted(at + "rc1") + "; " + binary + " --db " +
      Quoted(lab.path) + " db export poses --out out.csv 2> " + Quoted(at + "err2") +
      "; echo $? > " + Quoted(at + "rc2") + "; ls -a > " + Quoted(at + "listing");
  RunPrivately(dir, script);
  EXPECT_EQ(ReadText(dir.File("rc1")), "1\n");
  const std::string err1 = ReadText(dir.File("err1"));
  EXPECT_NE(err1.find("standard output: write failed (No space left on device) after "),
            std::string::npos)
      << err1;
  EXPECT_NE(err1.find("bytes: the output is incomplete"), std::string::npos) << err1;
  EXPECT_EQ(ReadText(dir.File("rc2")), "1\n");
  const std::string err2 = ReadText(dir.File("err2"));
  EXPECT_NE(err2.find("out.csv: write failed (No space left on device); out.csv was not changed"),
            std::string::npos)
      << err2;
  EXPECT_NE(err2.find("nothing was stored or changed"), std::string::npos) << err2;
  // Nothing left but the cut standard output and the messages: no out.csv, no temporary file.
  EXPECT_EQ(ReadText(dir.File("listing")), ".\n..\nposes.csv\n");
}

// The database on a file system that fills during a write: an import of 20,000 readings
// fails naming the full disk (not "disk I/O error" or "not a usable SQLite database"),
// without a "rollback failed" warning; what was stored before is intact and complete.
TEST(FullDisk, ADatabaseWriteOnAFullDiskIsNamedAndStoresNothing) {
  if (!PrivateMountsWork()) GTEST_SKIP() << "no private mount namespace here (unshare -rm)";
  TempDir dir;
  const LabDatabase lab = CopyLabDatabase(dir.path().string());
  std::string csv = "point,station,hz_gon,v_gon\n";
  for (int k = 0; k < 10000; ++k) {
    csv += "Q" + std::to_string(k) + ",S1,123.4567,98.7654\n";
    csv += "Q" + std::to_string(k) + ",S2,234.5678,101.2345\n";
  }
  WriteText(dir.File("many.csv"), csv);
  const auto size = std::filesystem::file_size(lab.path);
  const std::string full = dir.File("full"), at = dir.path().string() + "/";
  std::filesystem::create_directories(full);
  const std::string armsig = Quoted(ARMSIG_BINARY) + " --db " + Quoted(full + "/lab.db") + " ";
  RunPrivately(dir, "mount -t tmpfs -o size=" + std::to_string(size / 1024 + 96) + "k tmpfs " +
                        Quoted(full) + " && cp " + Quoted(lab.path) + " " + Quoted(full) + "/ && " +
                        armsig + "import observations " + Quoted(dir.File("many.csv")) +
                        " --stations " + Quoted(lab.stations_yaml) + " 2> " + Quoted(at + "err") +
                        "; echo $? > " + Quoted(at + "rc") + "; " + armsig +
                        "db export observations > " + Quoted(at + "after.csv") + " 2>&1; " +
                        armsig + "db info > " + Quoted(at + "info") + " 2>&1; cp " +
                        Quoted(full + "/lab.db") + " " + Quoted(at + "after.db"));
  EXPECT_EQ(ReadText(dir.File("rc")), "1\n");
  const std::string err = ReadText(dir.File("err"));
  EXPECT_NE(err.find("No space left on device"), std::string::npos) << err;
  EXPECT_EQ(err.find("rollback failed"), std::string::npos) << err;
  EXPECT_EQ(err.find("not a usable"), std::string::npos) << err;
  // Not one of the 20,000 readings, and everything that was there.
  const auto before = RunArmsig("--db " + Quoted(lab.path) + " db export observations");
  EXPECT_EQ(ReadText(dir.File("after.csv")), before.out);
  EXPECT_NE(ReadText(dir.File("info")).find("observations"), std::string::npos);
}

}  // namespace
}  // namespace armsig::testing
