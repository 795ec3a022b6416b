// The store (db/store.h through db::Database) on both backends: every typed row written and
// read back exactly, concurrent capture processes, concurrent writers of one robot's
// versions, consistent snapshots, and what only a server has (the schema's own table,
// another application's tables, search_path, read-only connections, a migration raced by
// several processes).
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <regex>
#include <set>
#include <thread>

#include "core/error.h"
#include "db/database.h"
#include "db/postgres_connection.h"
#include "db/report_queries.h"
#include "db/schema.h"
#include "db/store.h"
#include "support/postgres_server.h"
#include "support/stores.h"
#include "test_support.h"

namespace armsig::db {
namespace {

using testing::TempDir;

class TypedStore : public ::testing::TestWithParam<Backend> {
 protected:
  std::string NewStore(const std::string& name = "store") {
    return testing::NewStore(GetParam(), dir_, name);
  }
  TempDir dir_;
};

ObservationRow Reading(std::optional<int64_t> pose, const std::string& station, double hz) {
  ObservationRow o;
  o.pose_id = pose;
  o.point = "target";
  o.station = station;
  o.reading = {hz, 1.5707963267948966 + hz / 7, 1};
  o.sigma_hz_rad = 1.5e-6;
  o.sigma_v_rad = 2.5e-6;
  return o;
}

// A controller's identity and kinematics (schema v14): with the session as it began, with the
// robot its first identity and its newest kinematics; the history of checksums in order.
TEST_P(TypedStore, TheControllersIdentityIsKeptWithTheSessionAndTheRobot) {
  Database db(NewStore());
  WriteTransaction tx(db);
  const int64_t robot = EnsureRobot(db, "ur10", "ur10", "model: text\n");
  EXPECT_FALSE(RobotControllerRecord(db, robot));
  const int64_t s1 = CreateSession(db, robot, "", "[]", SessionState::kRunning, "");
  const int64_t s2 = CreateSession(db, robot, "", "[]", SessionState::kRunning, "");
  const int64_t s3 = CreateSession(db, robot, "", "[]", SessionState::kRunning, "");
  EXPECT_FALSE(SessionController(db, s1));
  const ControllerRecord first{"UR10", "20183010001", "URSoftware 5.11.1.108318 (Nov 03 2021)",
                               "0a-0b", R"({"checksum":"0a-0b"})"};
  SetSessionController(db, s1, first);
  RecordRobotController(db, robot, first);
  ControllerRecord later = first;
  later.serial = "another";  // never replaces the robot's identity
  later.kinematics_checksum = "0c-0d";
  later.kinematics_json = R"({"checksum":"0c-0d"})";
  SetSessionController(db, s3, later);
  RecordRobotController(db, robot, later);
  EXPECT_EQ(SessionController(db, s1), first);
  EXPECT_FALSE(SessionController(db, s2));
  EXPECT_EQ(SessionController(db, s3), later);
  const auto kept = RobotControllerRecord(db, robot);
  ASSERT_TRUE(kept);
  EXPECT_EQ(kept->serial, "20183010001");
  EXPECT_EQ(kept->kinematics_checksum, "0c-0d");
  const auto history = KinematicsHistory(db, robot);
  ASSERT_EQ(history.size(), 2u);
  EXPECT_EQ(history[0].session, s1);
  EXPECT_EQ(history[1].checksum, "0c-0d");
  // A pose keeps the controller's time stamp of its joints.
  const int64_t pose = InsertPose(db, s1, 0, "c0", Eigen::VectorXd::Zero(6), "measured", 1, 1234.568);
  auto q = db.connection().Prepare("SELECT controller_time_s FROM poses WHERE id = ?");
  q->Bind(1, pose);
  ASSERT_TRUE(q->Step());
  EXPECT_EQ(q->Double(0), 1234.568);
  tx.commit();
}

// Whatever the typed writers store, the readers give back to the last bit, on both backends.
TEST_P(TypedStore, EveryTypedRowReadsBackExactly) {
  Database db(NewStore());
  WriteTransaction tx(db);
  const int64_t robot = EnsureRobot(db, "puma", "puma760", "model: text\n");
  EXPECT_EQ(EnsureRobot(db, "puma", "other", "other"), robot);  // found, not stored again
  const int64_t session = CreateSession(db, robot, "lab: yaml", "[1,2]", SessionState::kRunning, "note ü");
  SetSessionOwner(db, session, {4242, "cell7", "boot:123"});
  const Eigen::VectorXd joints =
      (Eigen::VectorXd(6) << 0.1, -1.0 / 3.0, 2.5e-9, 3.14159, -2.0, 1e-300).finished();
  const int64_t pose = InsertPose(db, session, 0, "c0", joints, "measured", 2);
  InsertPose(db, session, 1, "c1", std::nullopt, "skipped", 3);

  StationSetupRow setup;
  setup.station = "S1";
  setup.pose.levelled = true;
  setup.pose.azimuth_rad = 0.7853981633974483;
  setup.pose.position_mm = {1000.125, -2000.5, 300.0625};
  setup.sigma_position_mm = {0.01, 0.02, 0.03};
  setup.sigma_azimuth_rad = 1e-6;
  setup.sigma_hz_rad = 4.8e-6;
  setup.sigma0 = 1.04;
  setup.dof = 17;
  setup.method = "mutual+scale_bar";
  InsertStationSetup(db, session, setup);
  StationSetupRow tilted = setup;
  tilted.station = "LT1";
  tilted.pose.levelled = false;
  tilted.pose.world_from_station =
      Eigen::AngleAxisd(0.3, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
  tilted.sigma0.reset();
  InsertStationSetup(db, session, tilted);

  ObservationRow tracker = Reading(pose, "LT1", 0.25);
  tracker.distance_mm = 2750.125;
  tracker.sigma_distance_mm = 0.015;
  tracker.temperature_c = 20.37;
  tracker.pressure_hpa = 1012.8;
  tracker.humidity_percent = 44.1;
  tracker.return_code = 0;
  ObservationRow theodolite = Reading(pose, "S1", 1.0 / 3.0);
  theodolite.reading.face = 2;
  theodolite.return_code = 1284;
  InsertObservations(db, session, {theodolite, tracker});

  PointRow point;
  point.pose_id = pose;
  point.point = "target";
  point.position_mm = Eigen::Vector3d(1500.0000000001, -20.25, 1e-12);
  point.covariance_mm2 << 1e-4, 2e-6, 3e-7, 2e-6, 2e-4, 4e-7, 3e-7, 4e-7, 9e-4;
  point.rays = 3;
  point.rejected_rays = 1;
  point.sigma0 = 0.98;
  point.miss_mm = 0.0123;
  point.flags = "blunder_rejected";
  // A 6-DoF probe's orientation (schema v12), stored as three angles and read back as the
  // same rotation to rounding.
  point.orientation = MeasuredOrientation{
      Eigen::AngleAxisd(2.9, Eigen::Vector3d(-1, 3, 2).normalized()).toRotationMatrix(),
      Eigen::Vector3d(4.3e-5, 1.1e-4, 1.5e-4)};
  InsertPoint(db, session, point);
  tx.commit();

  const auto row = LoadSession(db, session);
  ASSERT_TRUE(row);
  EXPECT_EQ(row->robot, "puma");
  EXPECT_EQ(row->lab_yaml, "lab: yaml");
  EXPECT_EQ(row->plan_json, "[1,2]");
  EXPECT_EQ(row->state, SessionState::kRunning);
  EXPECT_EQ(row->note, "note ü");
  EXPECT_EQ(row->owner, (SessionOwner{4242, "cell7", "boot:123"}));
  EXPECT_EQ(StoredSeqs(db, session), (std::vector<int>{0, 1}));

  const auto setups = LatestStationSetups(db, session);
  ASSERT_EQ(setups.size(), 2u);
  EXPECT_EQ(setups.at("S1").pose.position_mm, setup.pose.position_mm);
  EXPECT_EQ(setups.at("S1").pose.azimuth_rad, setup.pose.azimuth_rad);
  EXPECT_EQ(setups.at("S1").sigma0, 1.04);
  EXPECT_EQ(setups.at("S1").sigma_hz_rad, 4.8e-6);
  EXPECT_FALSE(setups.at("S1").sigma_v_rad);
  EXPECT_EQ(setups.at("S1").dof, 17);
  EXPECT_EQ(setups.at("S1").method, "mutual+scale_bar");
  EXPECT_FALSE(setups.at("LT1").pose.levelled);
  EXPECT_EQ(setups.at("LT1").pose.world_from_station, tilted.pose.world_from_station);
  EXPECT_FALSE(setups.at("LT1").sigma0);

  const auto readings = LoadObservations(db, session);
  ASSERT_EQ(readings.size(), 2u);
  for (const auto& r : readings) {
    const ObservationRow& want = r.station == "LT1" ? tracker : theodolite;
    EXPECT_EQ(r.pose_id, pose);
    EXPECT_EQ(r.reading.hz_rad, want.reading.hz_rad);
    EXPECT_EQ(r.reading.v_rad, want.reading.v_rad);
    EXPECT_EQ(r.reading.face, want.reading.face);
    EXPECT_EQ(r.distance_mm, want.distance_mm);
    EXPECT_NEAR(*r.sigma_hz_rad, *want.sigma_hz_rad, 1e-20);  // stored in arcsec
    EXPECT_EQ(r.sigma_distance_mm, want.sigma_distance_mm);
    EXPECT_EQ(r.return_code, want.return_code);
    EXPECT_EQ(r.temperature_c, want.temperature_c);
    EXPECT_EQ(r.pressure_hpa, want.pressure_hpa);
    EXPECT_EQ(r.humidity_percent, want.humidity_percent);
  }

  const auto points = LoadPoints(db, session);
  ASSERT_EQ(points.size(), 1u);
  EXPECT_EQ(*points[0].position_mm, *point.position_mm);
  EXPECT_EQ(points[0].covariance_mm2, point.covariance_mm2);
  EXPECT_EQ(points[0].rejected_rays, 1);
  EXPECT_EQ(points[0].miss_mm, 0.0123);
  EXPECT_EQ(points[0].flags, "blunder_rejected");
  auto same_orientation = [&](const std::optional<MeasuredOrientation>& o) {
    ASSERT_TRUE(o && o->sigma_rad);
    EXPECT_LT((o->world_from_target - point.orientation->world_from_target).norm(), 1e-14);
    EXPECT_EQ(*o->sigma_rad, *point.orientation->sigma_rad);
  };
  same_orientation(points[0].orientation);

  const auto poses = LoadRobotPoses(db, robot, "");
  ASSERT_EQ(poses.size(), 1u);  // the skipped configuration has no point
  EXPECT_EQ(poses[0].id, std::to_string(session) + ":c0");
  EXPECT_EQ(poses[0].frame, session);
  EXPECT_EQ(poses[0].joints_rad, joints);
  EXPECT_EQ(poses[0].target_in_world, *point.position_mm);
  same_orientation(poses[0].orientation);
  EXPECT_TRUE(LoadRobotPoses(db, robot, "9999-01-01T00:00:00.000Z").empty());
  std::vector<Eigen::Matrix3d> covariances;
  const auto session_poses = LoadSessionPoses(db, session, &covariances);
  ASSERT_EQ(session_poses.size(), 1u);
  same_orientation(session_poses[0].orientation);
  EXPECT_EQ(covariances.at(0), point.covariance_mm2);

  const auto temperatures = PoseTemperatures(db, {session});
  ASSERT_EQ(temperatures.size(), 1u);
  EXPECT_EQ(temperatures.begin()->second, 20.37);

  const auto summaries = ListSessions(db, robot);
  ASSERT_EQ(summaries.size(), 1u);
  EXPECT_EQ(summaries[0].measured, 1);
  EXPECT_EQ(summaries[0].skipped, 1);
  EXPECT_EQ(summaries[0].usable, 1);
  EXPECT_EQ(summaries[0].flagged, 1);
  EXPECT_EQ(ListSessions(db, std::nullopt).size(), 1u);
  EXPECT_TRUE(ListSessions(db, robot + 1000).empty());
  ASSERT_TRUE(LatestLabYaml(db, robot).has_value());
  EXPECT_EQ(LatestLabYaml(db, robot)->lab_yaml, "lab: yaml");
  {
    WriteTransaction finish(db);
    SetSessionState(db, session, SessionState::kCompleted);
    finish.commit();
  }
  EXPECT_FALSE(ListSessions(db, robot)[0].finished_at.empty());
}

// A stored orientation is all three angles or none: one left (an edited store) is refused
// naming the store, table, row and column instead of being read as a rotation.
TEST_P(TypedStore, APartlyStoredOrientationIsRefusedNamingTheCell) {
  Database db(NewStore());
  int64_t session = 0;
  {
    WriteTransaction tx(db);
    const int64_t robot = EnsureRobot(db, "ur", "ur10", "model: text\n");
    session = CreateSession(db, robot, "", "", SessionState::kCompleted, "");
    const int64_t pose =
        InsertPose(db, session, 0, "p", Eigen::VectorXd::Zero(6), "measured", 1);
    PointRow point;
    point.pose_id = pose;
    point.point = "target";
    point.position_mm = Eigen::Vector3d(1, 2, 3);
    point.orientation = MeasuredOrientation{Eigen::Matrix3d::Identity(), std::nullopt};
    InsertPoint(db, session, point);
    tx.commit();
  }
  ASSERT_TRUE(LoadSessionPoses(db, session).at(0).orientation);
  {
    WriteTransaction tx(db);
    db.connection().Prepare("UPDATE points SET ry_rad = NULL")->Execute();
    tx.commit();
  }
  try {
    LoadSessionPoses(db, session);
    ADD_FAILURE() << "a partly stored orientation was read";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("table points"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("rx_rad"), std::string::npos) << e.what();
  }
}

// A parameter set: parameters in their stored order, sigmas NaN where not known, the
// measuring frame and covariance exact; activation history in order.
TEST_P(TypedStore, ParameterSetsAndTheirActivationsReadBackExactly) {
  Database db(NewStore());
  const int64_t robot = EnsureRobot(db, "puma", "puma760", "x");
  CalibrationRecord record;
  record.robot_id = robot;
  record.params_spec = "all";
  record.inputs_json = R"({"sessions":[1]})";
  record.options_json = "{}";
  record.rank = 29;
  record.poses_fit = 80;
  record.validation_mean_mm = 0.0137;
  record.active = true;
  record.world_from_base.translation() << 1500.5, -20.25, 300;
  record.world_from_base.linear() = Eigen::AngleAxisd(0.25, Eigen::Vector3d::UnitZ()).matrix();
  record.parameters = {{"gamma1", "rad", 1e-5, 2e-7, true},
                       {"a1", "mm", 0.5, NAN, false},
                       {"beta2", "rad", -3e-4, 1e-6, true}};
  record.residuals = {{"c0", "fit", Eigen::Vector3d(0.01, -0.02, 0.005), 5.25}};
  const auto [id1, v1] = InsertCalibration(db, record);
  const auto [id2, v2] = InsertCalibration(db, record);
  EXPECT_EQ(v1, 1);
  EXPECT_EQ(v2, 2);
  RecordActivation(db, robot, {2, 1, "", "recalibrate", "nightly"});
  ASSERT_TRUE(SetActiveVersion(db, robot, 1));
  EXPECT_FALSE(SetActiveVersion(db, robot, 7));
  RecordActivation(db, robot, {1, 2, "", "activate", "roll back"});

  const auto active = ActiveCalibration(db, robot);
  ASSERT_TRUE(active);
  EXPECT_EQ(active->version, 1);
  ASSERT_EQ(active->parameters.size(), 3u);
  for (size_t k = 0; k < 3; ++k) {
    EXPECT_EQ(active->parameters[k].name, record.parameters[k].name);
    EXPECT_EQ(active->parameters[k].value, record.parameters[k].value);
    EXPECT_EQ(active->parameters[k].identified, record.parameters[k].identified);
  }
  EXPECT_TRUE(std::isnan(active->parameters[1].sigma));
  EXPECT_EQ(active->world_from_base->matrix(), record.world_from_base.matrix());
  EXPECT_EQ(active->validation_mean_mm, 0.0137);
  EXPECT_EQ(CalibrationHistory(db, robot).size(), 2u);
  const auto history = ActivationHistory(db, robot);
  ASSERT_EQ(history.size(), 2u);
  EXPECT_EQ(history[1].version, 1);
  EXPECT_EQ(history[1].previous_version, 2);
  EXPECT_EQ(history[1].activated_by, "activate");
  EXPECT_EQ(db.connection().QueryInt("SELECT count(*) FROM calibrations WHERE active = 1"), 1);
  const auto robots = ListRobots(db);
  ASSERT_EQ(robots.size(), 1u);
  EXPECT_EQ(robots[0].active_version, 1);
}

// Time stamps are the same ISO 8601 UTC text on both backends, written by the store's clock.
TEST_P(TypedStore, TimeStampsAreIsoUtcWithMilliseconds) {
  Database db(NewStore());
  const int64_t robot = EnsureRobot(db, "puma", "puma760", "x");
  const int64_t session = CreateSession(db, robot, "", "", SessionState::kCompleted, "");
  const auto s = ListSessions(db, robot).at(0);
  const std::regex iso(R"(\d{4}-\d\d-\d\dT\d\d:\d\d:\d\d\.\d{3}Z)");
  EXPECT_TRUE(std::regex_match(s.started_at, iso)) << s.started_at;
  EXPECT_TRUE(std::regex_match(s.finished_at, iso)) << s.finished_at;  // created completed
  const auto now = std::chrono::system_clock::now();
  const std::time_t t = std::chrono::system_clock::to_time_t(now);
  char today[16];
  std::strftime(today, sizeof today, "%Y-%m-%d", std::gmtime(&t));
  EXPECT_EQ(s.started_at.substr(0, 10), today);
  EXPECT_TRUE(SessionExists(db, session));
}

// Eight capture processes at once (each its own connection, as on eight machines), each
// configuration one transaction naming stations none of them made yet: every row once, the
// stations once.
TEST_P(TypedStore, EightCaptureProcessesStoreEveryRowOnce) {
  const std::string store = NewStore();
  constexpr int kWriters = 8, kConfigurations = 40;
  std::vector<int64_t> sessions;
  {
    Database db(store);
    WriteTransaction tx(db);
    const int64_t robot = EnsureRobot(db, "puma", "puma760", "x");
    for (int w = 0; w < kWriters; ++w)
      sessions.push_back(CreateSession(db, robot, "", "", SessionState::kRunning, "writer"));
    tx.commit();
  }
  std::vector<pid_t> children;
  for (int w = 0; w < kWriters; ++w) {
    const pid_t child = ::fork();
    ASSERT_GE(child, 0);
    if (child == 0) {
      int code = 0;
      try {
        Database db(store, OpenMode::kMustExist);
        for (int i = 0; i < kConfigurations; ++i) {
          WriteTransaction tx(db);
          const int64_t pose = InsertPose(db, sessions[w], i, "c" + std::to_string(i),
                                          Eigen::VectorXd::Constant(6, 0.01 * i), "measured", 1);
          InsertObservations(db, sessions[w],
                             {Reading(pose, "S1", 0.1), Reading(pose, "S2", 0.2),
                              Reading(pose, "S3", 0.3)});
          PointRow p;
          p.pose_id = pose;
          p.point = "target";
          p.position_mm = Eigen::Vector3d(w, i, 0);
          p.rays = 3;
          InsertPoint(db, sessions[w], p);
          tx.commit();
        }
      } catch (const std::exception& e) {
        std::fprintf(stderr, "writer %d: %s\n", w, e.what());
        code = 1;
      }
      ::_exit(code);
    }
    children.push_back(child);
  }
  for (pid_t child : children) {
    int status = 0;
    ::waitpid(child, &status, 0);
    EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0);
  }
  Database db(store, OpenMode::kReadOnly);
  auto& c = db.connection();
  EXPECT_EQ(c.QueryInt("SELECT count(*) FROM poses"), kWriters * kConfigurations);
  EXPECT_EQ(c.QueryInt("SELECT count(*) FROM (SELECT DISTINCT session_id, seq FROM poses) d"),
            kWriters * kConfigurations);
  EXPECT_EQ(c.QueryInt("SELECT count(*) FROM observations"), 3 * kWriters * kConfigurations);
  EXPECT_EQ(c.QueryInt("SELECT count(*) FROM points"), kWriters * kConfigurations);
  EXPECT_EQ(c.QueryInt("SELECT count(*) FROM stations"), 3);
  EXPECT_EQ(c.QueryInt("SELECT count(*) FROM points pt JOIN poses p ON p.id = pt.pose_id "
                       "WHERE pt.session_id <> p.session_id"),
            0);
}

// Writers of one robot's parameter sets at once (the nightly job and a push, say): the
// versions are 1…N without a gap or a clash, and one set is active.
TEST_P(TypedStore, ConcurrentWritersOfOneRobotsSetsGetDistinctVersions) {
  const std::string store = NewStore();
  int64_t robot = 0;
  {
    Database db(store);
    robot = EnsureRobot(db, "puma", "puma760", "x");
  }
  constexpr int kThreads = 4, kSets = 8;
  std::atomic<int> failures{0};
  std::vector<std::thread> pool;
  for (int t = 0; t < kThreads; ++t) {
    pool.emplace_back([&] {
      try {
        Database db(store, OpenMode::kMustExist);
        CalibrationRecord record;
        record.robot_id = robot;
        record.params_spec = "all";
        record.inputs_json = record.options_json = "{}";
        record.active = true;
        record.parameters = {{"a1", "mm", 0.5, 0.01, true}};
        for (int k = 0; k < kSets; ++k) {
          WriteTransaction tx(db);
          InsertCalibration(db, record);
          tx.commit();
        }
      } catch (const std::exception& e) {
        ADD_FAILURE() << e.what();
        ++failures;
      }
    });
  }
  for (auto& t : pool) t.join();
  EXPECT_EQ(failures, 0);
  Database db(store, OpenMode::kReadOnly);
  const auto history = CalibrationHistory(db, robot);
  ASSERT_EQ(history.size(), static_cast<size_t>(kThreads * kSets));
  for (size_t k = 0; k < history.size(); ++k) EXPECT_EQ(history[k].version, int(k) + 1);
  EXPECT_EQ(db.connection().QueryInt("SELECT count(*) FROM calibrations WHERE active = 1"), 1);
}

// A report reads one snapshot: rows a capture commits meanwhile are not half seen.
TEST_P(TypedStore, ASnapshotDoesNotSeeWhatIsCommittedWhileItReads) {
  const std::string store = NewStore();
  Database reader(store), writer(store, OpenMode::kMustExist);
  const int64_t robot = EnsureRobot(writer, "puma", "puma760", "x");
  const int64_t session = CreateSession(writer, robot, "", "", SessionState::kRunning, "");
  InsertPose(writer, session, 0, "c0", Eigen::VectorXd::Zero(6), "measured", 1);
  {
    ReadSnapshot snapshot(reader);
    EXPECT_EQ(StoredSeqs(reader, session).size(), 1u);
    WriteTransaction tx(writer);
    InsertPose(writer, session, 1, "c1", Eigen::VectorXd::Zero(6), "measured", 1);
    tx.commit();
    EXPECT_EQ(StoredSeqs(reader, session).size(), 1u);  // the same snapshot
    snapshot.commit();
  }
  EXPECT_EQ(StoredSeqs(reader, session).size(), 2u);
}

// A command that only reads cannot write by mistake, on either backend.
TEST_P(TypedStore, AReadOnlyStoreRefusesWrites) {
  const std::string store = NewStore();
  { Database create(store); }
  Database db(store, OpenMode::kReadOnly);
  EXPECT_TRUE(db.read_only());
  EXPECT_THROW(EnsureRobot(db, "puma", "puma760", "x"), DatabaseError);
  Database check(store, OpenMode::kMustExist);
  EXPECT_TRUE(ListRobots(check).empty());
}

ARMSIG_BOTH_BACKENDS(TypedStore);

// ---- What only a server store has. ---------------------------------------------------

std::string NewServerDatabase(const std::string& name, std::string* database = nullptr) {
  return testing::PostgresServer::Shared().NewDatabase(name, database);
}

// A database without an armsig store is refused by the commands that use what is there,
// and nothing is created in it.
TEST(ServerStore, MustExistAndReadOnlyRefuseADatabaseWithoutAStore) {
  const std::string uri = NewServerDatabase("empty");
  for (OpenMode mode : {OpenMode::kMustExist, OpenMode::kReadOnly}) {
    try {
      Database db(uri, mode);
      ADD_FAILURE() << "opened a database without a store";
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find("no armsig store in this database"), std::string::npos)
          << e.what();
      EXPECT_NE(std::string(e.what()).find("db init"), std::string::npos) << e.what();
    }
  }
  PostgresConnection c(uri);
  EXPECT_EQ(c.QueryInt("SELECT count(*) FROM information_schema.tables WHERE table_schema = "
                       "current_schema()"),
            0);
}

// Another application's table of one of armsig's names: refused, nothing created.
TEST(ServerStore, TablesOfArmsigsNamesItDidNotMakeAreRefusedUntouched) {
  std::string name;
  const std::string uri = NewServerDatabase("foreign", &name);
  testing::PostgresServer::Shared().Psql(name, "CREATE TABLE robots (serial TEXT)");
  try {
    Database db(uri);
    ADD_FAILURE() << "made a store beside another application's tables";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("armsig did not make (robots)"), std::string::npos)
        << e.what();
  }
  PostgresConnection c(uri);
  EXPECT_EQ(c.QueryInt("SELECT count(*) FROM information_schema.tables WHERE table_schema = "
                       "current_schema()"),
            1);
}

// Several processes opening one new store at once: one migrates, the others find it made.
TEST(ServerStore, ProcessesCreatingOneStoreAtOnceMigrateItOnce) {
  const std::string uri = NewServerDatabase("race");
  std::vector<pid_t> children;
  for (int k = 0; k < 6; ++k) {
    const pid_t child = ::fork();
    ASSERT_GE(child, 0);
    if (child == 0) {
      int code = 0;
      try {
        Database db(uri);
        code = db.SchemaVersion() == LatestSchemaVersion() ? 0 : 2;
      } catch (const std::exception& e) {
        std::fprintf(stderr, "opener: %s\n", e.what());
        code = 1;
      }
      ::_exit(code);
    }
    children.push_back(child);
  }
  for (pid_t child : children) {
    int status = 0;
    ::waitpid(child, &status, 0);
    EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0);
  }
  PostgresConnection c(uri);
  EXPECT_EQ(c.QueryInt("SELECT count(*) FROM armsig_schema"), 1);
  EXPECT_EQ(c.QueryInt("SELECT version FROM armsig_schema"), LatestSchemaVersion());
}

// search_path in the URI puts a store in a schema of its own: two stores in one database.
TEST(ServerStore, SearchPathInTheUriKeepsStoresApart) {
  std::string name;
  const std::string uri = NewServerDatabase("schemas", &name);
  const std::string cell_a = uri + "&options=-csearch_path%3Dcell_a";
  try {
    Database db(cell_a);
    ADD_FAILURE() << "a store without a schema to keep it in";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("no current schema"), std::string::npos) << e.what();
  }
  testing::PostgresServer::Shared().Psql(name, "CREATE SCHEMA cell_a; CREATE SCHEMA cell_b");
  {
    Database a(cell_a);
    EnsureRobot(a, "puma", "puma760", "x");
    Database b(uri + "&options=-csearch_path%3Dcell_b");
    EXPECT_TRUE(ListRobots(b).empty());
    EXPECT_EQ(ListRobots(a).size(), 1u);
  }
  PostgresConnection c(uri);
  EXPECT_EQ(c.QueryInt("SELECT count(*) FROM information_schema.tables WHERE table_schema = "
                       "'public'"),
            0);
}

// The translated DDL: every table of the schema has the same columns on both backends,
// and no floating column of PostgreSQL's is single precision.
TEST(ServerStore, TheSchemaHasTheSameColumnsOnBothBackends) {
  TempDir dir;
  Database file(dir.File("lab.db"));
  Database server(NewServerDatabase("columns"));
  for (std::string_view table : TableNames()) {
    const std::string t(table);
    auto columns = [&](Database& db) {
      auto q = db.connection().Prepare("SELECT * FROM " + t + " LIMIT 0");
      q->Step();
      std::vector<std::string> out;
      for (int k = 0; k < q->Columns(); ++k) out.push_back(q->ColumnName(k));
      return out;
    };
    EXPECT_EQ(columns(server), columns(file)) << t;
  }
  // Every REAL of SQLite's is a double on the server, none single precision.
  int64_t reals = 0;
  for (std::string_view table : TableNames()) {
    reals += file.connection().QueryInt("SELECT count(*) FROM pragma_table_info('" +
                                        std::string(table) + "') WHERE type = 'REAL'");
  }
  EXPECT_GT(reals, 40);
  EXPECT_EQ(server.connection().QueryInt(
                "SELECT count(*) FROM information_schema.columns WHERE table_schema = "
                "current_schema() AND data_type = 'double precision'"),
            reals);
  EXPECT_EQ(server.connection().QueryInt(
                "SELECT count(*) FROM information_schema.columns WHERE table_schema = "
                "current_schema() AND data_type = 'real'"),
            0);
}

TEST(PostgresDdl, TranslatesTypesKeysAndTheClockButNotTextOrComments) {
  EXPECT_EQ(PostgresDdl("CREATE TABLE t (\n  id INTEGER PRIMARY KEY,\n  x REAL NOT NULL, -- a "
                        "REAL one\n  n INTEGER, s TEXT DEFAULT 'REAL INTEGER',\n  at TEXT NOT "
                        "NULL DEFAULT (strftime('%Y-%m-%dT%H:%M:%fZ','now'))\n);"),
            "CREATE TABLE t (\n  id BIGINT GENERATED BY DEFAULT AS IDENTITY PRIMARY KEY,\n  x "
            "DOUBLE PRECISION NOT NULL, -- a REAL one\n  n BIGINT, s TEXT DEFAULT 'REAL "
            "INTEGER',\n  at TEXT NOT NULL DEFAULT (to_char(now() AT TIME ZONE 'UTC', "
            "'YYYY-MM-DD\"T\"HH24:MI:SS.MS\"Z\"'))\n);");
}

}  // namespace
}  // namespace armsig::db
