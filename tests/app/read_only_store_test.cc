// Read-only stores through the real binary: a lab database on a read-only mount (a bind
// mount with -o ro in a private mount namespace, `unshare -rm`), in a folder without write
// permission, and a file with its -wal but no -shm (a copied database). Every command that
// only reads works there and prints what it prints on a writable copy; none makes a -wal or
// -shm file; the commands that write say "read-only" plainly (exit 2), not "unable to open
// database file" or "not a usable SQLite database".
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <set>
#include <string>
#include <vector>

#include "db/database.h"
#include "support/lab_database.h"
#include "test_support.h"

namespace armsig::testing {
namespace {

std::set<std::string> Listing(const std::string& folder) {
  std::set<std::string> names;
  for (const auto& e : std::filesystem::directory_iterator(folder))
    names.insert(e.path().filename().string());
  return names;
}

// Every command that only reads the store, with its output files in `out` (never beside
// the store).
std::vector<std::string> ReadingCommands(const LabDatabase& lab, const std::string& out) {
  return {"robot list",
          "robot list --json",
          "sessions",
          "sessions --robot puma --json",
          "session export 1 --poses " + Quoted(out + "/session1.csv"),
          "versions --robot puma",
          "versions --robot puma --json",
          "db info",
          "db export observations --csv",
          "db export calibrations --out " + Quoted(out + "/calibrations.csv"),
          "predict --robot puma --joints " + Quoted(lab.joints_csv),
          "compensate --robot puma --targets " + Quoted(lab.targets_csv) + " --out " +
              Quoted(out + "/joints.csv"),
          "export --robot puma --format json --out " + Quoted(out + "/signature.json"),
          "report --robot puma --set 1 --out " + Quoted(out + "/report"),
          "jobs",
          "jobs --json"};
}

// The commands that write, each of which must refuse a read-only store.
std::vector<std::string> WritingCommands(const LabDatabase& lab) {
  return {"robot add second --model " + Quoted(lab.model_yaml),
          "reduce",
          "activate --robot puma --version 1",
          "session discard 2",
          "import observations " + Quoted(lab.observations_csv) + " --stations " +
              Quoted(lab.stations_yaml),
          "recalibrate --robot puma --force",
          "schedule recalibrate --robot puma"};
}

// What every reading command prints on a writable copy (the reference).
std::vector<std::string> ReferenceOutputs(const std::vector<std::string>& commands,
                                          const std::string& db) {
  std::vector<std::string> outs;
  for (const auto& c : commands) {
    const auto r = RunArmsig("--db " + Quoted(db) + " " + c);
    EXPECT_EQ(r.exit_code, 0) << c << "\n" << r.err;
    outs.push_back(r.out);
  }
  return outs;
}

// Runs `commands` on `db` in a private mount namespace where `folder` (holding the database)
// is mounted read-only onto itself; returns each command's exit code, stdout and stderr.
std::vector<CommandResult> RunOnReadOnlyMount(const std::vector<std::string>& commands,
                                              const std::string& folder, const std::string& db,
                                              const std::string& results) {
  std::string script =
      "mount --bind -o ro " + Quoted(folder) + " " + Quoted(folder) + " || exit 9\n";
  for (size_t k = 0; k < commands.size(); ++k) {
    const std::string base = results + "/" + std::to_string(k);
    script += Quoted(ARMSIG_BINARY) + " --db " + Quoted(db) + " " + commands[k] + " > " +
              Quoted(base + ".out") + " 2> " + Quoted(base + ".err");
    script += "; echo $? > " + Quoted(base + ".rc") + "\n";
  }
  WriteText(results + "/script.sh", script);
  EXPECT_EQ(std::system(("unshare -rm sh " + Quoted(results + "/script.sh")).c_str()), 0);
  std::vector<CommandResult> out;
  for (size_t k = 0; k < commands.size(); ++k) {
    const std::string base = results + "/" + std::to_string(k);
    CommandResult r;
    r.exit_code = std::atoi(ReadText(base + ".rc").c_str());
    r.out = ReadText(base + ".out");
    r.err = ReadText(base + ".err");
    out.push_back(r);
  }
  return out;
}

TEST(ReadOnlyStore, EveryReadingCommandWorksOnAReadOnlyMountAndEveryWriterSaysReadOnly) {
  if (!PrivateMountsWork()) GTEST_SKIP() << "no private mount namespace here (unshare -rm)";
  TempDir reference_dir, ro_dir, results;
  const LabDatabase reference = CopyLabDatabase(reference_dir.path().string());
  const LabDatabase lab = CopyLabDatabase(ro_dir.path().string());
  const std::string out = results.File("outputs");
  std::filesystem::create_directories(out);
  const auto commands = ReadingCommands(lab, out);
  const auto expected = ReferenceOutputs(ReadingCommands(reference, out), reference.path);
  const auto before = Listing(ro_dir.path().string());
  const auto got =
      RunOnReadOnlyMount(commands, ro_dir.path().string(), lab.path, results.path().string());
  for (size_t k = 0; k < commands.size(); ++k) {
    SCOPED_TRACE(commands[k]);
    EXPECT_EQ(got[k].exit_code, 0) << got[k].err;
    std::string want = expected[k];  // `db info` names the file
    for (size_t at; (at = want.find(reference.path)) != std::string::npos;)
      want.replace(at, reference.path.size(), lab.path);
    EXPECT_EQ(got[k].out, want);
  }
  EXPECT_EQ(Listing(ro_dir.path().string()), before);  // no -wal, no -shm

  const auto writers = WritingCommands(lab);
  const auto refused =
      RunOnReadOnlyMount(writers, ro_dir.path().string(), lab.path, results.path().string());
  for (size_t k = 0; k < writers.size(); ++k) {
    SCOPED_TRACE(writers[k]);
    EXPECT_EQ(refused[k].exit_code, 2) << refused[k].err;
    EXPECT_NE(refused[k].err.find("read-only: it lies on a read-only file system"),
              std::string::npos)
        << refused[k].err;
    EXPECT_EQ(refused[k].err.find("unable to open"), std::string::npos) << refused[k].err;
    EXPECT_EQ(refused[k].err.find("not a usable"), std::string::npos) << refused[k].err;
  }
  EXPECT_EQ(Listing(ro_dir.path().string()), before);
}

// A writer has the database open (its -wal and -shm exist, with a commit only in the -wal)
// while a reader on a read-only mount of the same folder reads it: the reader sees the
// commit and makes nothing.
TEST(ReadOnlyStore, AReaderOnAReadOnlyMountSeesWhatALiveWriterCommitted) {
  if (!PrivateMountsWork()) GTEST_SKIP() << "no private mount namespace here (unshare -rm)";
  TempDir dir, results;
  const LabDatabase lab = CopyLabDatabase(dir.path().string());
  db::Database writer(lab.path, db::OpenMode::kMustExist);
  writer.connection().Exec("UPDATE robots SET model_name = 'renamed' WHERE name = 'puma'");
  ASSERT_TRUE(std::filesystem::exists(lab.path + "-wal"));
  ASSERT_TRUE(std::filesystem::exists(lab.path + "-shm"));
  const auto before = Listing(dir.path().string());
  const auto got =
      RunOnReadOnlyMount({"robot list"}, dir.path().string(), lab.path, results.path().string());
  EXPECT_EQ(got[0].exit_code, 0) << got[0].err;
  EXPECT_NE(got[0].out.find("renamed"), std::string::npos) << got[0].out;
  EXPECT_EQ(Listing(dir.path().string()), before);
}

// In a writable folder too, a reading command leaves nothing beside the file: a read-only
// connection could not remove a -wal or -shm it made (and one made with the file's mode 0444
// kept every later writer out).
TEST(ReadOnlyStore, ReadingCommandsMakeNoWalOrShmFile) {
  TempDir dir, out;
  const LabDatabase lab = CopyLabDatabase(dir.path().string());
  const auto before = Listing(dir.path().string());
  for (const auto& c : ReadingCommands(lab, out.path().string())) {
    const auto r = RunArmsig("--db " + Quoted(lab.path) + " " + c);
    EXPECT_EQ(r.exit_code, 0) << c << "\n" << r.err;
    EXPECT_EQ(Listing(dir.path().string()), before) << c;
  }
}

// A database copied with its -wal but not its -shm (the -wal holds a commit the file does
// not): read as a private copy, the commit seen, nothing made beside it.
TEST(ReadOnlyStore, AWalWithoutItsShmIsReadAsAPrivateCopy) {
  TempDir dir, copy;
  const LabDatabase lab = CopyLabDatabase(dir.path().string());
  {
    db::Database writer(lab.path, db::OpenMode::kMustExist);
    writer.connection().Exec("UPDATE robots SET model_name = 'in-the-wal' WHERE name = 'puma'");
    // Copied while the writer has it open: the commit is in the -wal only.
    std::filesystem::copy_file(lab.path, copy.File("lab.db"));
    std::filesystem::copy_file(lab.path + "-wal", copy.File("lab.db-wal"));
  }
  const auto before = Listing(copy.path().string());
  const auto r = RunArmsig("--db " + Quoted(copy.File("lab.db")) + " robot list");
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("in-the-wal"), std::string::npos) << r.out;
  EXPECT_EQ(Listing(copy.path().string()), before);
}

// A folder the user may not write (a lab's shared store, read by everyone): the readers
// work, the writers say read-only and name the folder. As root, whom permissions do not
// stop, the commands run as the unprivileged user nobody (setpriv): the store's files are
// theirs, root's folder is not; otherwise the folder's own write permission is taken away.
TEST(ReadOnlyStore, AFolderWithoutWritePermission) {
  namespace fs = std::filesystem;
  TempDir dir, out, bin;
  const LabDatabase lab = CopyLabDatabase(dir.path().string());
  std::string launcher, binary = ARMSIG_BINARY;
  if (::geteuid() == 0) {
    launcher = "setpriv --reuid=65534 --regid=65534 --clear-groups";
    // The program where nobody may run it (a clone under /root is not theirs to enter).
    binary = bin.File("armsig");
    fs::copy_file(ARMSIG_BINARY, binary);
    for (const auto& e : fs::directory_iterator(dir.path()))  // nobody's files, root's folder
      ASSERT_EQ(::chown(e.path().c_str(), 65534, 65534), 0) << e.path();
    fs::permissions(out.path(), fs::perms::all);  // the outputs go elsewhere
    ASSERT_EQ(RunArmsigThrough(launcher, "--version", "/", binary).exit_code, 0)
        << "setpriv as nobody";
  } else {
    fs::permissions(dir.path(), fs::perms::owner_read | fs::perms::owner_exec);
  }
  for (const auto& c : ReadingCommands(lab, out.path().string())) {
    const auto r = RunArmsigThrough(launcher, "--db " + Quoted(lab.path) + " " + c, "/", binary);
    EXPECT_EQ(r.exit_code, 0) << c << "\n" << r.err;
  }
  const auto r = RunArmsigThrough(launcher, "--db " + Quoted(lab.path) + " reduce", "/", binary);
  EXPECT_EQ(r.exit_code, 2) << r.err;
  EXPECT_NE(r.err.find("read-only: its folder"), std::string::npos) << r.err;
  fs::permissions(dir.path(), fs::perms::owner_all);
}

}  // namespace
}  // namespace armsig::testing
