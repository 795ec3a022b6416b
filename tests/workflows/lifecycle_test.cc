// The life-cycle functions as a library: measured poses stored once (idempotent import),
// and sessions whose process is gone told apart from live ones.
#include "workflows/lifecycle.h"

#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <random>

#include "acquisition/session_owner.h"
#include "calibration/synthetic.h"
#include "core/error.h"
#include "db/sessions.h"
#include "support/simulated_sessions.h"
#include "test_support.h"

namespace armsig::testing {

namespace {

std::vector<MeasuredPose> SimulatedPoses(unsigned seed, int count) {
  const auto model = Puma();
  std::mt19937 rng(seed);
  return calibration::SimulatePoses(model, Eigen::Isometry3d::Identity(),
                                    calibration::PaperTable3Parameters(),
                                    calibration::RandomConfigurations(model, count, rng), 0.01,
                                    rng);
}

}  // namespace

// The same file imported twice stores one session; the second import names it. Poses
// that differ in one coordinate are other measurements; --allow-duplicate stores a copy.
TEST(StorePosesSession, TheSameMeasurementsAreStoredOnce) {
  TempDir dir;
  db::Database database(dir.File("lab.db"));
  ASSERT_TRUE(workflows::RegisterRobot(database, "puma", SourcePath("models/puma760.yaml")));
  auto poses = SimulatedPoses(5, 40);
  const auto first = workflows::StorePosesSession(database, "puma", poses, "a.csv");
  EXPECT_FALSE(first.duplicate);
  EXPECT_EQ(first.digest, workflows::PosesDigest(poses));
  // Renamed ids are the same measurements (a re-export with other labels).
  auto renamed = poses;
  for (auto& p : renamed) p.id = "x" + p.id;
  const auto again = workflows::StorePosesSession(database, "puma", renamed, "b.csv");
  EXPECT_TRUE(again.duplicate);
  EXPECT_EQ(again.session, first.session);
  // The same targets read from a file in metres: the unit conversion's last-bit rounding
  // makes no other measurement.
  auto in_m = poses;
  int differ = 0;
  for (size_t k = 0; k < in_m.size(); ++k) {
    for (int c = 0; c < 3; ++c) {
      const double metres = poses[k].target_in_world(c) / 1000.0 * 1.0000000000000002;
      in_m[k].target_in_world(c) = metres * 1000.0;
      differ += in_m[k].target_in_world(c) != poses[k].target_in_world(c);
    }
  }
  EXPECT_GT(differ, 0);  // the bits did change
  EXPECT_EQ(workflows::PosesDigest(in_m), first.digest);
  EXPECT_TRUE(workflows::StorePosesSession(database, "puma", in_m, "m.txt").duplicate);
  auto changed = poses;
  changed[17].target_in_world.z() += 0.001;
  EXPECT_NE(workflows::PosesDigest(changed), first.digest);
  const auto other = workflows::StorePosesSession(database, "puma", changed, "c.csv");
  EXPECT_FALSE(other.duplicate);
  EXPECT_NE(other.session, first.session);
  const auto copy = workflows::StorePosesSession(database, "puma", poses, "a.csv", true);
  EXPECT_FALSE(copy.duplicate);
  EXPECT_EQ(workflows::Sessions(database, "puma").size(), 3u);
  // What is stored comes back: the same joints and targets, in order.
  const auto back = workflows::SessionPoses(database, first.session);
  ASSERT_EQ(back.size(), poses.size());
  EXPECT_EQ(workflows::PosesDigest(back), first.digest);
  EXPECT_EQ(workflows::SessionJoints(database, first.session), 6);
}

// A `running` session whose process is gone (killed, a power cut) is shown `interrupted`
// and can be claimed; one whose process is alive, or runs on another host, cannot.
TEST(SessionOwner, ARunningSessionOfAGoneProcessIsInterrupted) {
  TempDir dir;
  db::Database database(dir.File("lab.db"));
  AddSession(database, calibration::PaperTable3Parameters(), 5, 1);
  const int64_t session = 1;
  db::SetSessionState(database, session, db::SessionState::kRunning);

  // Never recorded (a database from before owners): interrupted.
  EXPECT_EQ(workflows::Sessions(database, "puma").at(0).shown_state, "interrupted");

  const db::SessionOwner me = acquisition::ThisProcess();
  EXPECT_EQ(me.pid, ::getpid());
  EXPECT_FALSE(me.started.empty());
  EXPECT_EQ(acquisition::StateOf(me), acquisition::OwnerState::kAlive);
  // The same pid with another start token is another process that reused the pid.
  EXPECT_EQ(acquisition::StateOf({me.pid, me.host, me.started + "0"}),
            acquisition::OwnerState::kGone);
  EXPECT_EQ(acquisition::StateOf({me.pid, me.host + ".elsewhere", me.started}),
            acquisition::OwnerState::kUnknown);

  // A child that has exited and been reaped: its pid names no process.
  const pid_t child = ::fork();
  if (child == 0) ::_exit(0);
  int status = 0;
  ASSERT_EQ(::waitpid(child, &status, 0), child);
  const db::SessionOwner gone{child, me.host, "boot/1"};
  EXPECT_EQ(acquisition::StateOf(gone), acquisition::OwnerState::kGone);
  db::SetSessionOwner(database, session, gone);
  EXPECT_EQ(workflows::Sessions(database, "puma").at(0).shown_state, "interrupted");
  EXPECT_EQ(acquisition::DisplayState(db::SessionState::kPaused, gone), "paused");
  acquisition::ClaimSession(database, session);  // resumable: it is ours now
  auto row = db::LoadSession(database, session);
  ASSERT_TRUE(row && row->owner);
  EXPECT_EQ(*row->owner, me);
  EXPECT_EQ(row->state, db::SessionState::kRunning);
  EXPECT_EQ(workflows::Sessions(database, "puma").at(0).shown_state, "running");

  // A live process (this one, recorded without a start token, as by another armsig
  // process of the same pid namespace) and another host's process keep their claim.
  db::SetSessionOwner(database, session, {me.pid, me.host, ""});
  EXPECT_THROW(acquisition::ClaimSession(database, session), InputError);
  db::SetSessionOwner(database, session, {4242, "capture-pc-2", "x/1"});
  try {
    acquisition::ClaimSession(database, session);
    ADD_FAILURE() << "claimed a session running on another host";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("capture-pc-2"), std::string::npos) << e.what();
  }
  EXPECT_EQ(workflows::Sessions(database, "puma").at(0).shown_state, "running");
}

// `sessions` never cuts a count from its word: the counts stand whole beside the session or
// on the next line, the note on its own (issue 38: the doc's sample read "2773 | usable").
TEST(SessionsText, CountsStayWholeAndEveryLineFits) {
  workflows::ListedSession s;
  s.id = 1;
  s.robot = "ur10";
  s.state = db::SessionState::kCompleted;
  s.shown_state = "completed";
  s.kind = db::SessionKind::kCalibration;
  s.started_at = "2026-11-28T19:56:20.123Z";
  s.measured = s.usable = 2773;
  s.note = "poses imported from tests/data/ur10-ipa/series_C-measurements_random_poses.csv";
  const std::string text = workflows::FormatSessions({s}, false);
  EXPECT_NE(text.find("\n      2773 measured, 0 skipped, 2773 usable, 0 flagged\n"),
            std::string::npos)
      << text;
  EXPECT_NE(text.find("\n      poses imported from"), std::string::npos) << text;
  size_t start = 0;
  for (size_t end; (end = text.find('\n', start)) != std::string::npos; start = end + 1)
    EXPECT_LE(end - start, 100u) << text.substr(start, end - start);
}

}  // namespace armsig::testing
