// Observations files into sessions and stored sessions reduced (workflows/reduce).
#include "workflows/reduce.h"

#include <gtest/gtest.h>

#include <atomic>
#include <cmath>
#include <thread>

#include "calibration/synthetic.h"
#include "core/error.h"
#include "db/store.h"
#include "io/csv.h"
#include "support/simulated_sessions.h"
#include "support/stores.h"
#include "test_support.h"

namespace armsig::workflows {
namespace {

using testing::DataPath;
using testing::TempDir;
using testing::WriteText;

// GNU Gama's barta network, imported as a session and reduced twice: the same 18 points
// (a rerun replaces them), point 25 where gama-local put it.
TEST(ReduceSessions, ImportedRealNetworkReducesIdempotentlyToGnuGama) {
  TempDir dir;
  db::Database database(dir.File("lab.db"));
  ImportObservationsOptions o;
  o.file = DataPath("networks/barta-phase_1-2TK/observations.csv");
  o.stations = DataPath("networks/barta-phase_1-2TK/stations.yaml");
  const auto imported = ImportObservations(database, o);
  EXPECT_EQ(imported.observations, 52u);
  for (int run = 0; run < 2; ++run) {
    const auto summaries = ReduceSessions(database, 0, /*reject_blunders=*/false);
    ASSERT_EQ(summaries.size(), 1u);
    EXPECT_EQ(summaries[0].reduced, 18);
    EXPECT_EQ(summaries[0].failed, 0);
  }
  EXPECT_EQ(database.sql().execAndGet("SELECT count(*) FROM points").getInt(), 18);  // not 36
  const auto points = db::LoadPoints(database, imported.session);
  const auto expected = io::ReadCsvFile(DataPath("networks/barta-phase_1-2TK/expected.csv"));
  int compared = 0;
  for (const auto& row : expected.rows()) {
    for (const auto& p : points) {
      if (p.point != expected.Text(row, 0) || !p.position_mm) continue;
      const Eigen::Vector3d published(expected.Number(row, 1), expected.Number(row, 2),
                                      expected.Number(row, 3));
      EXPECT_LT((*p.position_mm - published).norm(), 5e-4) << p.point;
      ++compared;
    }
  }
  EXPECT_GE(compared, 10);
  EXPECT_NE(FormatReduceSummaries(ReduceSessions(database, imported.session, true), database.path())
                .find("18 points reduced"),
            std::string::npos);
}

// A session of measured points without readings (poses imported from a laser tracker's
// export) has nothing to reduce: `armsig reduce` keeps its points. Before, it replaced them
// with none, and the robot then had "0 measured configurations".
TEST(ReduceSessions, ASessionOfImportedPointsKeepsThem) {
  TempDir dir;
  db::Database database(dir.File("lab.db"));
  testing::AddSession(database, calibration::PaperTable3Parameters(), 30, 5);
  ImportObservationsOptions o;
  o.file = DataPath("networks/barta-phase_1-2TK/observations.csv");
  o.stations = DataPath("networks/barta-phase_1-2TK/stations.yaml");
  ImportObservations(database, o);
  const auto summaries = ReduceSessions(database, 0, /*reject_blunders=*/false);
  ASSERT_EQ(summaries.size(), 2u);
  EXPECT_EQ(summaries[0].observations, 0);
  EXPECT_EQ(summaries[0].kept_points, 30u);
  EXPECT_EQ(summaries[1].reduced, 18);
  EXPECT_EQ(db::LoadSessionPoses(database, 1).size(), 30u);
  EXPECT_NE(FormatReduceSummaries(summaries, "lab.db")
                .find("session 1: no observations to reduce; its 30 measured points are kept"),
            std::string::npos);
}

TEST(ReduceSessions, UnknownSessionIsAnInputErrorWithAWorkingHint) {
  TempDir dir;
  db::Database database(dir.File("lab.db"));
  try {
    ReduceSessions(database, 4, true);
    FAIL();
  } catch (const InputError& e) {
    EXPECT_NE(e.message().find("no session 4"), std::string::npos);
    EXPECT_NE(e.message().find("armsig --db " + database.path() + " sessions"), std::string::npos)
        << e.what();
  }
}

TEST(ImportObservations, UnknownStationIsRefusedAndNothingIsStored) {
  TempDir dir;
  WriteText(dir.File("obs.csv"), "point,station,hz_gon,v_gon\nP,1,10,100\nP,X,20,100\n");
  db::Database database(dir.File("lab.db"));
  ImportObservationsOptions o;
  o.file = dir.File("obs.csv");
  o.stations = DataPath("networks/k06/stations.yaml");
  try {
    ImportObservations(database, o);
    FAIL();
  } catch (const InputError& e) {
    EXPECT_EQ(e.where().line, 3) << e.what();
  }
  EXPECT_EQ(database.sql().execAndGet("SELECT count(*) FROM sessions").getInt(), 0);
}

// A reduction of a session while a capture of it goes on (the plant's server; a cell's file):
// every configuration the capture committed keeps exactly one point whatever the moment,
// none lost to a reduction that read the observations before the configuration came.
class ReduceWhileCapturing : public ::testing::TestWithParam<db::Backend> {};

TEST_P(ReduceWhileCapturing, NoConfigurationLosesItsPoint) {
  TempDir dir;
  const std::string store = testing::NewStore(GetParam(), dir, "lab");
  const Eigen::Vector3d stations[3] = {{0, 0, 1500}, {4000, 0, 1500}, {2000, 4000, 1500}};
  const char* codes[3] = {"S1", "S2", "S3"};
  int64_t session = 0;
  {
    db::Database db(store);
    db::WriteTransaction tx(db);
    const int64_t robot = db::EnsureRobot(db, "puma", "puma760", "x");
    session = db::CreateSession(db, robot, "", "", db::SessionState::kRunning, "capture");
    for (int s = 0; s < 3; ++s) {
      db::StationSetupRow setup;
      setup.station = codes[s];
      setup.pose.position_mm = stations[s];  // levelled, azimuth 0: world = instrument axes
      setup.sigma_hz_rad = setup.sigma_v_rad = 5e-6;
      setup.method = "file";
      db::InsertStationSetup(db, session, setup);
    }
    tx.commit();
  }
  // The capture: a configuration per transaction, its three readings and its point.
  constexpr int kConfigurations = 150;
  std::atomic<bool> done{false};
  std::atomic<int> reductions{0};
  std::string failure;
  std::thread capture([&] {
    try {
      db::Database db(store, db::OpenMode::kMustExist);
      for (int i = 0; i < kConfigurations; ++i) {
        const Eigen::Vector3d target(1500 + 3.0 * i, 1200 - 2.0 * i, 800 + i);
        db::WriteTransaction tx(db);
        const int64_t pose = db::InsertPose(db, session, i, "c" + std::to_string(i),
                                            Eigen::VectorXd::Zero(6), "measured", 1);
        std::vector<db::ObservationRow> readings;
        for (int s = 0; s < 3; ++s) {
          const Eigen::Vector3d d = target - stations[s];
          db::ObservationRow o;
          o.pose_id = pose;
          o.point = "target";
          o.station = codes[s];
          o.reading = {std::atan2(d.x(), d.y()), std::acos(d.z() / d.norm()), 1};
          readings.push_back(o);
        }
        db::InsertObservations(db, session, readings);
        db::PointRow p;
        p.pose_id = pose;
        p.point = "target";
        p.position_mm = target;
        p.rays = 3;
        db::InsertPoint(db, session, p);
        tx.commit();
        // A pause now and then, for the reduction to get in between (SQLite's waiting
        // writer polls; on the server it waits on the lock itself, and fewer pauses keep
        // the race close: without the session lock it loses a point most runs).
        if (GetParam() == db::Backend::kSqlite || i % 5 == 4)
          std::this_thread::sleep_for(std::chrono::milliseconds(1));
        // Every fiftieth configuration waits for a reduction that began after it, so that
        // reductions interleave with the capture however fast either runs on the machine.
        if (i % 50 == 49) {
          const int seen = reductions.load();
          const auto give_up = std::chrono::steady_clock::now() + std::chrono::seconds(60);
          while (reductions.load() < seen + 2 && std::chrono::steady_clock::now() < give_up)
            std::this_thread::sleep_for(std::chrono::milliseconds(1));
        }
      }
    } catch (const std::exception& e) {
      failure = e.what();
    }
    done = true;
  });
  {
    db::Database db(store, db::OpenMode::kMustExist);
    while (!done) {
      ReduceSession(db, session, reduction::PointOptions{});
      ++reductions;
      // SQLite's busy handler is not fair: a writer that retakes the lock at once can keep
      // another waiting past its timeout. A reduction is not run in a loop in a lab.
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
    }
  }
  capture.join();
  EXPECT_EQ(failure, "");
  db::Database db(store, db::OpenMode::kMustExist);
  auto& c = db.connection();
  EXPECT_GE(reductions.load(), 6);
  EXPECT_EQ(c.QueryInt("SELECT count(*) FROM points"), kConfigurations);
  EXPECT_EQ(c.QueryInt("SELECT count(*) FROM poses p WHERE (SELECT count(*) FROM points t "
                       "WHERE t.pose_id = p.id) <> 1"),
            0);
  // The reduced points are where the readings meet (the capture's own point, or the
  // reduction's: both the target).
  for (const auto& p : db::LoadPoints(db, session)) {
    ASSERT_TRUE(p.position_mm) << p.point;
  }
}

ARMSIG_BOTH_BACKENDS(ReduceWhileCapturing);

}  // namespace
}  // namespace armsig::workflows
