#include "db/database.h"

#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <filesystem>
#include <thread>

#include "core/error.h"
#include "db/calibrations.h"
#include "db/observations.h"
#include "db/schema.h"
#include "test_support.h"

namespace armsig::db {

TEST(Database, CreatesLatestSchemaWithWalAndForeignKeys) {
  testing::TempDir dir;
  Database db(dir.File("lab.db"));
  EXPECT_EQ(db.SchemaVersion(), LatestSchemaVersion());
  EXPECT_EQ(db.sql().execAndGet("PRAGMA journal_mode").getString(), "wal");
  EXPECT_EQ(db.sql().execAndGet("PRAGMA foreign_keys").getInt(), 1);
  for (const auto& count : db.RowCounts()) EXPECT_EQ(count.rows, 0) << count.table;
  EXPECT_EQ(db.RowCounts().size(), TableNames().size());
}

TEST(Database, ReopeningDoesNotMigrateAgainAndKeepsRows) {
  testing::TempDir dir;
  {
    Database db(dir.File("lab.db"));
    db.sql().exec("INSERT INTO robots(name, model_name, model_yaml) VALUES ('r1','puma760','x')");
  }
  Database db(dir.File("lab.db"));
  EXPECT_EQ(db.sql().execAndGet("SELECT count(*) FROM robots").getInt(), 1);
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

TEST(Database, CovarianceOfAParameterSetRoundTrips) {
  testing::TempDir dir;
  Database db(dir.File("lab.db"));
  db.sql().exec("INSERT INTO robots(name, model_name, model_yaml) VALUES ('r1','puma760','x')");
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

TEST(Database, RefusesNewerSchema) {
  testing::TempDir dir;
  {
    Database db(dir.File("lab.db"));
    db.sql().exec("PRAGMA user_version=" + std::to_string(LatestSchemaVersion() + 1));
  }
  EXPECT_THROW(Database(dir.File("lab.db")), InputError);
}

TEST(Database, RefusesAFileThatIsNotADatabase) {
  testing::TempDir dir;
  testing::WriteText(dir.File("junk.db"), std::string(4096, 'x'));
  EXPECT_THROW(Database(dir.File("junk.db")), InputError);
}

TEST(Database, ForeignKeysAreEnforced) {
  testing::TempDir dir;
  Database db(dir.File("lab.db"));
  EXPECT_THROW(db.sql().exec("INSERT INTO sessions(robot_id) VALUES (42)"), SQLite::Exception);
}

TEST(Database, ExportsTablesAsCsvAndRejectsUnknownTables) {
  testing::TempDir dir;
  Database db(dir.File("lab.db"));
  db.sql().exec("INSERT INTO robots(name, model_name, model_yaml) VALUES ('r,1','puma760','a\"b')");
  const std::string csv = db.ExportCsv("robots");
  EXPECT_NE(csv.find("id,name,model_name,model_yaml,created_at\n"), std::string::npos);
  EXPECT_NE(csv.find("\"r,1\""), std::string::npos);
  EXPECT_NE(csv.find("\"a\"\"b\""), std::string::npos);
  EXPECT_THROW(db.ExportCsv("robots; DROP TABLE robots"), InputError);
}

// A writer killed with SIGKILL in the middle of a transaction: the reopened file is
// consistent and holds every committed row, and none of the uncommitted ones.
TEST(Database, SurvivesSigkillMidTransaction) {
  testing::TempDir dir;
  const std::string path = dir.File("lab.db");
  {
    Database db(path);
    db.sql().exec("INSERT INTO robots(name, model_name, model_yaml) VALUES ('r','puma760','')");
    db.sql().exec("INSERT INTO sessions(robot_id) VALUES (1)");
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
      SQLite::Transaction tx(db.sql());
      for (int k = 0; k < 3; ++k) {
        db.sql().exec("INSERT INTO poses(session_id, seq, label, joints_json, status) VALUES (1, " +
                      std::to_string(3 * t + k) + ", 'p', '[0,0,0,0,0,0]', 'measured')");
      }
      tx.commit();
    }
    SQLite::Transaction open_tx(db.sql());
    for (int k = 0; k < 1000; ++k) {
      db.sql().exec("INSERT INTO poses(session_id, seq, label, joints_json, status) VALUES (1, " +
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
  EXPECT_EQ(db.sql().execAndGet("PRAGMA integrity_check").getString(), "ok");
  EXPECT_EQ(db.sql().execAndGet("SELECT count(*) FROM poses").getInt(), 150);
  EXPECT_EQ(db.sql().execAndGet("SELECT count(*) FROM poses WHERE label='uncommitted'").getInt(),
            0);
  EXPECT_EQ(db.sql().execAndGet("SELECT max(seq) FROM poses").getInt(), 149);
}

// Two writers at once: the busy timeout makes the second wait instead of failing.
TEST(Database, ConcurrentWritersWaitForEachOther) {
  testing::TempDir dir;
  const std::string path = dir.File("lab.db");
  { Database db(path); }
  auto writer = [&](int offset) {
    Database db(path);
    for (int i = 0; i < 100; ++i) {
      SQLite::Transaction tx(db.sql());
      db.sql().exec("INSERT INTO instruments(name, kind, protocol) VALUES ('i" +
                    std::to_string(offset + i) + "', 'theodolite', 'geocom')");
      tx.commit();
    }
  };
  std::thread a(writer, 0), b(writer, 1000);
  a.join();
  b.join();
  Database db(path);
  EXPECT_EQ(db.sql().execAndGet("SELECT count(*) FROM instruments").getInt(), 200);
}

// A command that only reads opens with kMustExist: a missing file is an input error
// naming it, and nothing is created; an existing database opens as usual.
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

}  // namespace armsig::db
