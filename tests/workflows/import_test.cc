// `import poses` as a library call into a real SQLite store: a pose table and a tracker's
// point table with the robot's joint log stored as sessions that read back as the poses
// written into the files; the same measurements refused as a duplicate; a bad line named
// by file:line:column with nothing stored and no --out file left.
#include "workflows/import.h"

#include <fmt/format.h>
#include <gtest/gtest.h>

#include <filesystem>
#include <random>

#include "calibration/synthetic.h"
#include "core/error.h"
#include "core/units.h"
#include "db/database.h"
#include "io/poses_csv.h"
#include "test_support.h"
#include "workflows/lifecycle.h"

namespace armsig::testing {
namespace {

// Simulated PUMA poses: joints and targets the files are written from, the truth the
// stored session is compared with.
std::vector<MeasuredPose> SimulatedPoses(unsigned seed, int count) {
  const auto model = Puma();
  std::mt19937 rng(seed);
  return calibration::SimulatePoses(
      model, Eigen::Isometry3d::Identity(), calibration::PaperTable3Parameters(),
      calibration::RandomConfigurations(model, count, rng), 0.01, rng);
}

// The poses file armsig reads, written here by hand: joints in degrees, targets in mm.
std::string PosesFile(const std::vector<MeasuredPose>& poses) {
  std::string text = "pose,q1_deg,q2_deg,q3_deg,q4_deg,q5_deg,q6_deg,x_mm,y_mm,z_mm\n";
  for (const auto& p : poses) {
    text += p.id;
    for (int i = 0; i < 6; ++i) text += fmt::format(",{:.15f}", p.joints_rad(i) / kRadPerDeg);
    for (int c = 0; c < 3; ++c) text += fmt::format(",{:.12f}", p.target_in_world(c));
    text += "\n";
  }
  return text;
}

// A lab database with the PUMA registered.
std::string LabDatabase(const TempDir& dir) {
  const std::string path = dir.File("lab.db");
  db::Database database(path);
  EXPECT_TRUE(workflows::RegisterRobot(database, "puma", SourcePath("models/puma760.yaml")));
  return path;
}

void ExpectSamePoses(const std::vector<MeasuredPose>& stored,
                     const std::vector<MeasuredPose>& truth) {
  ASSERT_EQ(stored.size(), truth.size());
  for (size_t k = 0; k < truth.size(); ++k) {
    EXPECT_EQ(stored[k].id, truth[k].id);
    EXPECT_LT((stored[k].joints_rad - truth[k].joints_rad).cwiseAbs().maxCoeff(), 1e-12) << k;
    EXPECT_LT((stored[k].target_in_world - truth[k].target_in_world).norm(), 1e-9) << k;
  }
}

}  // namespace

// A poses file into the store and to --out: the session holds the file's poses in its
// order, and the --out file reads back as the same poses.
TEST(ImportPosesFile, StoresThePosesOfAFileAsASessionOfTheRobot) {
  TempDir dir;
  const auto truth = SimulatedPoses(3, 25);
  WriteText(dir.File("poses.csv"), PosesFile(truth));
  workflows::ImportPosesRequest request;
  request.file = dir.File("poses.csv");
  request.robot = "puma";
  request.db_path = LabDatabase(dir);
  request.out = dir.File("copy.csv");
  const auto result = workflows::ImportPosesFile(request);
  EXPECT_EQ(result.poses, truth.size());
  EXPECT_FALSE(result.duplicate);
  EXPECT_GT(result.session, 0);
  EXPECT_EQ(result.db_path, request.db_path);

  db::Database database(request.db_path);
  const auto sessions = workflows::Sessions(database, "puma");
  ASSERT_EQ(sessions.size(), 1u);
  ExpectSamePoses(workflows::SessionPoses(database, result.session), truth);
  WriteText(dir.File("again.csv"), ReadText(request.out));
  workflows::ImportPosesRequest copy;
  copy.file = dir.File("again.csv");
  copy.out = dir.File("copy2.csv");
  EXPECT_EQ(workflows::ImportPosesFile(copy).poses, truth.size());
  EXPECT_EQ(ReadText(copy.out), ReadText(request.out));  // the poses format reads as written
}

// The same measurements imported again (another file name, other ids) are refused as a
// duplicate naming the session that holds them; nothing more is stored. --allow-duplicate
// stores a copy.
TEST(ImportPosesFile, TheSameMeasurementsTwiceAreStoredOnce) {
  TempDir dir;
  auto truth = SimulatedPoses(4, 12);
  WriteText(dir.File("a.csv"), PosesFile(truth));
  for (auto& p : truth) p.id = "again-" + p.id;
  WriteText(dir.File("b.csv"), PosesFile(truth));
  workflows::ImportPosesRequest request;
  request.robot = "puma";
  request.db_path = LabDatabase(dir);
  request.file = dir.File("a.csv");
  const auto first = workflows::ImportPosesFile(request);
  request.file = dir.File("b.csv");
  const auto second = workflows::ImportPosesFile(request);
  EXPECT_TRUE(second.duplicate);
  EXPECT_EQ(second.session, first.session);
  {
    db::Database database(request.db_path);
    EXPECT_EQ(workflows::Sessions(database, "puma").size(), 1u);
  }
  request.allow_duplicate = true;
  const auto copy = workflows::ImportPosesFile(request);
  EXPECT_FALSE(copy.duplicate);
  EXPECT_NE(copy.session, first.session);
  db::Database database(request.db_path);
  EXPECT_EQ(workflows::Sessions(database, "puma").size(), 2u);
}

// Issue 38: a session exported (`session export --poses`, io::FormatPosesCsv: 12 significant
// digits of a joint in degrees, 9 of a coordinate in mm) and imported again was stored a
// second time: the rounding moved the values off the digest's grid. One coordinate 1 µm off
// is another measurement and is stored.
TEST(ImportPosesFile, AnExportedSessionImportedAgainIsTheSameMeasurement) {
  TempDir dir;
  const auto truth = SimulatedPoses(6, 30);
  WriteText(dir.File("full.csv"), PosesFile(truth));
  workflows::ImportPosesRequest request;
  request.robot = "puma";
  request.db_path = LabDatabase(dir);
  request.file = dir.File("full.csv");
  const auto first = workflows::ImportPosesFile(request);
  ASSERT_FALSE(first.duplicate);
  std::vector<MeasuredPose> stored;
  {
    db::Database database(request.db_path);
    stored = workflows::SessionPoses(database, first.session);
  }
  WriteText(dir.File("export.csv"), io::FormatPosesCsv(stored));
  request.file = dir.File("export.csv");
  const auto again = workflows::ImportPosesFile(request);
  EXPECT_TRUE(again.duplicate);
  EXPECT_EQ(again.session, first.session);
  auto moved = stored;
  moved[17].target_in_world.y() += 0.001;
  WriteText(dir.File("moved.csv"), io::FormatPosesCsv(moved));
  request.file = dir.File("moved.csv");
  const auto other = workflows::ImportPosesFile(request);
  EXPECT_FALSE(other.duplicate);
  EXPECT_NE(other.session, first.session);
  db::Database database(request.db_path);
  EXPECT_EQ(workflows::Sessions(database, "puma").size(), 2u);
}

// A number that is none on line 6: the error names file:line:column and the column; the
// store holds no session and no --out file is left behind.
TEST(ImportPosesFile, ABadLineIsNamedAndNothingIsKept) {
  TempDir dir;
  std::string text = PosesFile(SimulatedPoses(5, 10));
  const size_t line6 = [&] {
    size_t at = 0;
    for (int k = 0; k < 5; ++k) at = text.find('\n', at) + 1;
    return at;
  }();
  const size_t q3 = [&] {  // the fourth field of line 6
    size_t at = line6;
    for (int k = 0; k < 3; ++k) at = text.find(',', at) + 1;
    return at;
  }();
  text.replace(q3, text.find(',', q3) - q3, "12.5.3");
  WriteText(dir.File("poses.csv"), text);
  workflows::ImportPosesRequest request;
  request.file = dir.File("poses.csv");
  request.robot = "puma";
  request.db_path = LabDatabase(dir);
  request.out = dir.File("out.csv");
  try {
    workflows::ImportPosesFile(request);
    FAIL() << "accepted a bad number";
  } catch (const InputError& e) {
    EXPECT_EQ(e.where().file, request.file);
    EXPECT_EQ(e.where().line, 6);
    EXPECT_EQ(e.where().column, 4);
    EXPECT_NE(std::string(e.what()).find(request.file + ":6:4 (q3_deg)"), std::string::npos)
        << e.what();
  }
  db::Database database(request.db_path);
  EXPECT_TRUE(workflows::Sessions(database, "puma").empty());
  EXPECT_FALSE(std::filesystem::exists(request.out));
}

// A tracker's point table (metres, sigmas) joined by id with the robot's joint log: the
// session holds the joints of the log and the points in mm, in the point table's order.
TEST(ImportPosesFile, StoresATrackersPointsJoinedWithTheJointLog) {
  TempDir dir;
  const auto truth = SimulatedPoses(6, 8);
  std::string points = "Units: Meter\nName X Y Z SigmaX SigmaY SigmaZ\n";
  std::string log = "pose,q1_deg,q2_deg,q3_deg,q4_deg,q5_deg,q6_deg\n";
  for (auto p = truth.rbegin(); p != truth.rend(); ++p) {  // the log in another order
    log += p->id;
    for (int i = 0; i < 6; ++i) log += fmt::format(",{:.15f}", p->joints_rad(i) / kRadPerDeg);
    log += "\n";
  }
  for (const auto& p : truth) {
    points += fmt::format("{} {:.15f} {:.15f} {:.15f} 0.00001 0.00001 0.00002\n", p.id,
                          p.target_in_world.x() / 1000, p.target_in_world.y() / 1000,
                          p.target_in_world.z() / 1000);
  }
  WriteText(dir.File("pts.txt"), points);
  WriteText(dir.File("log.csv"), log + "HOME,0,0,0,0,0,0\n");
  workflows::ImportPosesRequest request;
  request.points = dir.File("pts.txt");
  request.joints = dir.File("log.csv");
  request.robot = "puma";
  request.db_path = LabDatabase(dir);
  const auto result = workflows::ImportPosesFile(request);
  EXPECT_EQ(result.poses, truth.size());
  EXPECT_EQ(result.unused_joint_rows, 1);
  db::Database database(request.db_path);
  ExpectSamePoses(workflows::SessionPoses(database, result.session), truth);
}

}  // namespace armsig::testing
