// Hostile databases: a file armsig did not make, a schema from the future and a
// damaged file are refused before anything is written to them (byte for byte the same
// afterwards, no -wal or -shm created next to them); concurrent writers wait their turn.
#include <fcntl.h>
#include <gtest/gtest.h>
#include <spawn.h>
#include <sys/stat.h>
#include <sys/wait.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <functional>
#include <set>
#include <utility>

#include "core/error.h"
#include "db/database.h"
#include "db/schema.h"
#include "test_support.h"

extern char** environ;

namespace armsig::db {
namespace {

using testing::ReadText;
using testing::TempDir;

std::string Refusal(const std::string& path) {
  try {
    Database db(path);
  } catch (const InputError& e) {
    return e.what();
  }
  ADD_FAILURE() << path << ": expected an InputError";
  return "";
}

// A read-only look from the test that leaves no -wal or -shm behind (a plain read-only
// connection to a WAL-mode file creates both).
SQLite::Database Immutable(const std::string& path) {
  return SQLite::Database("file:" + path + "?immutable=1",
                          SQLite::OPEN_READONLY | SQLite::OPEN_URI);
}

// The file is exactly `before`, and SQLite left nothing beside it.
void ExpectUntouched(const std::string& path, const std::string& before) {
  EXPECT_TRUE(ReadText(path) == before) << path << " changed";
  EXPECT_FALSE(std::filesystem::exists(path + "-wal")) << path << "-wal created";
  EXPECT_FALSE(std::filesystem::exists(path + "-shm")) << path << "-shm created";
  EXPECT_FALSE(std::filesystem::exists(path + "-journal")) << path << "-journal created";
}

// A real armsig database with enough rows for its robots table to span several pages.
void MakeArmsigDatabase(const std::string& path) {
  Database db(path);
  WriteTransaction tx(db);
  SQLite::Statement insert(db.sql(),
                           "INSERT INTO robots(name, model_name, model_yaml) VALUES (?, 'm', ?)");
  for (int i = 0; i < 200; ++i) {
    insert.bind(1, "robot " + std::to_string(i));
    insert.bind(2, std::string(300, static_cast<char>('a' + i % 26)));
    insert.exec();
    insert.reset();
  }
  tx.commit();
}

TEST(DatabaseIntegrity, NewAndMigratedFilesCarryArmsigsApplicationId) {
  TempDir dir;
  {
    Database db(dir.File("new.db"));
    EXPECT_EQ(db.sql().execAndGet("PRAGMA application_id").getInt(), kApplicationId);
    EXPECT_TRUE(db.created());
  }
  // An armsig file from before application_id: user_version set, armsig's tables.
  const std::string old = dir.File("old.db");
  {
    SQLite::Database raw(old, SQLite::OPEN_READWRITE | SQLite::OPEN_CREATE);
    for (int v = 0; v < LatestSchemaVersion(); ++v) raw.exec(std::string(Migrations()[v]));
    raw.exec("PRAGMA user_version=" + std::to_string(LatestSchemaVersion()));
    raw.exec("INSERT INTO robots(name, model_name, model_yaml) VALUES ('r1','puma760','x')");
  }
  Database db(old);
  EXPECT_FALSE(db.created());
  EXPECT_EQ(db.sql().execAndGet("PRAGMA application_id").getInt(), kApplicationId);
  EXPECT_EQ(db.sql().execAndGet("SELECT count(*) FROM robots").getInt(), 1);
}

TEST(DatabaseIntegrity, AnotherApplicationsSqliteFileIsRefusedUntouched) {
  TempDir dir;
  const std::string path = dir.File("customers.db");
  {
    SQLite::Database raw(path, SQLite::OPEN_READWRITE | SQLite::OPEN_CREATE);
    raw.exec("CREATE TABLE customers(id INTEGER PRIMARY KEY, name TEXT)");
    raw.exec("INSERT INTO customers(name) VALUES ('Ada'), ('Grace')");
  }
  const std::string before = ReadText(path);
  const std::string why = Refusal(path);
  EXPECT_NE(why.find("not an armsig database"), std::string::npos) << why;
  EXPECT_NE(why.find("customers"), std::string::npos) << why;
  ExpectUntouched(path, before);
  // Read-only commands (OpenMode::kMustExist) refuse it the same way.
  EXPECT_THROW(Database(path, OpenMode::kMustExist), InputError);
  ExpectUntouched(path, before);
}

TEST(DatabaseIntegrity, AForeignApplicationIdIsRefusedEvenInWalMode) {
  TempDir dir;
  const std::string path = dir.File("other.db");
  {
    SQLite::Database raw(path, SQLite::OPEN_READWRITE | SQLite::OPEN_CREATE);
    raw.exec("PRAGMA journal_mode=WAL");
    raw.exec("PRAGMA application_id=1196444237");             // 'GPKG': a GeoPackage
    raw.exec("CREATE TABLE robots(id INTEGER PRIMARY KEY)");  // even with a table of ours
  }
  const std::string before = ReadText(path);
  const std::string why = Refusal(path);
  EXPECT_NE(why.find("another application's"), std::string::npos) << why;
  ExpectUntouched(path, before);
}

TEST(DatabaseIntegrity, AForeignWalFileWithoutApplicationIdIsRefusedUntouched) {
  TempDir dir;
  const std::string path = dir.File("notes.db");
  {
    SQLite::Database raw(path, SQLite::OPEN_READWRITE | SQLite::OPEN_CREATE);
    raw.exec("PRAGMA journal_mode=WAL");
    raw.exec("CREATE TABLE notes(body TEXT)");
  }
  const std::string before = ReadText(path);
  EXPECT_NE(Refusal(path).find("not an armsig database"), std::string::npos);
  ExpectUntouched(path, before);
}

TEST(DatabaseIntegrity, AFutureSchemaVersionIsRefusedUntouched) {
  TempDir dir;
  const std::string path = dir.File("future.db");
  MakeArmsigDatabase(path);
  {
    SQLite::Database raw(path, SQLite::OPEN_READWRITE);
    raw.exec("PRAGMA user_version=" + std::to_string(LatestSchemaVersion() + 1));
  }
  const std::string before = ReadText(path);
  const std::string why = Refusal(path);
  EXPECT_NE(why.find("newer than this armsig"), std::string::npos) << why;
  ExpectUntouched(path, before);

  // The same in a rollback-journal file (it used to be switched to WAL before the refusal).
  const std::string rollback = dir.File("future-rollback.db");
  {
    SQLite::Database raw(rollback, SQLite::OPEN_READWRITE | SQLite::OPEN_CREATE);
    raw.exec(std::string(Migrations()[0]));
    raw.exec("PRAGMA user_version=" + std::to_string(LatestSchemaVersion() + 7));
  }
  const std::string rollback_before = ReadText(rollback);
  EXPECT_NE(Refusal(rollback).find("newer than this armsig"), std::string::npos);
  ExpectUntouched(rollback, rollback_before);
}

TEST(DatabaseIntegrity, ADamagedFileIsRefusedWithTheRecoveryCommandAndNotWritten) {
  TempDir dir;
  const std::string path = dir.File("damaged.db");
  MakeArmsigDatabase(path);
  int root_page = 0, page_size = 0;
  {
    SQLite::Database raw = Immutable(path);
    root_page = raw.execAndGet("SELECT rootpage FROM sqlite_master WHERE name = 'robots'").getInt();
    page_size = raw.execAndGet("PRAGMA page_size").getInt();
    ASSERT_GT(raw.execAndGet("PRAGMA page_count").getInt(), root_page + 5);
  }
  ASSERT_GT(root_page, 1);
  {
    // Overwrite the b-tree page header of the robots table's root page (its page type and
    // cell count) with garbage.
    std::fstream file(path, std::ios::in | std::ios::out | std::ios::binary);
    file.seekp(static_cast<std::streamoff>(root_page - 1) * page_size);
    const std::string garbage(8, '\xa5');
    file.write(garbage.data(), static_cast<std::streamsize>(garbage.size()));
  }
  {
    // Precondition, checked independently: SQLite itself finds the damage.
    SQLite::Database raw = Immutable(path);
    EXPECT_NE(raw.execAndGet("PRAGMA quick_check").getString(), "ok");
  }
  const std::string before = ReadText(path);
  const std::string why = Refusal(path);
  EXPECT_EQ(why.rfind(path + ": ", 0), 0u) << why;  // names the file first
  EXPECT_NE(why.find("damaged"), std::string::npos) << why;
  EXPECT_NE(why.find("sqlite3 " + path + " \".recover\" | sqlite3 recovered.db"), std::string::npos)
      << why;
  ExpectUntouched(path, before);
}

TEST(DatabaseIntegrity, ANonSqliteFileIsRefusedUntouched) {
  TempDir dir;
  const std::string path = dir.File("notes.txt");
  testing::WriteText(path, "my notes, not a database\n");
  EXPECT_NE(Refusal(path).find("not an SQLite database"), std::string::npos);
  ExpectUntouched(path, "my notes, not a database\n");
}

// Eight `armsig import observations` processes started together on one database file that
// does not exist yet: every one exits 0 and every row is stored exactly once.
TEST(DatabaseIntegrity, EightConcurrentWriterProcessesAllSucceedAndStoreEveryRowOnce) {
  TempDir dir;
  const std::string db = dir.File("lab.db");
  const std::string observations = testing::DataPath("networks/k06/observations.csv");
  const std::string stations = testing::DataPath("networks/k06/stations.yaml");
  const int expected_rows = [&] {
    std::ifstream in(observations);
    int lines = 0;
    for (std::string line; std::getline(in, line);) lines += !line.empty() && line[0] != '#';
    return lines - 1;  // the header
  }();
  ASSERT_GT(expected_rows, 100);
  constexpr int kWriters = 8;
  std::vector<pid_t> children;
  for (int k = 0; k < kWriters; ++k) {
    const std::string note = "writer " + std::to_string(k);
    const std::string err = dir.File("err" + std::to_string(k));
    std::vector<std::string> args = {ARMSIG_BINARY, "-q",           "--db",       db,
                                     "import",      "observations", observations, "--stations",
                                     stations,      "--note",       note};
    std::vector<char*> argv;
    for (auto& a : args) argv.push_back(a.data());
    argv.push_back(nullptr);
    posix_spawn_file_actions_t actions;
    posix_spawn_file_actions_init(&actions);
    posix_spawn_file_actions_addopen(&actions, 1, "/dev/null", O_WRONLY, 0);
    posix_spawn_file_actions_addopen(&actions, 2, err.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    pid_t pid = 0;
    ASSERT_EQ(posix_spawn(&pid, ARMSIG_BINARY, &actions, nullptr, argv.data(), environ), 0);
    posix_spawn_file_actions_destroy(&actions);
    children.push_back(pid);
  }
  for (int k = 0; k < kWriters; ++k) {
    int status = 0;
    ASSERT_EQ(::waitpid(children[k], &status, 0), children[k]);
    EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0)
        << "writer " << k << ": " << ReadText(dir.File("err" + std::to_string(k)));
  }
  Database database(db, OpenMode::kMustExist);
  EXPECT_EQ(database.sql().execAndGet("SELECT count(*) FROM observations").getInt(),
            kWriters * expected_rows);
  SQLite::Statement sessions(database.sql(),
                             "SELECT s.note, count(o.id) FROM sessions s LEFT JOIN observations o "
                             "ON o.session_id = s.id GROUP BY s.id ORDER BY s.id");
  std::multiset<std::string> notes;
  while (sessions.executeStep()) {
    notes.insert(sessions.getColumn(0).getString());
    EXPECT_EQ(sessions.getColumn(1).getInt(), expected_rows) << sessions.getColumn(0).getString();
  }
  EXPECT_EQ(notes.size(), static_cast<size_t>(kWriters));
  for (int k = 0; k < kWriters; ++k) EXPECT_EQ(notes.count("writer " + std::to_string(k)), 1u);
}

// --- Hostile inputs, a second audit.

// A WAL-mode database written by `make` and copied, while its writer still has it open,
// together with its -wal but not its -shm (what a backup of the two files, or a copy
// from another machine, gives). The copy's content lives in its -wal.
std::string CopiedWithWal(const TempDir& dir, const std::string& name,
                          const std::function<void(SQLite::Database&)>& make) {
  const std::string original = dir.File(name + ".orig");
  const std::string copy = dir.File(name);
  SQLite::Database raw(original, SQLite::OPEN_READWRITE | SQLite::OPEN_CREATE);
  raw.exec("PRAGMA journal_mode=WAL");
  raw.exec("PRAGMA wal_autocheckpoint=0");
  make(raw);
  std::filesystem::copy_file(original, copy);
  std::filesystem::copy_file(original + "-wal", copy + "-wal");
  return copy;
}

TEST(DatabaseIntegrity, AForeignOrFutureFileWithAWalButNoShmIsRefusedAndNoShmAppears) {
  TempDir dir;
  const std::string foreign = CopiedWithWal(dir, "foreign.db", [](SQLite::Database& db) {
    db.exec("CREATE TABLE invoices(id INTEGER PRIMARY KEY, total REAL)");
    db.exec("INSERT INTO invoices(total) VALUES (12.5)");
  });
  const std::string future = CopiedWithWal(dir, "future.db", [](SQLite::Database& db) {
    for (int v = 0; v < LatestSchemaVersion(); ++v) db.exec(std::string(Migrations()[v]));
    db.exec("PRAGMA application_id=" + std::to_string(kApplicationId));
    db.exec("PRAGMA user_version=" + std::to_string(LatestSchemaVersion() + 1));
  });
  for (const auto& [path, why] : {std::pair{foreign, std::string("not an armsig database")},
                                  std::pair{future, std::string("newer than this armsig")}}) {
    const std::string before = ReadText(path), wal_before = ReadText(path + "-wal");
    for (const OpenMode mode : {OpenMode::kReadOnly, OpenMode::kCreate}) {
      try {
        Database db(path, mode);
        ADD_FAILURE() << path << ": expected an InputError";
      } catch (const InputError& e) {
        EXPECT_NE(std::string(e.what()).find(why), std::string::npos) << e.what();
      }
      EXPECT_TRUE(ReadText(path) == before) << path;
      EXPECT_TRUE(ReadText(path + "-wal") == wal_before) << path;
      EXPECT_FALSE(std::filesystem::exists(path + "-shm")) << path << "-shm created";
    }
  }
  // armsig's own file copied the same way is read with its -wal's content.
  const std::string own = CopiedWithWal(dir, "own.db", [](SQLite::Database& db) {
    for (int v = 0; v < LatestSchemaVersion(); ++v) db.exec(std::string(Migrations()[v]));
    db.exec("PRAGMA application_id=" + std::to_string(kApplicationId));
    db.exec("PRAGMA user_version=" + std::to_string(LatestSchemaVersion()));
    db.exec("INSERT INTO robots(name, model_name, model_yaml) VALUES ('r1', 'm', 'x')");
  });
  Database db(own, OpenMode::kReadOnly);
  EXPECT_EQ(db.sql().execAndGet("SELECT count(*) FROM robots").getInt(), 1);
}

TEST(DatabaseIntegrity, ArmsigsApplicationIdWithSchemaVersionZeroAndTablesIsRefusedUntouched) {
  TempDir dir;
  const std::string path = dir.File("zero.db");
  MakeArmsigDatabase(path);
  {
    SQLite::Database raw(path, SQLite::OPEN_READWRITE);
    raw.exec("PRAGMA user_version=0");
  }
  const std::string before = ReadText(path);
  const std::string why = Refusal(path);
  EXPECT_NE(why.find("carries armsig's application_id but is not a database armsig made "
                     "(schema version 0"),
            std::string::npos)
      << why;
  EXPECT_EQ(why.find("already exists"), std::string::npos) << why;
  ExpectUntouched(path, before);
}

TEST(DatabaseIntegrity, CommandsThatOnlyReadCreateAndInitialiseNothing) {
  TempDir dir;
  const std::string empty = dir.File("empty.db");
  testing::WriteText(empty, "");
  for (const OpenMode mode : {OpenMode::kReadOnly, OpenMode::kMustExist}) {
    try {
      Database db(empty, mode);
      ADD_FAILURE() << "an empty file was opened";
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find("an empty file, not an armsig database yet"),
                std::string::npos)
          << e.what();
    }
    ExpectUntouched(empty, "");
  }
  EXPECT_THROW(Database(dir.File("missing.db"), OpenMode::kReadOnly), InputError);
  EXPECT_FALSE(std::filesystem::exists(dir.File("missing.db")));

  // An armsig file of schema v1 is read through a migrated copy in memory: the file is left
  // byte for byte (no migration written, no application_id set).
  const std::string old = dir.File("v1.db");
  {
    SQLite::Database raw(old, SQLite::OPEN_READWRITE | SQLite::OPEN_CREATE);
    raw.exec(std::string(Migrations()[0]));
    raw.exec("PRAGMA user_version=1");
    raw.exec("INSERT INTO robots(name, model_name, model_yaml) VALUES ('r1','puma760','x')");
  }
  const std::string before = ReadText(old);
  {
    Database db(old, OpenMode::kReadOnly);
    EXPECT_TRUE(db.read_only());
    EXPECT_EQ(db.SchemaVersion(), LatestSchemaVersion());
    EXPECT_EQ(db.sql().execAndGet("SELECT count(*) FROM robots").getInt(), 1);
  }
  EXPECT_TRUE(ReadText(old) == before);
  // A read-only connection refuses writes.
  const std::string current = dir.File("current.db");
  MakeArmsigDatabase(current);
  Database db(current, OpenMode::kReadOnly);
  EXPECT_THROW(db.sql().exec("DELETE FROM robots"), SQLite::Exception);
}

TEST(DatabaseIntegrity, ANonRegularFileIsNeverOpened) {
  TempDir dir;
  const std::string fifo = dir.File("lab.db");
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  const auto start = std::chrono::steady_clock::now();
  for (const OpenMode mode : {OpenMode::kCreate, OpenMode::kReadOnly}) {
    try {
      Database db(fifo, mode);
      ADD_FAILURE() << "a FIFO was opened";
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find("not a regular file"), std::string::npos) << e.what();
    }
  }
  EXPECT_LT(std::chrono::steady_clock::now() - start, std::chrono::seconds(2));
}

}  // namespace
}  // namespace armsig::db
