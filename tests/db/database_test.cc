#include "db/database.h"

#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <atomic>
#include <filesystem>
#include <thread>

#include "core/error.h"
#include "db/calibrations.h"
#include "db/observations.h"
#include "db/postgres_connection.h"
#include "db/schema.h"
#include "db/sessions.h"
#include "support/stores.h"
#include "test_support.h"

namespace armsig::db {

// The tests of this file that are not about SQLite's file run on both backends.
class Store : public ::testing::TestWithParam<Backend> {
 protected:
  std::string NewStore(const std::string& name = "lab") {
    return testing::NewStore(GetParam(), dir_, name);
  }
  static void Exec(Database& db, const std::string& sql) { db.connection().Exec(sql); }
  static int64_t Count(Database& db, const std::string& sql) {
    return db.connection().QueryInt(sql);
  }
  testing::TempDir dir_;
};

TEST_P(Store, CreatesTheLatestSchemaEmpty) {
  Database db(NewStore());
  EXPECT_TRUE(db.created());
  EXPECT_EQ(db.backend(), GetParam());
  EXPECT_EQ(db.SchemaVersion(), LatestSchemaVersion());
  for (const auto& count : db.RowCounts()) EXPECT_EQ(count.rows, 0) << count.table;
  EXPECT_EQ(db.RowCounts().size(), TableNames().size());
}

// Opening a file while other connections open and close it: the last one to close
// removes the -wal, then the -shm, and an opening look that saw the -wal without its -shm
// copied a -wal that was gone ("cannot copy file", a writer lost, seen once under ASan).
TEST(Database, OpeningWhileOthersOpenAndCloseNeverFails) {
  testing::TempDir dir;
  const std::string path = dir.File("lab.db");
  { Database create(path); }
  std::atomic<int> failures{0};
  std::vector<std::thread> pool;
  for (int t = 0; t < 4; ++t) {
    pool.emplace_back([&] {
      for (int k = 0; k < 150; ++k) {
        try {
          Database db(path, OpenMode::kMustExist);
          if (db.connection().QueryInt("SELECT count(*) FROM robots") != 0) ++failures;
        } catch (const std::exception& e) {
          ADD_FAILURE() << e.what();
          ++failures;
        }
      }
    });
  }
  for (auto& t : pool) t.join();
  EXPECT_EQ(failures, 0);
}

// A session's poses are joined to their points through an index: no query of the loaders
// scans the points table (on pose_id alone it did so for every pose, 41,595 poses 380 s).
TEST(Database, PosesMeetTheirPointsThroughAnIndex) {
  testing::TempDir dir;
  Database db(dir.File("lab.db"));
  for (const char* query : {kRobotPosesQuery, kSessionPosesQuery}) {
    SQLite::Statement plan(db.sql(), std::string("EXPLAIN QUERY PLAN ") + query);
    std::string steps;
    while (plan.executeStep()) steps += plan.getColumn(3).getString() + "\n";
    EXPECT_NE(steps.find("SEARCH pt USING INDEX"), std::string::npos) << query << "\n" << steps;
    EXPECT_EQ(steps.find("SCAN pt"), std::string::npos) << query << "\n" << steps;
  }
}

TEST(Database, SqliteFileIsInWalModeWithForeignKeys) {
  testing::TempDir dir;
  Database db(dir.File("lab.db"));
  EXPECT_EQ(db.sql().execAndGet("PRAGMA journal_mode").getString(), "wal");
  EXPECT_EQ(db.sql().execAndGet("PRAGMA foreign_keys").getInt(), 1);
  EXPECT_EQ(db.sql().execAndGet("PRAGMA synchronous").getInt(), 2);  // FULL
}

TEST_P(Store, ReopeningDoesNotMigrateAgainAndKeepsRows) {
  const std::string store = NewStore();
  {
    Database db(store);
    Exec(db, "INSERT INTO robots(name, model_name, model_yaml) VALUES ('r1','puma760','x')");
  }
  Database db(store);
  EXPECT_FALSE(db.created());
  EXPECT_EQ(Count(db, "SELECT count(*) FROM robots"), 1);
}

// A file written by schema v1 (the base transform inside report_json) opens as the latest with
// the transform in its own column, and the stored parameter set reads back with it.
TEST(Database, MigratesAVersion1FileKeepingItsParameterSets) {
  testing::TempDir dir;
  const std::string path = dir.File("v1.db");
  {
    SQLite::Database raw(path, SQLite::OPEN_READWRITE | SQLite::OPEN_CREATE);
    raw.exec(std::string(Migrations()[0]));
    raw.exec("PRAGMA user_version=1");
    raw.exec("INSERT INTO robots(name, model_name, model_yaml) VALUES ('r1','puma760','x')");
    raw.exec(
        "INSERT INTO calibrations(robot_id, version, active, params_spec, inputs_json, "
        "options_json, rank, poses_fit, report_json) VALUES (1, 1, 1, 'all', '{}', '{}', 29, 80, "
        "'{\"base\": [[1,0,0,1500.5],[0,0,-1,-20.25],[0,1,0,300],[0,0,0,1]]}')");
    raw.exec(
        "INSERT INTO calibrations(robot_id, version, active, params_spec, inputs_json, "
        "options_json, rank, poses_fit, report_json) VALUES (1, 2, 0, 'all', '{}', '{}', 29, 80, "
        "'not json')");
  }
  Database db(path);
  EXPECT_EQ(db.SchemaVersion(), LatestSchemaVersion());
  EXPECT_EQ(db.sql().execAndGet("SELECT count(*) FROM calibrations").getInt(), 2);
  const auto history = CalibrationHistory(db, 1);
  ASSERT_EQ(history.size(), 2u);
  ASSERT_TRUE(history[0].world_from_base.has_value());
  Eigen::Matrix4d expected;
  expected << 1, 0, 0, 1500.5, 0, 0, -1, -20.25, 0, 1, 0, 300, 0, 0, 0, 1;
  EXPECT_EQ(history[0].world_from_base->matrix(), expected);
  EXPECT_FALSE(history[1].world_from_base.has_value());  // nothing to carry over
  EXPECT_TRUE(history[0].covariance_parameters.empty());  // v3: none stored before
}

// A file of schema v3 (before the laser-tracker environment columns) opens as the latest:
// its readings keep their values and have no temperature, pressure or humidity; a new
// reading stores and reads them back, and a theodolite reading leaves them NULL.
TEST(Database, MigratesAVersion3FileToReadingsWithTheirEnvironment) {
  testing::TempDir dir;
  const std::string path = dir.File("v3.db");
  {
    SQLite::Database raw(path, SQLite::OPEN_READWRITE | SQLite::OPEN_CREATE);
    for (int v = 0; v < 3; ++v) raw.exec(std::string(Migrations()[v]));
    raw.exec("PRAGMA user_version=3");
    raw.exec("INSERT INTO robots(name, model_name, model_yaml) VALUES ('r1','puma760','x')");
    raw.exec("INSERT INTO sessions(robot_id, state) VALUES (1, 'completed')");
    raw.exec("INSERT INTO stations(code) VALUES ('T1')");
    raw.exec(
        "INSERT INTO observations(session_id, point, station_id, hz_rad, v_rad) VALUES (1, 'p', "
        "1, 1.25, 1.5)");
  }
  Database db(path);
  EXPECT_EQ(db.SchemaVersion(), LatestSchemaVersion());
  auto rows = LoadObservations(db, 1);
  ASSERT_EQ(rows.size(), 1u);
  EXPECT_EQ(rows[0].reading.hz_rad, 1.25);
  EXPECT_FALSE(rows[0].temperature_c || rows[0].pressure_hpa || rows[0].humidity_percent);
  ObservationRow tracker;
  tracker.point = "q";
  tracker.station = "LT1";
  tracker.reading = {0.5, 1.4, 1};
  tracker.distance_mm = 2750.125;
  tracker.temperature_c = 20.37;
  tracker.pressure_hpa = 1012.8;
  tracker.humidity_percent = 44.1;
  ObservationRow theodolite = tracker;
  theodolite.point = "r";
  theodolite.distance_mm.reset();
  theodolite.temperature_c.reset();
  theodolite.pressure_hpa.reset();
  theodolite.humidity_percent.reset();
  InsertObservations(db, 1, {tracker, theodolite});
  rows = LoadObservations(db, 1);
  ASSERT_EQ(rows.size(), 3u);
  EXPECT_EQ(rows[1].point, "q");
  EXPECT_EQ(rows[1].temperature_c, 20.37);
  EXPECT_EQ(rows[1].pressure_hpa, 1012.8);
  EXPECT_EQ(rows[1].humidity_percent, 44.1);
  EXPECT_FALSE(rows[2].temperature_c.has_value());
}

TEST_P(Store, CovarianceOfAParameterSetRoundTrips) {
  Database db(NewStore());
  Exec(db, "INSERT INTO robots(name, model_name, model_yaml) VALUES ('r1','puma760','x')");
  CalibrationRecord record;
  record.robot_id = 1;
  record.params_spec = "all";
  record.inputs_json = record.options_json = "{}";
  record.covariance_parameters = {"a2", "beta2"};
  record.covariance.resize(2, 2);
  record.covariance << 1e-4, -2.5e-7, -2.5e-7, 3.0000000000000001e-9;
  InsertCalibration(db, record);
  const auto history = CalibrationHistory(db, 1);
  ASSERT_EQ(history.size(), 1u);
  EXPECT_EQ(history[0].covariance_parameters, record.covariance_parameters);
  EXPECT_EQ(history[0].covariance, record.covariance);  // exact: JSON keeps 17 digits
}

TEST_P(Store, RefusesANewerSchemaUntouched) {
  const std::string store = NewStore();
  const std::string newer = std::to_string(LatestSchemaVersion() + 1);
  {
    Database db(store);
    Exec(db, GetParam() == Backend::kSqlite ? "PRAGMA user_version=" + newer
                                            : "UPDATE armsig_schema SET version = " + newer);
  }
  for (OpenMode mode : {OpenMode::kCreate, OpenMode::kMustExist, OpenMode::kReadOnly}) {
    try {
      Database db(store, mode);
      ADD_FAILURE() << "opened a newer schema";
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find("schema version " + newer + " is newer"),
                std::string::npos)
          << e.what();
    }
  }
  if (GetParam() == Backend::kPostgres) {  // still the newer version: nothing was written
    auto c = std::make_unique<PostgresConnection>(store);
    EXPECT_EQ(c->QueryInt("SELECT version FROM armsig_schema"), LatestSchemaVersion() + 1);
  }
}

TEST(Database, RefusesAFileThatIsNotADatabase) {
  testing::TempDir dir;
  testing::WriteText(dir.File("junk.db"), std::string(4096, 'x'));
  EXPECT_THROW(Database(dir.File("junk.db")), InputError);
}

TEST_P(Store, ForeignKeysAreEnforced) {
  Database db(NewStore());
  try {
    Exec(db, "INSERT INTO sessions(robot_id) VALUES (42)");
    ADD_FAILURE() << "a session of no robot was stored";
  } catch (const DatabaseError& e) {
    EXPECT_FALSE(e.transient());
  }
  EXPECT_EQ(Count(db, "SELECT count(*) FROM sessions"), 0);
}

TEST_P(Store, ExportsTablesAsCsvAndRejectsUnknownTables) {
  Database db(NewStore());
  Exec(db, "INSERT INTO robots(name, model_name, model_yaml) VALUES ('r,1','puma760','a\"b')");
  const std::string csv = db.ExportCsv("robots");
  // The header names the table's columns in order (later schemas add the controller's).
  EXPECT_EQ(csv.rfind("id,name,model_name,model_yaml,created_at,", 0), 0u) << csv;
  EXPECT_NE(csv.find("\"r,1\""), std::string::npos);
  EXPECT_NE(csv.find("\"a\"\"b\""), std::string::npos);
  EXPECT_THROW(db.ExportCsv("robots; DROP TABLE robots"), InputError);
  // An empty table still has its header.
  EXPECT_EQ(db.ExportCsv("activations"),
            "id,robot_id,version,previous_version,activated_at,activated_by,note,uuid\n");
}

// The same rows give the same CSV on both backends: numbers to the last digit, NULL empty,
// parameters in the order they were stored (not by name).
TEST(Database, CsvExportIsTheSameTextOnBothBackends) {
  testing::TempDir dir;
  std::string csv[2];
  for (Backend backend : {Backend::kSqlite, Backend::kPostgres}) {
    Database db(testing::NewStore(backend, dir, "csv"));
    db.connection().Exec(
        "INSERT INTO robots(name, model_name, model_yaml) VALUES ('r','puma760','x')");
    CalibrationRecord record;
    record.robot_id = 1;
    record.params_spec = "all";
    record.inputs_json = record.options_json = "{}";
    record.parameters = {{"d1", "mm", 1.0 / 3.0, 2.5e-300, true},
                         {"alpha1", "rad", -6.02214076e-7, NAN, false},
                         {"a1", "mm", 0.1, 1e-3, true}};
    InsertCalibration(db, record);
    csv[backend == Backend::kPostgres] = db.ExportCsv("calibration_parameters");
  }
  EXPECT_EQ(csv[1], csv[0]);
  EXPECT_EQ(csv[0],
            "calibration_id,name,value,unit,identified,sigma,seq\n"
            "1,d1,0.33333333333333331,mm,1,2.5e-300,1\n"  // %.17g, as printf gives it
            "1,alpha1,-6.0221407599999995e-07,rad,0,,2\n"
            "1,a1,0.10000000000000001,mm,1,0.001,3\n");
}

// A writer killed with SIGKILL in the middle of a transaction: the reopened file is
// consistent and holds every committed row, and none of the uncommitted ones.
TEST_P(Store, SurvivesSigkillMidTransaction) {
  const std::string path = NewStore();
  {
    Database db(path);
    Exec(db, "INSERT INTO robots(name, model_name, model_yaml) VALUES ('r','puma760','')");
    Exec(db, "INSERT INTO sessions(robot_id) VALUES (1)");
  }
  int pipe_fd[2];
  ASSERT_EQ(::pipe(pipe_fd), 0);
  const pid_t child = ::fork();
  ASSERT_GE(child, 0);
  if (child == 0) {
    ::close(pipe_fd[0]);
    Database db(path);
    // 50 committed transactions of 3 poses each, then one left open forever.
    for (int t = 0; t < 50; ++t) {
      WriteTransaction tx(db);
      for (int k = 0; k < 3; ++k) {
        Exec(db, "INSERT INTO poses(session_id, seq, label, joints_json, status) VALUES (1, " +
                     std::to_string(3 * t + k) + ", 'p', '[0,0,0,0,0,0]', 'measured')");
      }
      tx.commit();
    }
    WriteTransaction open_tx(db);
    for (int k = 0; k < 1000; ++k) {
      Exec(db, "INSERT INTO poses(session_id, seq, label, joints_json, status) VALUES (1, " +
                   std::to_string(1000 + k) + ", 'uncommitted', NULL, 'skipped')");
    }
    const char ready = 'r';
    if (::write(pipe_fd[1], &ready, 1) != 1) _exit(3);
    for (;;) ::pause();  // killed here, transaction open
  }
  ::close(pipe_fd[1]);
  char ready = 0;
  ASSERT_EQ(::read(pipe_fd[0], &ready, 1), 1);
  ::close(pipe_fd[0]);
  ASSERT_EQ(::kill(child, SIGKILL), 0);
  int status = 0;
  ::waitpid(child, &status, 0);
  ASSERT_TRUE(WIFSIGNALED(status));

  Database db(path);
  if (GetParam() == Backend::kSqlite) {
    EXPECT_EQ(db.sql().execAndGet("PRAGMA integrity_check").getString(), "ok");
  }
  EXPECT_EQ(Count(db, "SELECT count(*) FROM poses"), 150);
  EXPECT_EQ(Count(db, "SELECT count(*) FROM poses WHERE label='uncommitted'"), 0);
  EXPECT_EQ(Count(db, "SELECT max(seq) FROM poses"), 149);
}

// Two writers at once: the busy timeout makes the second wait instead of failing.
TEST_P(Store, ConcurrentWritersWaitForEachOther) {
  const std::string path = NewStore();
  { Database db(path); }
  auto writer = [&](int offset) {
    Database db(path);
    for (int i = 0; i < 100; ++i) {
      WriteTransaction tx(db);
      Exec(db, "INSERT INTO instruments(name, kind, protocol) VALUES ('i" +
                   std::to_string(offset + i) + "', 'theodolite', 'geocom')");
      tx.commit();
    }
  };
  std::thread a(writer, 0), b(writer, 1000);
  a.join();
  b.join();
  Database db(path);
  EXPECT_EQ(Count(db, "SELECT count(*) FROM instruments"), 200);
}

// A command that only reads opens with kMustExist: a missing file is an input error
// naming it, and nothing is created; an existing database opens as usual.
// A reading command reads a file no connection has open immutable (nothing made beside it),
// holding SQLite's shared lock: a writer that opens and closes the file meanwhile cannot
// checkpoint into it on close (its commit waits in the -wal for the next writer, lost to
// nobody), and one that checkpoints while the reader reads (a -wal past 4 MB; here by hand)
// is seen: ChangedWhileRead.
TEST(Database, AnImmutableReadHoldsOffTheClosingCheckpointAndSeesAnotherOne) {
  testing::TempDir dir;
  const std::string path = dir.File("lab.db");
  { Database created(path); }
  ASSERT_FALSE(std::filesystem::exists(path + "-wal"));
  Database reader(path, OpenMode::kReadOnly);
  EXPECT_FALSE(std::filesystem::exists(path + "-shm"));  // immutable: nothing made
  {
    Database writer(path, OpenMode::kMustExist);
    writer.connection().Exec(
        "INSERT INTO robots(name, model_name, model_yaml) VALUES ('a', '', '')");
  }
  EXPECT_TRUE(std::filesystem::exists(path + "-wal"));  // not checkpointed under the reader
  EXPECT_FALSE(reader.ChangedWhileRead());
  {
    Database writer(path, OpenMode::kMustExist);
    EXPECT_EQ(writer.connection().QueryInt("SELECT count(*) FROM robots"), 1);
    writer.connection().Exec("PRAGMA wal_checkpoint(FULL)");
  }
  EXPECT_TRUE(reader.ChangedWhileRead());
}

TEST(Database, MustExistRefusesAMissingFileAndCreatesNothing) {
  testing::TempDir dir;
  const std::string path = dir.File("typo.db");
  try {
    Database db(path, OpenMode::kMustExist);
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_EQ(e.where().file, path);
    EXPECT_NE(std::string(e.what()).find("no such database file"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("--db or $ARMSIG_DB"), std::string::npos) << e.what();
  }
  EXPECT_FALSE(std::filesystem::exists(path));
  { Database created(path); }  // kCreate, the default
  Database db(path, OpenMode::kMustExist);
  EXPECT_EQ(db.SchemaVersion(), LatestSchemaVersion());
}

ARMSIG_BOTH_BACKENDS(Store);

}  // namespace armsig::db
