// The nightly job never makes the robot worse, and knows when it would (issue 37): sessions
// still being captured and ISO 9283 tests are not fitted, a set worse where it was not fitted
// is not activated, a set that says "not this robot" is refused, and the door refuses data
// that cannot be this robot's in these units.
#include <fmt/format.h>
#include <gtest/gtest.h>

#include <random>

#include "acquisition/session_owner.h"
#include "calibration/synthetic.h"
#include "core/error.h"
#include "db/database.h"
#include "db/sessions.h"
#include "db/store.h"
#include "io/poses_csv.h"
#include "support/simulated_sessions.h"
#include "test_support.h"
#include "workflows/import.h"
#include "workflows/lifecycle.h"
#include "nightly/recalibrate.h"

namespace armsig::testing {
namespace {

using Outcome = nightly::RecalibrationDecision::Outcome;

nightly::RecalibrateOptions Options(const std::string& path) {
  nightly::RecalibrateOptions o;
  o.db_path = path;
  o.robot = "puma";
  return o;
}

// A session of the true PUMA at the given configurations, stored as a capture would
// (bypassing the import's door checks, as a capture does).
int64_t StoreSession(db::Database& db, const std::vector<MeasuredPose>& poses) {
  db::WriteTransaction tx(db);
  const int64_t robot =
      db::EnsureRobot(db, "puma", "puma760", ReadText(SourcePath("models/puma760.yaml")));
  const int64_t session = db::CreateSession(db, robot, "", "", db::SessionState::kCompleted, "simulated");
  for (size_t i = 0; i < poses.size(); ++i) {
    const int64_t pose = db::InsertPose(db, session, static_cast<int>(i), poses[i].id,
                                        poses[i].joints_rad, "measured", 1);
    db::PointRow point;
    point.pose_id = pose;
    point.point = "target";
    point.position_mm = poses[i].target_in_world;
    point.covariance_mm2 = Eigen::Matrix3d::Constant(NAN);
    point.rays = 3;
    db::InsertPoint(db, session, point);
  }
  tx.commit();
  return session;
}

std::vector<MeasuredPose> TruePoses(int count, unsigned seed, double range_rad = 2.5,
                                    double scale = 1.0) {
  const auto model = Puma();
  std::mt19937 rng(seed);
  auto poses = calibration::SimulatePoses(model, Eigen::Isometry3d::Identity(),
                                          calibration::PaperTable3Parameters(),
                                          calibration::RandomConfigurations(model, count, rng,
                                                                            range_rad),
                                          0.01, rng);
  for (auto& p : poses) {
    p.target_in_world *= scale;
    p.id = fmt::format("s{}-{}", seed, p.id);
  }
  return poses;
}

class NeverWorse : public ::testing::Test {
 protected:
  std::string Path() const { return dir_.File("lab.db"); }
  TempDir dir_;
};

TEST_F(NeverWorse, ASessionStillBeingCapturedIsNotFitted) {
  int64_t live = 0;
  {
    db::Database database(Path());
    AddSession(database, calibration::PaperTable3Parameters(), 150, 1);
    AddSession(database, calibration::PaperTable3Parameters(), 150, 2);
    live = 2;
    // Session 2 is being captured right now, by this very process.
    db::SetSessionState(database, live, db::SessionState::kRunning);
    db::SetSessionOwner(database, live, acquisition::ThisProcess());
  }
  const auto night = nightly::Recalibrate(Options(Path()));
  ASSERT_EQ(night.outcome, Outcome::kStored) << night.Describe();
  EXPECT_EQ(night.sessions, std::vector<int64_t>{1});
  {
    db::Database database(Path());
    db::SetSessionState(database, live, db::SessionState::kCompleted);
  }
  const auto next = nightly::Recalibrate(Options(Path()));
  EXPECT_EQ(next.sessions, (std::vector<int64_t>{1, 2}));
}

TEST_F(NeverWorse, TestAndCheckSessionsAreFittedOnlyWhenAsked) {
  {
    db::Database database(Path());
    AddSession(database, calibration::PaperTable3Parameters(), 150, 3);
    AddSession(database, calibration::PaperTable3Parameters(), 150, 4);
    AddSession(database, calibration::PaperTable3Parameters(), 150, 5);
    workflows::SetSessionKind(database, 2, db::SessionKind::kTest);
    workflows::SetSessionKind(database, 3, db::SessionKind::kCheck);
    const auto sessions = db::ListSessions(database, std::nullopt);
    EXPECT_EQ(sessions[1].kind, db::SessionKind::kTest);
    EXPECT_EQ(sessions[2].kind, db::SessionKind::kCheck);
    EXPECT_FALSE(db::SessionKindNamed("tset"));
  }
  const auto night = nightly::Recalibrate(Options(Path()));
  ASSERT_EQ(night.outcome, Outcome::kStored) << night.Describe();
  EXPECT_EQ(night.sessions, std::vector<int64_t>{1});
  // The sessions not fitted are where the new set was tried before it became active.
  ASSERT_EQ(night.elsewhere.size(), 2u);
  for (const auto& e : night.elsewhere) {
    EXPECT_TRUE(e.held);
    EXPECT_EQ(e.reference, "the nominal model");
    EXPECT_LT(e.new_mean_mm, 0.1 * e.reference_mean_mm);
  }
  auto options = Options(Path());
  options.kinds = {db::SessionKind::kCalibration, db::SessionKind::kTest};
  const auto asked = nightly::Recalibrate(options);
  EXPECT_EQ(asked.sessions, (std::vector<int64_t>{1, 2}));
}

// A night whose data cover a small corner of the work volume fits it well and validates
// well there; on the robot's earlier sessions, placed by their own frames, it is far worse
// than the active set, and is not activated.
TEST_F(NeverWorse, ASetWorseWhereItWasNotFittedIsNotActivated) {
  {
    db::Database database(Path());
    StoreSession(database, TruePoses(150, 6));
    StoreSession(database, TruePoses(150, 7));
  }
  const auto first = nightly::Recalibrate(Options(Path()));
  ASSERT_EQ(first.outcome, Outcome::kStored) << first.Describe();
  {
    db::Database database(Path());
    StoreSession(database, TruePoses(150, 8, 0.25));  // every joint within ±14°
  }
  auto options = Options(Path());
  options.window_sessions = 1;  // the nightly window: the newest session alone
  const auto night = nightly::Recalibrate(options);
  EXPECT_EQ(night.outcome, Outcome::kRejected) << night.Describe();
  EXPECT_EQ(night.ExitCode(), 3);
  ASSERT_FALSE(night.refusals.empty());
  EXPECT_NE(night.refusals.front().find("worse elsewhere"), std::string::npos)
      << night.refusals.front();
  EXPECT_NE(night.Describe().find("version 1 stays active"), std::string::npos);
  EXPECT_EQ(ActiveVersion(Path()), 1);
  EXPECT_EQ(Versions(Path()), 1);
}

// Positions 3 % too large (a tracker set to the wrong unit scale, another robot's data):
// the fit turns them into link lengths tens of millimetres off and validates; the set is
// refused naming the figure, never activated.
TEST_F(NeverWorse, AnImplausibleSetIsRefusedWithTheFigure) {
  {
    db::Database database(Path());
    StoreSession(database, TruePoses(200, 9, 2.5, 1.03));
  }
  const auto night = nightly::Recalibrate(Options(Path()));
  EXPECT_EQ(night.outcome, Outcome::kRejected) << night.Describe();
  ASSERT_FALSE(night.refusals.empty());
  EXPECT_NE(night.refusals.front().find("not this robot or not these units"), std::string::npos)
      << night.refusals.front();
  EXPECT_NE(night.refusals.front().find("mm (limit"), std::string::npos) << night.refusals.front();
  EXPECT_EQ(Versions(Path()), 0);
}

// --- At the door ---------------------------------------------------------------------------

class Door : public ::testing::Test {
 protected:
  void SetUp() override {
    db::Database database(dir_.File("lab.db"));
    workflows::RegisterRobot(database, "puma", SourcePath("models/puma760.yaml"));
  }
  workflows::ImportPosesRequest Request(const std::vector<MeasuredPose>& poses) {
    const std::string file = dir_.File("poses.csv");
    WriteText(file, io::FormatPosesCsv(poses));
    workflows::ImportPosesRequest r;
    r.file = file;
    r.robot = "puma";
    r.db_path = dir_.File("lab.db");
    return r;
  }
  int SessionCount() {
    db::Database database(dir_.File("lab.db"));
    return static_cast<int>(db::ListSessions(database, std::nullopt).size());
  }
  std::string Refusal(const workflows::ImportPosesRequest& r) {
    try {
      workflows::ImportPosesFile(r);
    } catch (const InputError& e) {
      return e.what();
    }
    return "";
  }
  TempDir dir_;
};

TEST_F(Door, TheRobotsOwnPosesAreStoredWithTheirKind) {
  auto r = Request(TruePoses(40, 10));
  r.kind = db::SessionKind::kCheck;
  const auto stored = workflows::ImportPosesFile(r);
  EXPECT_EQ(stored.poses, 40u);
  db::Database database(dir_.File("lab.db"));
  EXPECT_EQ(db::ListSessions(database, std::nullopt).at(0).kind, db::SessionKind::kCheck);
}

TEST_F(Door, AnotherRobotsPosesAreRefusedAndNothingIsStored) {
  const auto ur10 = Ur10();
  std::mt19937 rng(11);
  auto poses = calibration::SimulatePoses(ur10, Eigen::Isometry3d::Identity(),
                                          Eigen::VectorXd::Zero(ur10.num_parameters()),
                                          calibration::RandomConfigurations(ur10, 40, rng), 0.02,
                                          rng);
  const std::string why = Refusal(Request(poses));
  EXPECT_NE(why.find("misses these poses by"), std::string::npos) << why;
  EXPECT_NE(why.find("another robot"), std::string::npos) << why;
  EXPECT_EQ(SessionCount(), 0);
}

TEST_F(Door, MetresTakenForMillimetresAreNamed) {
  auto poses = TruePoses(40, 12, 2.5, 0.001);
  const std::string why = Refusal(Request(poses));
  EXPECT_NE(why.find("the positions are metres, not millimetres"), std::string::npos) << why;
  EXPECT_EQ(SessionCount(), 0);
}

TEST_F(Door, ThreeReadingsOfAnUnmovedRobotAreNotASession) {
  auto poses = TruePoses(3, 13);
  poses[1].joints_rad = poses[2].joints_rad = poses[0].joints_rad;
  const std::string why = Refusal(Request(poses));
  EXPECT_NE(why.find("only 1 distinct configuration"), std::string::npos) << why;
  EXPECT_EQ(SessionCount(), 0);
}

TEST_F(Door, RadiansUnderADegreeLabelAreRefusedWithTheFigures) {
  auto poses = TruePoses(40, 14);
  // The file says q*_deg; its numbers are radians.
  std::string text = "pose,q1_deg,q2_deg,q3_deg,q4_deg,q5_deg,q6_deg,x_mm,y_mm,z_mm\n";
  for (const auto& p : poses) {
    text += p.id;
    for (int i = 0; i < 6; ++i) text += fmt::format(",{:.9f}", p.joints_rad(i));
    text += fmt::format(",{:.4f},{:.4f},{:.4f}\n", p.target_in_world.x(), p.target_in_world.y(),
                        p.target_in_world.z());
  }
  auto r = Request(poses);
  WriteText(r.file, text);
  const std::string why = Refusal(r);
  EXPECT_NE(why.find("look like radians"), std::string::npos) << why;
  EXPECT_EQ(SessionCount(), 0);
  // Converting only (no robot): the same refusal, no file.
  r.robot.clear();
  r.out = dir_.File("out.csv");
  EXPECT_NE(Refusal(r).find("look like radians"), std::string::npos);
  EXPECT_FALSE(std::filesystem::exists(r.out));
}

}  // namespace
}  // namespace armsig::testing
