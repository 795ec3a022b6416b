// Point tables as laser-tracker software exports them, joined with a robot's joint log:
// every dialect of the fixtures (tests/data/tracker-exports, modelled on documented vendor
// layouts) gives the same points, and simulated robot data written in those dialects come
// back as the simulated poses, by id and by time stamp; what cannot be told apart or
// matched is refused at its line.
#include "io/tracker_import.h"

#include <fmt/format.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <ctime>
#include <functional>
#include <random>

#include "calibration/simulation.h"
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

// The four points every fixture holds, in mm.
const Eigen::Vector3d kFixture[4] = {{1512.4031, -203.1187, 1034.5520},
                                     {1498.7725, 12.0390, 1102.7713},
                                     {1377.0051, 240.6624, 987.2209},
                                     {1620.1998, -412.5071, 856.4412}};

std::string Fixture(const std::string& name) {
  return testing::DataPath("tracker-exports/" + name);
}

void ExpectFixturePoints(const PointTable& t, double tolerance_mm, const std::string& prefix) {
  ASSERT_EQ(t.points.size(), 4u) << t.source;
  for (int k = 0; k < 4; ++k) {
    EXPECT_EQ(t.points[k].name, prefix.empty() ? std::to_string(k + 1)
                                               : fmt::format("{}{:03d}", prefix, k + 1));
    EXPECT_LT((t.points[k].position_mm - kFixture[k]).norm(), tolerance_mm)
        << t.source << " point " << k + 1 << ": " << t.points[k].position_mm.transpose();
  }
}

std::string Refusal(const std::string& text, const PointTableOptions& options = {}) {
  try {
    ParsePointTable(text, "pts.txt", options);
  } catch (const InputError& e) {
    return e.what();
  }
  return "(accepted)";
}

}  // namespace

TEST(TrackerImport, EveryExportDialectGivesTheSamePoints) {
  {
    // SpatialAnalyzer: // comments, Collection Group Target x y z, no unit in the file.
    PointTableOptions mm;
    mm.unit = LengthUnit::kMm;
    const auto t = ReadPointTable(Fixture("sa-collection-group-target.txt"), mm);
    ExpectFixturePoints(t, 1e-9, "P");
    EXPECT_EQ(t.delimiter, "whitespace");
    EXPECT_EQ(t.header_line, 0);
    EXPECT_EQ(t.unit_from, "--points-unit");
  }
  {
    // Leica: title lines, "Units: Meter", an aligned header with a code column.
    const auto t = ReadPointTable(Fixture("leica-ptid-east-north-height.txt"));
    ExpectFixturePoints(t, 1e-9, "P");
    EXPECT_EQ(t.header_line, 6);
    EXPECT_EQ(t.unit, LengthUnit::kM);
    EXPECT_NE(t.unit_from.find("line 4"), std::string::npos) << t.unit_from;
  }
  {
    // ';' with decimal commas, title lines, units in the header, ISO times, CR LF.
    const auto t = ReadPointTable(Fixture("semicolon-decimal-comma.csv"));
    ExpectFixturePoints(t, 1e-9, "P");
    EXPECT_EQ(t.delimiter, "semicolon");
    EXPECT_TRUE(t.decimal_comma);
    EXPECT_EQ(t.header_line, 4);
    ASSERT_TRUE(t.has_times);
    EXPECT_TRUE(t.points[0].time->absolute);
    EXPECT_NEAR(t.points[1].time->seconds - t.points[0].time->seconds, 11.75, 1e-6);
  }
  {
    // Tab-separated, a units line: inches for the coordinates, mm for the sigmas.
    const auto t = ReadPointTable(Fixture("tab-units-line-sigmas.txt"));
    ExpectFixturePoints(t, 2e-5, "P");  // six decimals of an inch: 2.5e-5 mm
    EXPECT_EQ(t.delimiter, "tab");
    EXPECT_EQ(t.unit, LengthUnit::kInch);
    ASSERT_TRUE(t.points[0].sigma_mm.has_value());
    EXPECT_NEAR(t.points[0].sigma_mm->x(), 0.0081, 1e-12);  // mm, not inches
    EXPECT_NEAR(t.points[3].sigma_mm->z(), 0.0110, 1e-12);
  }
  {
    // Numbered points with a code column, no header: positional.
    PointTableOptions mm;
    mm.unit = LengthUnit::kMm;
    ExpectFixturePoints(ReadPointTable(Fixture("numbered-points-with-codes.txt"), mm), 1e-9, "");
  }
}

TEST(TrackerImport, RefusesWhatItCannotTellApartAtItsLine) {
  PointTableOptions mm;
  mm.unit = LengthUnit::kMm;
  // Name, xyz, ijk, offset, tolerances: nine numbers, no header.
  try {
    ReadPointTable(Fixture("powerinspect-normals.txt"), mm);
    FAIL();
  } catch (const InputError& e) {
    EXPECT_EQ(e.where().line, 1);
    EXPECT_NE(std::string(e.what()).find("cannot tell the columns apart"), std::string::npos)
        << e.what();
  }
  // No unit anywhere: never guessed.
  EXPECT_NE(Refusal("A B P1 1 2 3\nA B P2 4 5 6\n").find("give --points-unit"), std::string::npos);
  // Two units that disagree.
  PointTableOptions metres;
  metres.unit = LengthUnit::kM;
  const std::string conflict = Refusal("name,x [mm],y [mm],z [mm]\nP1,1,2,3\n", metres);
  EXPECT_NE(conflict.find("says mm but --points-unit says m"), std::string::npos) << conflict;
  EXPECT_NE(Refusal("name,x [mm],y [m],z [mm]\nP1,1,2,3\n").find("one length unit"),
            std::string::npos);
  // A number that is none: file:line:column (column name).
  EXPECT_NE(Refusal("name;x [mm];y [mm];z [mm]\nP1;1;2;3\nP2;4;5,5,5;6\n")
                .find("pts.txt:3:3 (y [mm]): expected a finite number, got '5,5,5'"),
            std::string::npos)
      << Refusal("name;x [mm];y [mm];z [mm]\nP1;1;2;3\nP2;4;5,5,5;6\n");
  // Implausible coordinates (a unit mix-up by 10^9).
  EXPECT_NE(Refusal("name,x [m],y [m],z [m]\nP1,1e9,2,3\n").find("pts.txt:2:2"), std::string::npos);
  // Duplicate names, with both lines.
  EXPECT_NE(Refusal("name x y z\nmm mm mm\nP1 1 2 3\nP2 4 5 6\nP1 7 8 9\n")
                .find("pts.txt:5:1 (name): duplicate point name 'P1' (also on line 3)"),
            std::string::npos)
      << Refusal("name x y z\nmm mm mm\nP1 1 2 3\nP2 4 5 6\nP1 7 8 9\n");
  // A row that does not fit the table, after the first point row.
  EXPECT_NE(Refusal("name,x_mm,y_mm,z_mm\nP1,1,2,3\nP2,4,5\n")
                .find("pts.txt:3: expected 4 fields (comma-separated)"),
            std::string::npos);
  // Text between the header and the points that is no units line.
  EXPECT_NE(Refusal("name,x_mm,y_mm,z_mm\nmeasured by hand\nP1,1,2,3\n")
                .find("pts.txt:2: expected a units line"),
            std::string::npos)
      << Refusal("name,x_mm,y_mm,z_mm\nmeasured by hand\nP1,1,2,3\n");
  // No point rows at all.
  EXPECT_NE(Refusal("just a title\n").find("no point rows"), std::string::npos);
  // A bad time stamp, at its column.
  EXPECT_NE(Refusal("name,x_mm,y_mm,z_mm,time\nP1,1,2,3,yesterday\n").find("pts.txt:2:5 (time)"),
            std::string::npos);
}

TEST(TrackerImport, TimeStampsAreIsoDateTimesOrSeconds) {
  // An independent computation of the same instants: timegm of the broken-down UTC time.
  std::tm tm{};
  tm.tm_year = 2024 - 1900;
  tm.tm_mon = 2;
  tm.tm_mday = 5;
  tm.tm_hour = 9;
  tm.tm_min = 15;
  tm.tm_sec = 30;
  const double utc = static_cast<double>(::timegm(&tm));
  auto seconds = [](const char* text) {
    const auto t = ParseTimeStamp(text);
    EXPECT_TRUE(t.has_value()) << text;
    return t ? t->seconds : NAN;
  };
  EXPECT_DOUBLE_EQ(seconds("2024-03-05T09:15:30Z"), utc);
  EXPECT_DOUBLE_EQ(seconds("2024-03-05 09:15:30.25"), utc + 0.25);
  EXPECT_DOUBLE_EQ(seconds("2024-03-05T10:15:30+01:00"), utc);
  EXPECT_DOUBLE_EQ(seconds("2024-03-05T04:45:30-0430"), utc);
  EXPECT_DOUBLE_EQ(seconds("1970-01-01T00:00Z"), 0.0);
  EXPECT_TRUE(ParseTimeStamp("2024-03-05T09:15:30Z")->absolute);
  EXPECT_FALSE(ParseTimeStamp("1234.5")->absolute);
  EXPECT_DOUBLE_EQ(ParseTimeStamp("1234,5")->seconds, 1234.5);
  for (const char* bad : {"", "2024-13-05T09:15:30", "2024-03-05", "2024-03-05T25:00", "noon",
                          "2024-03-05T09:15:30+25:00", "2024-03-05T09:15:30 UTC"}) {
    EXPECT_FALSE(ParseTimeStamp(bad).has_value()) << bad;
  }
}

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
TEST(TrackerImport, JoinByIdGivesBackTheSimulatedPoses) {
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
  const int c7_line = 5 + static_cast<int>(std::find(order.begin(), order.end(), 6) - order.begin());
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
TEST(TrackerImport, JoinByTimeTakesTheStandstillAroundEachPoint) {
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
    points += fmt::format("A Robot C{} {:.4f} {:.4f} {:.4f} {:04d}-{:02d}-{:02d} {:02d}:{:02d}:{:06.3f}\n",
                          k + 1, sim.targets[k].x(), sim.targets[k].y(), sim.targets[k].z(),
                          tm.tm_year + 1900, tm.tm_mon + 1, tm.tm_mday, tm.tm_hour, tm.tm_min,
                          tm.tm_sec + (t - whole));
  }
  // The log's clock as the controller writes it: date-times too.
  std::string iso_log = "time,q1_deg,q2_deg,q3_deg,q4_deg,q5_deg,q6_deg\n";
  for (size_t at = log.find('\n') + 1; at < log.size();) {
    const size_t comma = log.find(',', at), end = log.find('\n', at);
    const double t = std::stod(log.substr(at, comma - at));
    std::time_t whole = static_cast<std::time_t>(std::floor(t));
    std::tm tm{};
    ::gmtime_r(&whole, &tm);
    iso_log += fmt::format("{:04d}-{:02d}-{:02d}T{:02d}:{:02d}:{:06.3f}Z", tm.tm_year + 1900,
                           tm.tm_mon + 1, tm.tm_mday, tm.tm_hour, tm.tm_min,
                           tm.tm_sec + (t - whole)) +
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
  EXPECT_NE(Refused([&] { JoinPointsAndJoints(table, ReadJointLog(dir.File("log.csv"))); })
                .find("join by time"),
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
