// Outputs checked to the last byte, through the real binary: every command that prints,
// with its standard output on a full device (/dev/full). A lost output is exit code 1 with a
// message that names the output and the disk-full reason and says what the command did;
// never exit 0 with the output silently cut. (Full file systems: full_disk_test.cc.)
#include <fcntl.h>
#include <gtest/gtest.h>
#include <sys/file.h>
#include <unistd.h>

#include <filesystem>
#include <string>
#include <vector>

#include "support/lab_database.h"
#include "test_support.h"

namespace armsig::testing {
namespace {

// Runs build/armsig with standard output sent to `stdout_target` (a shell redirection).
CommandResult RunWithStdout(const std::string& args, const std::string& stdout_target,
                            const std::string& cwd = ".") {
  TempDir capture;
  const std::string err = capture.File("err");
  const std::string command = "cd " + Quoted(cwd) + " && " + Quoted(ARMSIG_BINARY) + " " + args +
                              " >" + stdout_target + " 2>" + Quoted(err);
  const int status = std::system(command.c_str());
  CommandResult result;
  result.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  result.err = ReadText(err);
  return result;
}

struct Case {
  std::string name;
  std::string args;
  bool only_reads;
};

TEST(CheckedStdout, EveryCommandThatPrintsFailsOnAFullDeviceSayingWhatItDid) {
  TempDir dir;
  const LabDatabase lab = CopyLabDatabase(dir.path().string());
  const std::string db = "--db " + Quoted(lab.path) + " ";
  const std::string out = dir.File("written");  // a file output of a command, not stdout
  const std::vector<Case> cases = {
      {"help", "--help", true},
      {"version", "--version", true},
      {"generate man", "generate man", true},
      {"db init", "--db " + Quoted(dir.File("new.db")) + " db init", false},
      {"db info", db + "db info", true},
      {"db export", db + "db export observations --csv", true},
      {"robot add", db + "robot add second --model " + Quoted(lab.model_yaml), false},
      {"robot list", db + "robot list", true},
      {"robot list --json", db + "robot list --json", true},
      {"sessions", db + "sessions", true},
      {"sessions --json", db + "sessions --json", true},
      {"session export", db + "session export 1 --poses " + Quoted(out + ".csv"), true},
      {"session discard", db + "session discard 2 --reason test", false},
      {"session restore", db + "session restore 2", false},
      {"versions", db + "versions --robot puma", true},
      {"versions --json", db + "versions --robot puma --json", true},
      {"activate", db + "activate --robot puma --version 1", false},
      {"predict", db + "predict --robot puma --joints " + Quoted(lab.joints_csv), true},
      {"compensate",
       db + "compensate --robot puma --targets " + Quoted(lab.targets_csv) + " --out " +
           Quoted(out + "-joints.csv"),
       true},
      {"export", db + "export --robot puma --format json --out " + Quoted(out + ".json"), true},
      {"report", db + "report --robot puma --out " + Quoted(out + "-report"), true},
      {"calibrate",
       "calibrate --model " + Quoted(lab.model_yaml) + " --poses " + Quoted(lab.poses_csv), true},
      {"triangulate",
       "triangulate --stations " + Quoted(lab.stations_yaml) + " --observations " +
           Quoted(lab.observations_csv) + " --out " + Quoted(out + "-points.csv"),
       true},
      {"import observations",
       db + "import observations " + Quoted(lab.observations_csv) + " --stations " +
           Quoted(lab.stations_yaml) + " --robot puma",
       false},
      {"import poses --robot",
       db + "import poses " + Quoted(lab.poses_csv) +
           " --joint-columns q1_deg,q2_deg,q3_deg,q4_deg,q5_deg,q6_deg --xyz-columns "
           "x_mm,y_mm,z_mm --joint-unit deg --id pose --robot puma --allow-duplicate",
       false},
      {"reduce", db + "reduce", false},
      {"recalibrate", db + "recalibrate --robot puma --force", false},
      {"schedule", db + "schedule recalibrate --robot puma", false},
      {"worker", db + "worker --once", false},
      {"jobs", db + "jobs", true},
      {"jobs --json", db + "jobs --json", true},
      {"db push", db + "db push --to " + Quoted(dir.File("central.db")), false},
      {"instrument simulate",
       "instrument simulate --protocol geocom --link " + Quoted(dir.File("tty")) + " --seconds 0.2",
       true},
  };
  for (const auto& c : cases) {
    SCOPED_TRACE(c.name);
    const auto r = RunWithStdout(c.args, "/dev/full");
    EXPECT_EQ(r.exit_code, 1) << r.err;
    EXPECT_NE(r.err.find("standard output: write failed (No space left on device)"),
              std::string::npos)
        << r.err;
    if (c.only_reads) {
      // Nothing stored: either nothing written at all, or the files it wrote named (they
      // exist, whole).
      const size_t wrote = r.err.find("changed nothing in the store and wrote ");
      if (wrote == std::string::npos) {
        EXPECT_NE(r.err.find("only reads: nothing was stored or changed"), std::string::npos)
            << r.err;
      } else {
        const size_t from = wrote + std::string("changed nothing in the store and wrote ").size();
        const std::string first = r.err.substr(from, r.err.find_first_of(", ", from) - from);
        EXPECT_TRUE(std::filesystem::exists(first)) << first;
      }
    } else {
      EXPECT_NE(r.err.find("did its work"), std::string::npos) << r.err;
    }
  }
}

// Issue 38: a command that changes nothing in the store but writes a file (`iso9283 plan
// --out`) said "the command only reads: nothing was stored or changed" while its plan lay
// written; it names the file it wrote whole.
TEST(CheckedStdout, ACommandThatWroteAFileSaysSoWhenItsOutputFails) {
  TempDir dir;
  const std::string db = "--db " + Quoted(dir.File("lab.db")) + " ";
  ASSERT_EQ(RunArmsig(db + "robot add puma --model " + Quoted(SourcePath("models/puma760.yaml")))
                .exit_code,
            0);
  const std::string plan = dir.File("plan.csv");
  const auto r = RunWithStdout(
      db + "iso9283 plan --robot puma --cube 600,100,700,400 --cycles 3 --out " + Quoted(plan),
      "/dev/full");
  EXPECT_EQ(r.exit_code, 1) << r.err;
  EXPECT_TRUE(std::filesystem::exists(plan));
  EXPECT_EQ(r.err.find("nothing was stored or changed"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("The command changed nothing in the store and wrote " + plan + " whole"),
            std::string::npos)
      << r.err;
}

// A command that stores and cannot print its summary repeats it in the message, so that the
// log says what was stored; the store has it.
TEST(CheckedStdout, AStoringCommandRepeatsTheSummaryItCouldNotPrint) {
  TempDir dir;
  const LabDatabase lab = CopyLabDatabase(dir.path().string());
  const auto r = RunWithStdout(
      "--db " + Quoted(lab.path) + " robot add second --model " + Quoted(lab.model_yaml),
      "/dev/full");
  EXPECT_EQ(r.exit_code, 1) << r.err;
  EXPECT_NE(r.err.find("what it could not print:\n  robot second registered in "),
            std::string::npos)
      << r.err;
  const auto list = RunArmsig("--db " + Quoted(lab.path) + " robot list");
  EXPECT_NE(list.out.find("second"), std::string::npos) << list.out;
}

// The same output to a regular file and to a pipe is written whole, exit 0: the check adds
// nothing where the output has room.
TEST(CheckedStdout, OutputWithRoomIsWrittenWhole) {
  TempDir dir;
  const LabDatabase lab = CopyLabDatabase(dir.path().string());
  const std::string export_poses = "--db " + Quoted(lab.path) + " db export poses --csv";
  const auto to_file = RunWithStdout(export_poses, Quoted(dir.File("poses.csv")));
  ASSERT_EQ(to_file.exit_code, 0) << to_file.err;
  const auto to_pipe = RunWithStdout(export_poses + " | cat", Quoted(dir.File("piped.csv")));
  ASSERT_EQ(to_pipe.exit_code, 0) << to_pipe.err;
  const std::string text = ReadText(dir.File("poses.csv"));
  EXPECT_EQ(text, ReadText(dir.File("piped.csv")));
  // 160 configurations of two simulated sessions (and the imported session's four), a header.
  EXPECT_GE(std::count(text.begin(), text.end(), '\n'), 161);
  EXPECT_EQ(text.back(), '\n');
}

// A temporary output file a killed writer left (unlocked) is removed by the next writer of
// the same file; one a living writer holds (locked) is left alone.
TEST(CheckedStdout, TemporaryFilesOfDeadWritersAreRemovedByTheNextWriter) {
  TempDir dir;
  const LabDatabase lab = CopyLabDatabase(dir.path().string());
  const std::string target = dir.File("robots.csv");
  WriteText(target + ".tmp.AbC123", "left by a writer killed with SIGKILL");
  WriteText(target + ".tmp.XyZ789", "being written by a living process");
  const int held = ::open((target + ".tmp.XyZ789").c_str(), O_RDONLY | O_CLOEXEC);
  ASSERT_GE(held, 0);
  ASSERT_EQ(::flock(held, LOCK_EX), 0);
  WriteText(target + ".tmp.other", "not a name armsig makes");
  const auto r =
      RunArmsig("--db " + Quoted(lab.path) + " db export robots --out " + Quoted(target));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_TRUE(std::filesystem::exists(target));
  EXPECT_FALSE(std::filesystem::exists(target + ".tmp.AbC123"));
  EXPECT_TRUE(std::filesystem::exists(target + ".tmp.XyZ789"));
  EXPECT_TRUE(std::filesystem::exists(target + ".tmp.other"));
  ::close(held);
}

}  // namespace
}  // namespace armsig::testing
