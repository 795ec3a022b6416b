// The robot's joint log: ids and times beside the joints, each joint in the unit its column
// names (against the conversions written out here), named columns in a given unit, and the
// logs that cannot be joined refused at their line.
#include "io/joint_log.h"

#include <fmt/format.h>
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <string>

#include "core/error.h"
#include "test_support.h"

namespace armsig::io {
namespace {

constexpr double kPi = std::numbers::pi;

// The log's text in a file of its own; the error's text, or "(accepted)".
std::string JointLogRefusal(const std::string& text, const JointLogOptions& options = {}) {
  testing::TempDir dir;
  testing::WriteText(dir.File("log.csv"), text);
  try {
    ReadJointLog(dir.File("log.csv"), options);
  } catch (const InputError& e) {
    return e.what();
  }
  return "(accepted)";
}

}  // namespace

// Three joints in three units and two kinds of time stamp: every angle in radians, the
// ids and times kept per row, the rows in file order with their lines.
TEST(JointLog, ReadsIdsTimesAndEachJointInItsColumnsUnit) {
  testing::TempDir dir;
  testing::WriteText(dir.File("log.csv"),
                     "pose;time;q1_deg;q2_gon;q3_rad\n"
                     "A;2024-03-05T09:15:30.5Z;90;100;0,25\n"
                     ";1234,5;-45;-50;-1\n");
  const JointLog log = ReadJointLog(dir.File("log.csv"));
  EXPECT_TRUE(log.has_ids);
  EXPECT_TRUE(log.has_times);
  ASSERT_EQ(log.rows.size(), 2u);
  EXPECT_EQ(log.rows[0].line, 2);
  EXPECT_EQ(log.rows[0].id, "A");
  ASSERT_TRUE(log.rows[0].time.has_value());
  EXPECT_TRUE(log.rows[0].time->absolute);
  EXPECT_DOUBLE_EQ(std::fmod(log.rows[0].time->seconds, 86400.0), 9 * 3600 + 15 * 60 + 30.5);
  ASSERT_EQ(log.rows[0].joints_rad.size(), 3);
  EXPECT_NEAR(log.rows[0].joints_rad(0), kPi / 2, 1e-15);  // 90°
  EXPECT_NEAR(log.rows[0].joints_rad(1), kPi / 2, 1e-15);  // 100 gon
  EXPECT_DOUBLE_EQ(log.rows[0].joints_rad(2), 0.25);
  // An empty id is no id; the time alone identifies the reading.
  EXPECT_EQ(log.rows[1].line, 3);
  EXPECT_FALSE(log.rows[1].id.has_value());
  EXPECT_FALSE(log.rows[1].time->absolute);
  EXPECT_DOUBLE_EQ(log.rows[1].time->seconds, 1234.5);
  EXPECT_NEAR(log.rows[1].joints_rad(0), -kPi / 4, 1e-15);
  EXPECT_NEAR(log.rows[1].joints_rad(1), -kPi / 4, 1e-15);
  EXPECT_DOUBLE_EQ(log.rows[1].joints_rad(2), -1.0);
}

// A controller's own column names, read in the unit given for them, in the order given.
TEST(JointLog, NamedJointColumnsAreReadInTheGivenUnitAndOrder) {
  testing::TempDir dir;
  testing::WriteText(dir.File("log.csv"), "id,A2,A1\nP1,0.5,-0.25\n");
  JointLogOptions options;
  options.joint_columns = {"A1", "A2"};
  options.joint_unit = AngleUnit::kRad;
  const JointLog log = ReadJointLog(dir.File("log.csv"), options);
  EXPECT_TRUE(log.has_ids);
  EXPECT_FALSE(log.has_times);
  ASSERT_EQ(log.rows.size(), 1u);
  EXPECT_DOUBLE_EQ(log.rows[0].joints_rad(0), -0.25);
  EXPECT_DOUBLE_EQ(log.rows[0].joints_rad(1), 0.5);
}

// With the robot's joint count known, the log has exactly its joints.
TEST(JointLog, HasExactlyTheRobotsJoints) {
  JointLogOptions two;
  two.num_joints = 2;
  const std::string extra = JointLogRefusal("pose,q1_deg,q2_deg,q3_deg\nP1,1,2,3\n", two);
  EXPECT_NE(extra.find("log.csv:1: has a column q3_deg but the robot model has 2 joints"),
            std::string::npos)
      << extra;
  JointLogOptions three;
  three.num_joints = 3;
  const std::string missing = JointLogRefusal("pose,q1_deg,q2_deg\nP1,1,2\n", three);
  EXPECT_NE(missing.find("missing column 'q3_deg'"), std::string::npos) << missing;
  // Unknown count: as many as there are, and at least one.
  const std::string none = JointLogRefusal("pose,x_mm\nP1,1\n");
  EXPECT_NE(none.find("log.csv:1: no joint columns"), std::string::npos) << none;
}

// What cannot be joined is refused at its line: no id and no time column, a reading with
// neither, a time that is none, an angle that is no joint angle, no readings at all.
TEST(JointLog, RefusesWhatCannotBeJoinedAtItsLine) {
  const std::string no_key = JointLogRefusal("q1_deg,q2_deg\n1,2\n");
  EXPECT_NE(no_key.find("log.csv:1: expected a pose id column"), std::string::npos) << no_key;
  const std::string anonymous = JointLogRefusal("pose,q1_deg\nP1,1\n,2\n");
  EXPECT_NE(anonymous.find("log.csv:3: a joint reading without an id or a time"), std::string::npos)
      << anonymous;
  const std::string bad_time = JointLogRefusal("time,q1_deg\n10.5,1\nnoon,2\n");
  EXPECT_NE(bad_time.find("log.csv:3:1 (time): expected a time stamp"), std::string::npos)
      << bad_time;
  const std::string wild = JointLogRefusal("pose,q1_deg\nP1,1e6\n");
  EXPECT_NE(wild.find("log.csv:2:2 (q1_deg)"), std::string::npos) << wild;
  const std::string empty = JointLogRefusal("pose,q1_deg\n");
  EXPECT_NE(empty.find("no joint readings after the header"), std::string::npos) << empty;
}

}  // namespace armsig::io

namespace armsig::io {
namespace {

// A robot controller that logs radians into columns named _deg: every value of every joint
// within ±2π over many readings, while a calibration moves joints by tens of degrees. The
// log is refused with the figures; the same numbers under _rad, or a real degree log that
// reaches past 2π, are read.
TEST(JointLog, RadiansUnderADegreeLabelAreRefused) {
  std::string deg = "pose,q1_deg,q2_deg,q3_deg\n", rad = "pose,q1_rad,q2_rad,q3_rad\n";
  std::string real = deg;
  for (int k = 0; k < 12; ++k) {
    const std::string row = fmt::format("P{},{:.4f},{:.4f},{:.4f}\n", k, -2.6 + 0.4 * k,
                                        1.1 - 0.2 * k, 0.3 * std::sin(k));
    deg += row;
    rad += row;
    real += fmt::format("P{},{:.4f},{:.4f},{:.4f}\n", k, -26.0 + 4.0 * k, 11 - 2.0 * k, 3.0 * k);
  }
  const std::string why = JointLogRefusal(deg);
  EXPECT_NE(why.find("look like radians under a degree label"), std::string::npos) << why;
  EXPECT_NE(why.find("q1_deg, q2_deg, q3_deg"), std::string::npos) << why;
  EXPECT_EQ(JointLogRefusal(rad), "(accepted)");
  EXPECT_EQ(JointLogRefusal(real), "(accepted)");
}

}  // namespace
}  // namespace armsig::io
