// `demo --robot ur10 --on-the-move` (issue 40): the virtual UR10 sweeps well-spread waypoints
// without stopping while the virtual tracker measures continuously on its own clock, planted
// off the controller's by an offset and a drift; the clock estimated from the data, the paired
// points calibrated and validated on held-out stretches of the sweep, against the stop-and-go
// demo of the same robot.
#include <gtest/gtest.h>

#include <cmath>

#include "db/database.h"
#include "demo/demo.h"
#include "test_support.h"

namespace armsig::demo {
namespace {

TEST(DemoOnTheMove, AThousandConfigurationsInMinutesOfRobotTimeWithTheClockFromTheData) {
  testing::TempDir dir;
  // The stop-and-go demo of the same robot: its validation mean is the yardstick.
  DemoOptions still;
  still.db_path = dir.File("still.db");
  still.robot = "ur10";
  still.configurations = 100;
  still.select = 60;
  still.time_scale = 0.01;
  const DemoResult standing = RunDemo(still, {});
  ASSERT_TRUE(standing.completed);
  const double stop_and_go = standing.json["stages"][1]["validation"]["mean_mm"];

  DemoOptions o;
  o.db_path = dir.File("move.db");
  o.robot = "ur10";
  o.on_the_move = true;
  o.waypoints = 40;
  o.time_scale = 0.05;  // RTDE keeps up from 0.05 on
  o.clock_offset_ms = 87.5;
  o.clock_drift_ppm = 12.0;
  std::string narrative;
  DemoObserver observer;
  observer.say = [&](const std::string& text) { narrative += text; };
  const DemoResult r = RunDemo(o, observer);
  ASSERT_TRUE(r.completed) << narrative;
  const auto& j = r.json;
  const int poses = j["session"]["poses"];
  const double robot_time_s = j["robot_time_s"];
  EXPECT_GE(poses, 1000) << narrative;
  EXPECT_LE(robot_time_s, 600.0) << narrative;
  EXPECT_NEAR(j["sync"]["offset_ms"].get<double>(), 87.5, 0.1) << narrative;
  EXPECT_NEAR(j["sync"]["drift_ppm"].get<double>(), 12.0, 5.0) << narrative;
  EXPECT_GT(j["sync"]["sigma_ms"].get<double>(), 0.0);
  EXPECT_LT(j["sync"]["sigma_ms"].get<double>(), 0.05);
  const double on_the_move = j["stages"][1]["validation"]["mean_mm"];
  EXPECT_LE(on_the_move, 1.3 * stop_and_go) << "stop-and-go " << stop_and_go << " mm\n"
                                             << narrative;
  // The streams are stored; every paired point is a configuration with its clock share.
  db::Database db(o.db_path);
  EXPECT_GT(db.sql().execAndGet("SELECT count(*) FROM stream_joints").getInt(), poses);
  EXPECT_EQ(db.sql().execAndGet("SELECT count(*) FROM points WHERE sync_sigma_mm IS NOT NULL").getInt(),
            poses);
  EXPECT_NE(narrative.find("clock estimated from the data"), std::string::npos) << narrative;
}

TEST(DemoOnTheMove, NeedsAControllerThatStreamsItsJoints) {
  testing::TempDir dir;
  DemoOptions o;
  o.db_path = dir.File("x.db");
  o.robot = "puma";
  o.on_the_move = true;
  EXPECT_THROW(RunDemo(o, {}), InputError);
  o.robot = "ur10";
  o.time_scale = 0.01;  // the joint stream could not keep up: refused, nothing made
  EXPECT_THROW(RunDemo(o, {}), InputError);
}

}  // namespace
}  // namespace armsig::demo
