// A full file system (a tmpfs of a few kB in a private mount namespace, `unshare -rm`) under
// standard output, an output file and the database: each is named as "No space left on
// device", with what was and was not done; the store stays as it was, and no temporary file
// is left behind.
#include <fmt/format.h>
#include <gtest/gtest.h>

#include <filesystem>
#include <nlohmann/json.hpp>
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


// A capture that fills the disk (a tmpfs of 500 kB under the database, the virtual PUMA lab
// served beside it) stops at the failed write, names it, and says what the session keeps: the
// configurations stored before it, each whole (a technician reading "nothing of it was
// stored" must not think the session lost). With room again, the hint it printed completes
// the session, and nothing is measured twice.
TEST(FullDisk, ACaptureThatFillsTheDiskSaysWhatItKeptAndResumes) {
  if (!PrivateMountsWork()) GTEST_SKIP() << "no private mount namespace here (unshare -rm)";
  TempDir dir;
  const ServedLab served(dir, "lab");
  ASSERT_TRUE(served.ready()) << served.errors();
  const std::string lab = served.folder();
  const std::string full = dir.File("full"), at = dir.path().string() + "/";
  std::filesystem::create_directories(full);
  const std::string armsig = Quoted(ARMSIG_BINARY) + " --db " + Quoted(full + "/lab.db") + " ";
  const std::string capture = armsig + "capture --lab " + Quoted(lab + "/lab.yaml");
  RunPrivately(dir, "mount -t tmpfs -o size=500k tmpfs " + Quoted(full) + " && " + capture +
                        " --plan auto:120 --robot puma > " + Quoted(at + "out") + " 2> " +
                        Quoted(at + "err") + "; echo $? > " + Quoted(at + "rc") + "; cp " +
                        Quoted(full + "/lab.db") + " " + Quoted(at + "full.db") + "; cp " +
                        Quoted(full + "/lab.db-wal") + " " + Quoted(at + "full.db-wal") +
                        "; mount -o remount,size=64m " + Quoted(full) + " && " + capture +
                        " --resume 1 > " + Quoted(at + "resumed") + " 2>&1; echo $? >> " +
                        Quoted(at + "rc") + "; " + armsig + "sessions --json > " +
                        Quoted(at + "sessions") + " 2>&1");
  EXPECT_EQ(ReadText(dir.File("rc")), "1\n0\n") << ReadText(dir.File("err"))
                                                 << ReadText(dir.File("resumed"));
  const std::string err = ReadText(dir.File("err"));
  EXPECT_NE(err.find("No space left on device"), std::string::npos) << err;
  // What the full disk kept, as the capture said it: its configurations, each with its
  // readings (the copy of the database as the failed capture left it).
  const auto kept = RunArmsig("--db " + Quoted(dir.File("full.db")) + " sessions --json");
  const auto kept_sessions = nlohmann::json::parse(kept.out);
  ASSERT_EQ(kept_sessions.size(), 1u) << kept.err;
  const int stored = kept_sessions[0]["measured"].get<int>();
  EXPECT_GT(stored, 0);
  EXPECT_LT(stored, 120);
  // Paused, or interrupted when the full disk refused the pause too: resumed alike.
  const std::string kept_line = fmt::format("({} configurations stored", stored);
  EXPECT_TRUE(err.find("session 1 paused " + kept_line + ")") != std::string::npos ||
              err.find("session 1 interrupted " + kept_line +
                       "; its pause could not be written)") != std::string::npos)
      << err;
  const std::string resumed = ReadText(dir.File("resumed"));
  EXPECT_NE(resumed.find(fmt::format("120 of 120 configurations stored ({} now, {} before)",
                                     120 - stored, stored)),
            std::string::npos)
      << resumed;
  const auto sessions = nlohmann::json::parse(ReadText(dir.File("sessions")));
  ASSERT_EQ(sessions.size(), 1u);
  EXPECT_EQ(sessions[0]["state"], "completed");
  EXPECT_EQ(sessions[0]["measured"], 120);
}

}  // namespace
}  // namespace armsig::testing
