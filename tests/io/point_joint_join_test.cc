// A tracker's point table joined with a robot's joint log: simulated robot data written in
// the tracker exports' dialects come back as the simulated poses, by id and by time stamp;
// what cannot be matched is refused at its line.
#include "io/point_joint_join.h"

#include <fmt/format.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <ctime>
#include <functional>
#include <random>

#include "calibration/synthetic.h"
#include "core/error.h"
#include "core/units.h"
#include "test_support.h"

namespace armsig::io {
namespace {

JointLogOptions SixJoints() {
  JointLogOptions options;
  options.num_joints = 6;
  return options;
}

}  // namespace

namespace {

// A simulated robot's poses (the paper's PUMA with its Table 3 errors) in a tracker frame.
struct Simulated {
  calibration::RobotModel model = testing::Puma();
  std::vector<Eigen::VectorXd> joints;
  std::vector<Eigen::Vector3d> targets;  // mm
  explicit Simulated(int n, unsigned seed) {
    std::mt19937 rng(seed);
    joints = calibration::RandomConfigurations(model, n, rng);
    Eigen::Isometry3d world_from_base = Eigen::Isometry3d::Identity();
    world_from_base.translate(Eigen::Vector3d(2400.0, -1300.0, -700.0));
    world_from_base.rotate(Eigen::AngleAxisd(2.1, Eigen::Vector3d::UnitZ()));
    calibration::Kinematics kin(model);
    for (const auto& q : joints)
      targets.push_back(
          kin.Position(world_from_base, calibration::PaperTable3Parameters(), q.data()));
  }
};

std::string DecimalComma(double v, int digits) {
  std::string s = fmt::format("{:.{}f}", v, digits);
  std::replace(s.begin(), s.end(), '.', ',');
  return s;
}

std::string JointsCsvRow(const Eigen::VectorXd& q) {
  std::string row;
  for (int i = 0; i < q.size(); ++i) row += fmt::format(",{:.12f}", q(i) / kRadPerDeg);
  return row;
}

std::string Refused(const std::function<void()>& f) {
  try {
    f();
  } catch (const InputError& e) {
    return e.what();
  }
  return "(accepted)";
}

}  // namespace

// Points in metres with decimal commas and title lines, in another order than the joint
// log, which has readings no point uses: the join by id gives back every simulated pose.
TEST(PointJointJoin, JoinByIdGivesBackTheSimulatedPoses) {
  const Simulated sim(40, 11);
  testing::TempDir dir;
  std::string points = "Tracker export;cell 3\nUnits;Meter\n\nPoint;X;Y;Z;SigmaX;SigmaY;SigmaZ\n";
  std::vector<int> order(sim.joints.size());
  for (size_t k = 0; k < order.size(); ++k) order[k] = static_cast<int>(k);
  std::shuffle(order.begin(), order.end(), std::mt19937(3));
  for (int k : order) {
    points += fmt::format("C{};{};{};{};0,000012;0,000013;0,000015\n", k + 1,
                          DecimalComma(sim.targets[k].x() / 1000, 9),
                          DecimalComma(sim.targets[k].y() / 1000, 9),
                          DecimalComma(sim.targets[k].z() / 1000, 9));
  }
  testing::WriteText(dir.File("pts.csv"), points);
  std::string log = "pose,q1_deg,q2_deg,q3_deg,q4_deg,q5_deg,q6_deg\n";
  for (size_t k = 0; k < sim.joints.size(); ++k)
    log += "C" + std::to_string(k + 1) + JointsCsvRow(sim.joints[k]) + "\n";
  log += "HOME,0,0,0,0,0,0\n";
  testing::WriteText(dir.File("log.csv"), log);

  const auto table = ReadPointTable(dir.File("pts.csv"));
  EXPECT_EQ(table.unit, LengthUnit::kM);
  const auto joined = JoinPointsAndJoints(table, ReadJointLog(dir.File("log.csv"), SixJoints()));
  ASSERT_EQ(joined.poses.size(), sim.joints.size());
  EXPECT_EQ(joined.unused_joint_rows, 1);
  for (size_t j = 0; j < joined.poses.size(); ++j) {
    const int k = order[j];
    EXPECT_EQ(joined.poses[j].id, "C" + std::to_string(k + 1));
    EXPECT_LT((joined.poses[j].joints_rad - sim.joints[k]).cwiseAbs().maxCoeff(), 1e-12);
    EXPECT_LT((joined.poses[j].target_in_world - sim.targets[k]).norm(), 1e-5);  // 1e-9 m
    EXPECT_NEAR(std::sqrt(joined.covariances_mm2[j](2, 2)), 0.015, 1e-12);
  }
  // A point the log does not have, and an id the log has twice: refused at the point's line.
  testing::WriteText(dir.File("log2.csv"), "pose,q1_deg,q2_deg,q3_deg,q4_deg,q5_deg,q6_deg\n" +
                                               log.substr(log.find('\n') + 1) + "C7" +
                                               JointsCsvRow(sim.joints[6]) + "\n");
  std::string pts2 = points + "EXTRA;1;2;3;0,1;0,1;0,1\n";
  testing::WriteText(dir.File("pts2.csv"), pts2);
  const std::string refused = Refused([&] {
    JoinPointsAndJoints(ReadPointTable(dir.File("pts2.csv")),
                        ReadJointLog(dir.File("log2.csv"), SixJoints()));
  });
  const int c7_line =
      5 + static_cast<int>(std::find(order.begin(), order.end(), 6) - order.begin());
  EXPECT_NE(refused.find(fmt::format("pts2.csv:{}: point 'C7' is ambiguous", c7_line)),
            std::string::npos)
      << refused;
  EXPECT_NE(refused.find("lines 8 and 43"), std::string::npos) << refused;
  EXPECT_NE(refused.find("1 more: line 45 (EXTRA): no joint reading"), std::string::npos)
      << refused;
}

// A robot that logs its joints at 10 Hz, standing 2 s at each configuration and moving 1 s
// between them; the tracker measures somewhere in each standstill (its clock 0.02 s off).
// The join by time finds each point's configuration; a point taken while the robot moved,
// one far from any reading and two points on one reading are refused at their lines.
TEST(PointJointJoin, JoinByTimeTakesTheStandstillAroundEachPoint) {
  const Simulated sim(12, 5);
  testing::TempDir dir;
  std::mt19937 rng(9);
  std::normal_distribution<double> encoder(0.0, 1e-6);
  std::uniform_real_distribution<double> when(0.6, 1.4);
  std::string log = "time,q1_deg,q2_deg,q3_deg,q4_deg,q5_deg,q6_deg\n";
  std::string points = "// SA Version 2023.2\nCollection Group Target X Y Z Timestamp\n";
  const double t0 = 1709630000.0;  // 2024-03-05 09:13:20 UTC
  std::vector<double> point_times;
  for (size_t k = 0; k < sim.joints.size(); ++k) {
    const double stand = t0 + 3.0 * k;
    for (int tick = 0; tick < 30; ++tick) {
      const double t = stand + 0.1 * tick;
      Eigen::VectorXd q = sim.joints[k];
      if (tick >= 20 && k + 1 < sim.joints.size())  // moving to the next configuration
        q += (sim.joints[k + 1] - sim.joints[k]) * (tick - 19) / 11.0;
      for (int i = 0; i < q.size(); ++i) q(i) += encoder(rng);
      log += fmt::format("{:.3f}", t) + JointsCsvRow(q) + "\n";
    }
    const double t = stand + when(rng) + 0.02;
    point_times.push_back(t);
    std::time_t whole = static_cast<std::time_t>(std::floor(t));
    std::tm tm{};
    ::gmtime_r(&whole, &tm);
    points += fmt::format(
        "A Robot C{} {:.4f} {:.4f} {:.4f} {:04d}-{:02d}-{:02d} {:02d}:{:02d}:{:06.3f}\n", k + 1,
        sim.targets[k].x(), sim.targets[k].y(), sim.targets[k].z(), tm.tm_year + 1900,
        tm.tm_mon + 1, tm.tm_mday, tm.tm_hour, tm.tm_min, tm.tm_sec + (t - whole));
  }
  // The log's clock as the controller writes it: date-times too.
  std::string iso_log = "time,q1_deg,q2_deg,q3_deg,q4_deg,q5_deg,q6_deg\n";
  for (size_t at = log.find('\n') + 1; at < log.size();) {
    const size_t comma = log.find(',', at), end = log.find('\n', at);
    const double t = std::stod(log.substr(at, comma - at));
    std::time_t whole = static_cast<std::time_t>(std::floor(t));
    std::tm tm{};
    ::gmtime_r(&whole, &tm);
    iso_log +=
        fmt::format("{:04d}-{:02d}-{:02d}T{:02d}:{:02d}:{:06.3f}Z", tm.tm_year + 1900,
                    tm.tm_mon + 1, tm.tm_mday, tm.tm_hour, tm.tm_min, tm.tm_sec + (t - whole)) +
        log.substr(comma, end - comma) + "\n";
    at = end + 1;
  }
  testing::WriteText(dir.File("log.csv"), iso_log);
  testing::WriteText(dir.File("pts.txt"), points);
  PointTableOptions mm;
  mm.unit = LengthUnit::kMm;
  const auto table = ReadPointTable(dir.File("pts.txt"), mm);
  ASSERT_TRUE(table.has_times);
  JoinOptions by_time;
  by_time.by = JoinBy::kTime;
  by_time.time_tolerance_s = 0.5;
  const auto joined = JoinPointsAndJoints(table, ReadJointLog(dir.File("log.csv")), by_time);
  ASSERT_EQ(joined.poses.size(), sim.joints.size());
  for (size_t k = 0; k < sim.joints.size(); ++k) {
    EXPECT_EQ(joined.poses[k].id, "C" + std::to_string(k + 1));
    EXPECT_LT((joined.poses[k].joints_rad - sim.joints[k]).cwiseAbs().maxCoeff(), 1e-5);
    EXPECT_LT((joined.poses[k].target_in_world - sim.targets[k]).norm(), 1e-4);
  }
  EXPECT_LE(joined.max_time_gap_s, 0.05 + 1e-6);  // the nearest 10 Hz tick
  EXPECT_EQ(joined.unused_joint_rows, 30 * 12 - 12);
  // Joining by id needs ids in the log.
  EXPECT_NE(Refused([&] {
              JoinPointsAndJoints(table, ReadJointLog(dir.File("log.csv")));
            }).find("join by time"),
            std::string::npos);

  // Point 3 measured while the robot moved (2.5 s into its slot), point 5 an hour later,
  // point 8 at the time of point 7.
  std::vector<std::string> lines;
  for (size_t at = 0; at < points.size();) {
    const size_t end = points.find('\n', at);
    lines.push_back(points.substr(at, end - at));
    at = end + 1;
  }
  auto with_time = [&](int k, double t) {
    std::time_t whole = static_cast<std::time_t>(std::floor(t));
    std::tm tm{};
    ::gmtime_r(&whole, &tm);
    std::string& l = lines[2 + k];
    l = l.substr(0, l.rfind(' ', l.rfind(' ') - 1)) +
        fmt::format(" {:04d}-{:02d}-{:02d} {:02d}:{:02d}:{:06.3f}", tm.tm_year + 1900,
                    tm.tm_mon + 1, tm.tm_mday, tm.tm_hour, tm.tm_min, tm.tm_sec + (t - whole));
  };
  with_time(2, t0 + 3.0 * 2 + 2.5);
  with_time(4, t0 + 3600.0);
  with_time(7, point_times[6]);
  std::string broken;
  for (const auto& l : lines) broken += l + "\n";
  testing::WriteText(dir.File("broken.txt"), broken);
  const std::string refused = Refused([&] {
    JoinPointsAndJoints(ReadPointTable(dir.File("broken.txt"), mm),
                        ReadJointLog(dir.File("log.csv")), by_time);
  });
  EXPECT_NE(refused.find("broken.txt:5: point 'C3' is ambiguous"), std::string::npos) << refused;
  EXPECT_NE(refused.find("the robot moved"), std::string::npos) << refused;
  EXPECT_NE(refused.find("line 7 (C5): nearest"), std::string::npos) << refused;
  EXPECT_NE(refused.find("line 10 (C8): shares a joint reading"), std::string::npos) << refused;
  // Date-times on one side, seconds on the other: refused, never compared.
  testing::WriteText(dir.File("seconds.csv"), log);
  EXPECT_NE(Refused([&] {
              JoinPointsAndJoints(table, ReadJointLog(dir.File("seconds.csv")), by_time);
            }).find("the same kind"),
            std::string::npos);
}

}  // namespace armsig::io
