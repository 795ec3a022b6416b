// `demo --robot ur10 --on-the-move` (issue 40): the virtual UR10 sweeps well-spread waypoints
// without stopping while the virtual tracker measures continuously on its own clock, planted
// off the controller's by an offset and a drift; the clock estimated from the data, the paired
// points calibrated and validated on held-out stretches of the sweep, against the stop-and-go
// demo of the same robot.
#include <gtest/gtest.h>

#include <cmath>
#include <string>

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
  // ISO 9283 path accuracy on the standard's line and rectangle, movel on the controller's
  // own kinematics, before and after compensation by the set just fitted.
  ASSERT_TRUE(j.contains("iso9283_path")) << narrative;
  const auto& path = j["iso9283_path"];
  for (const char* name : {"line", "rectangle"}) {
    const double before = path[name]["original"]["AT_mm"], after = path[name]["compensated"]["AT_mm"];
    // The controller's factory kinematics miss the path: about 0.1 mm on the line here (0.091 in
    // one suite run, where a bound of 0.1 failed: the frame is the signature fitted on that
    // run's swept stream), several times the tracker's noise in a path's mean; compensation
    // halves it at least.
    EXPECT_GT(before, 0.05) << name << ": " << before << " → " << after << " mm";
    EXPECT_LT(after, 0.5 * before) << name << ": " << before << " → " << after << " mm";
    EXPECT_LT(after, 0.1) << name;
    EXPECT_LT(std::abs(path[name]["compensated"]["AV_percent"].get<double>()), 1.0) << name;
  }
  EXPECT_LT(path["rectangle"]["compensated"]["CR_mm"].get<double>(),
            0.5 * path["rectangle"]["original"]["CR_mm"].get<double>());
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
