// armsig robot rename | remove | restore | history and session move (issue 38, "robots and
// sessions"): the lab reorganises, the history stays. Every change keeps every stored row,
// is refused when it would mix arms of different joint counts or reuse a taken name, and is
// recorded with who made it and why.
#include <fmt/format.h>
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>
#include <pwd.h>
#include <unistd.h>

#include "calibration/synthetic.h"
#include "db/database.h"
#include "io/file_lock.h"
#include "support/simulated_sessions.h"
#include "test_support.h"
#include "nightly/recalibrate.h"
#include "workflows/lifecycle.h"

namespace armsig::testing {

namespace {

int64_t Count(const std::string& path, const std::string& sql) {
  db::Database database(path, db::OpenMode::kMustExist);
  return database.connection().QueryInt(sql);
}

}  // namespace

TEST(RobotHistory, RenameMoveRemoveAndRestoreKeepEveryRowAndSayWhoAndWhy) {
  TempDir dir;
  const std::string path = dir.File("lab.db");
  {
    db::Database database(path);
    AddSession(database, calibration::PaperTable3Parameters(), 40, 3);  // robot puma, session 1
  }
  const std::string db = "--db '" + path + "' ";
  const int64_t poses = Count(path, "SELECT count(*) FROM poses");
  ASSERT_GT(poses, 0);
  ASSERT_EQ(RunArmsig(db + "robot add puma-b --model '" + SourcePath("models/puma760.yaml") + "'")
                .exit_code,
            0);
  WriteText(dir.File("arm3.yaml"),
            "name: arm3\nbase: auto\nlinks:\n  - [[1,0,0,0],[0,0,-1,164],[0,1,0,0],[0,0,0,1]]\n"
            "  - [[1,0,0,650],[0,1,0,0],[0,0,1,50],[0,0,0,1]]\ntool_mm: [0, 0, 0]\n");
  ASSERT_EQ(RunArmsig(db + "robot add arm3 --model '" + dir.File("arm3.yaml") + "'").exit_code, 0);

  // Renamed: its session follows it; the name taken by another robot is refused.
  const auto renamed = RunArmsig(db + "robot rename puma puma-cell3 --reason 'cell renumbered'");
  ASSERT_EQ(renamed.exit_code, 0) << renamed.err;
  const auto list = nlohmann::json::parse(RunArmsig(db + "robot list --json").out);
  ASSERT_EQ(list.size(), 3u);
  EXPECT_EQ(list[2]["name"], "puma-cell3");
  EXPECT_EQ(list[2]["sessions"], 1);
  const auto taken = RunArmsig(db + "robot rename puma-b puma-cell3");
  EXPECT_EQ(taken.exit_code, 2);
  EXPECT_NE(taken.err.find("robot 'puma-cell3' exists already: nothing was renamed"),
            std::string::npos)
      << taken.err;
  EXPECT_EQ(RunArmsig(db + "robot rename nosuch x").exit_code, 2);
  const auto same = RunArmsig(db + "robot rename puma-b puma-b");  // no wait on its own lock
  EXPECT_EQ(same.exit_code, 2);
  EXPECT_NE(same.err.find("robot 'puma-b' has that name already"), std::string::npos) << same.err;
  {  // A night's run of the robot under way (its lock held): nothing changes under it.
    const io::FileLock night(workflows::RobotLockPath(path, "puma-cell3"), 1);
    const auto busy = RunArmsig(db + "robot rename puma-cell3 other");
    EXPECT_EQ(busy.exit_code, 2);
    EXPECT_NE(busy.err.find("robot 'puma-cell3' is being recalibrated ("), std::string::npos)
        << busy.err;
    EXPECT_NE(busy.err.find("nothing was changed"), std::string::npos) << busy.err;
  }

  // Moved: not to an arm of another joint count; to a twin, with both histories.
  const auto three = RunArmsig(db + "session move 1 --robot arm3");
  EXPECT_EQ(three.exit_code, 2);
  EXPECT_NE(three.err.find("session 1 holds 6-joint configurations of robot 'puma-cell3'; robot "
                           "'arm3' has 3 joints: nothing was moved"),
            std::string::npos)
      << three.err;
  const auto moved =
      RunArmsig(db + "session move 1 --robot puma-b --reason 'captured under the wrong name'");
  ASSERT_EQ(moved.exit_code, 0) << moved.err;
  EXPECT_NE(moved.out.find("session 1 moved from robot puma-cell3 to robot puma-b"),
            std::string::npos)
      << moved.out;
  const auto again = RunArmsig(db + "session move 1 --robot puma-b");  // no wait on its own lock
  EXPECT_EQ(again.exit_code, 2);
  EXPECT_NE(again.err.find("session 1 is robot puma-b's already"), std::string::npos) << again.err;
  const auto sessions = nlohmann::json::parse(RunArmsig(db + "sessions --json").out);
  ASSERT_EQ(sessions.size(), 1u);
  EXPECT_EQ(sessions[0]["robot"], "puma-b");

  // Removed: hidden, refused for new work (each named), every row kept; then restored.
  ASSERT_EQ(RunArmsig(db + "robot remove puma-b --reason 'sold'").exit_code, 0);
  EXPECT_EQ(nlohmann::json::parse(RunArmsig(db + "robot list --json").out).size(), 2u);
  EXPECT_NE(RunArmsig(db + "robot list").out.find("(1 removed: armsig robot list --removed)"),
            std::string::npos);
  const auto all = RunArmsig(db + "robot list --removed");
  EXPECT_NE(all.out.find("removed 20"), std::string::npos) << all.out;
  for (const std::string& work :
       {std::string("recalibrate --robot puma-b"), std::string("schedule recalibrate --robot puma-b"),
        "robot add puma-b --model '" + SourcePath("models/puma760.yaml") + "'"}) {
    const auto refused = RunArmsig(db + work);
    EXPECT_EQ(refused.exit_code, 2) << work << "\n" << refused.err;
    EXPECT_NE(refused.err.find("robot 'puma-b' was removed ("), std::string::npos)
        << work << "\n" << refused.err;
    EXPECT_NE(refused.err.find("armsig robot restore puma-b"), std::string::npos) << refused.err;
  }
  EXPECT_EQ(RunArmsig(db + "session move 1 --robot puma-cell3").exit_code, 0);
  EXPECT_EQ(RunArmsig(db + "session move 1 --robot puma-b").exit_code, 2);  // into a removed one
  ASSERT_EQ(RunArmsig(db + "robot restore puma-b").exit_code, 0);
  EXPECT_EQ(Count(path, "SELECT count(*) FROM poses"), poses);
  EXPECT_EQ(Count(path, "SELECT count(*) FROM robots"), 3);

  // The history: every change, oldest first, with its reason and the user.
  const std::string user = ::getpwuid(::geteuid())->pw_name;
  const auto history = nlohmann::json::parse(RunArmsig(db + "robot history puma-b --json").out);
  ASSERT_EQ(history.size(), 4u) << history.dump();
  EXPECT_EQ(history[0]["event"], "session_moved_in");
  EXPECT_EQ(history[0]["detail"], "session 1 moved in from puma-cell3");
  EXPECT_EQ(history[0]["reason"], "captured under the wrong name");
  EXPECT_EQ(history[0]["by"], user);
  EXPECT_EQ(history[1]["event"], "removed");
  EXPECT_EQ(history[1]["reason"], "sold");
  EXPECT_EQ(history[2]["event"], "session_moved_out");
  EXPECT_EQ(history[3]["event"], "restored");
  const auto text = RunArmsig(db + "robot history puma-cell3");
  EXPECT_NE(text.out.find("renamed from puma to puma-cell3: cell renumbered, by " + user + "\n"),
            std::string::npos)
      << text.out;
}

}  // namespace armsig::testing
