// The lab's life cycle from the command line, on real data: a UR10 measured by a laser
// tracker (IPA series C) registered, its tracker export imported as a session,
// recalibrated, predicted, compensated, exported, listed and rolled back.
#include <fmt/format.h>
#include <gtest/gtest.h>

#include <filesystem>
#include <nlohmann/json.hpp>

#include "core/units.h"
#include "io/csv.h"
#include "io/model_yaml.h"
#include "io/poses_csv.h"
#include "test_support.h"

namespace armsig::testing {

TEST(LifecycleCommands, RealUr10FromRegistrationToCompensationAndRollback) {
  TempDir dir;
  const std::string db = "--db '" + dir.File("lab.db") + "' ";
  const std::string ur10 = SourcePath("models/ur10.yaml");
  ASSERT_EQ(RunArmsig(db + "robot add ur10 --model '" + ur10 + "'").exit_code, 0);
  const auto again = RunArmsig(db + "robot add ur10 --model '" + ur10 + "'");
  EXPECT_EQ(again.exit_code, 0);
  EXPECT_NE(again.out.find("already registered"), std::string::npos) << again.out;
  const auto other =
      RunArmsig(db + "robot add ur10 --model '" + SourcePath("models/puma760.yaml") + "'");
  EXPECT_EQ(other.exit_code, 2) << other.err;
  WriteText(dir.File("bad.yaml"), "name: x\ndh:\n  - {d_mm: 1, a_mm: 0, alpha_dg: 90}\n");
  const auto bad = RunArmsig(db + "robot add x --model '" + dir.File("bad.yaml") + "'");
  EXPECT_EQ(bad.exit_code, 2);
  EXPECT_NE(bad.err.find("alpha_dg"), std::string::npos) << bad.err;

  // The tracker export straight into a session of the robot (and a copy as poses CSV).
  const std::string data = DataPath("ur10-ipa/series_C-measurements_random_poses.csv");
  const auto imported =
      RunArmsig(db + "import poses '" + data + "' --preset ur-ipa --robot ur10 --out '" +
                dir.File("c.csv") + "'");
  ASSERT_EQ(imported.exit_code, 0) << imported.err;
  // The same export again stores nothing and names the session that holds it.
  const auto twice = RunArmsig(db + "import poses '" + data + "' --preset ur-ipa --robot ur10");
  EXPECT_EQ(twice.exit_code, 0) << twice.err;
  EXPECT_NE(twice.out.find("already stored as session 1"), std::string::npos) << twice.out;
  const auto unknown = RunArmsig(db + "import poses '" + data + "' --preset ur-ipa --robot ur5");
  EXPECT_EQ(unknown.exit_code, 2);
  EXPECT_NE(unknown.err.find("robot add ur5"), std::string::npos) << unknown.err;

  const auto robots = RunArmsig(db + "robot list --json");
  ASSERT_EQ(robots.exit_code, 0);
  const auto rj = nlohmann::json::parse(robots.out);
  ASSERT_EQ(rj.size(), 1u);
  EXPECT_EQ(rj[0]["name"], "ur10");
  EXPECT_EQ(rj[0]["sessions"], 1);
  EXPECT_TRUE(rj[0]["active_version"].is_null());
  const auto sessions = RunArmsig(db + "sessions --robot ur10 --json");
  ASSERT_EQ(sessions.exit_code, 0) << sessions.err;
  const auto sj = nlohmann::json::parse(sessions.out);
  ASSERT_EQ(sj.size(), 1u);
  EXPECT_EQ(sj[0]["measured"], 2773);
  EXPECT_EQ(sj[0]["usable_points"], 2773);
  EXPECT_EQ(sj[0]["state"], "completed");

  // The session comes back as the same poses.
  ASSERT_EQ(RunArmsig(db + "session export " + std::to_string(sj[0]["id"].get<int>()) +
                      " --poses '" + dir.File("back.csv") + "'")
                .exit_code,
            0);
  const auto original = io::ReadPosesCsv(dir.File("c.csv"), 6);
  const auto back = io::ReadPosesCsv(dir.File("back.csv"), 6);
  ASSERT_EQ(back.size(), original.size());
  for (size_t k = 0; k < back.size(); ++k) {
    EXPECT_EQ(back[k].id, original[k].id);
    EXPECT_LT((back[k].joints_rad - original[k].joints_rad).norm(), 1e-9);
    EXPECT_LT((back[k].target_in_world - original[k].target_in_world).norm(), 1e-6);
  }
  EXPECT_EQ(RunArmsig(db + "session export 99 --poses '" + dir.File("x.csv") + "'").exit_code, 2);

  // Two nights' fits, then a roll-back.
  const std::string recal =
      db + "recalibrate --robot ur10 --params geometric --max-validation-mean-mm 0.8 ";
  const auto first = RunArmsig(recal + "--json '" + dir.File("1.json") + "'");
  ASSERT_EQ(first.exit_code, 0) << first.err;
  const auto j1 = nlohmann::json::parse(ReadText(dir.File("1.json")));
  EXPECT_EQ(j1["version"], 1);
  EXPECT_GT(j1["validation"]["mean_mm"].get<double>(), 0.3);  // README: 0.49 mm, the model's floor
  EXPECT_LT(j1["validation"]["mean_mm"].get<double>(), 0.6);
  ASSERT_EQ(RunArmsig(recal + "--select 120").exit_code, 0);
  auto versions = nlohmann::json::parse(RunArmsig(db + "versions --robot ur10 --json").out);
  ASSERT_EQ(versions.size(), 2u);
  EXPECT_FALSE(versions[0]["active"].get<bool>());
  EXPECT_TRUE(versions[1]["active"].get<bool>());
  EXPECT_EQ(versions[1]["sessions"], nlohmann::json::array({1}));
  EXPECT_EQ(versions[1]["poses_fit"], 120);
  const auto rollback = RunArmsig(db + "activate --robot ur10 --version 1");
  ASSERT_EQ(rollback.exit_code, 0) << rollback.err;
  EXPECT_NE(rollback.out.find("was version 2"), std::string::npos) << rollback.out;
  versions = nlohmann::json::parse(RunArmsig(db + "versions --robot ur10 --json").out);
  EXPECT_TRUE(versions[0]["active"].get<bool>());
  EXPECT_FALSE(versions[1]["active"].get<bool>());
  EXPECT_EQ(RunArmsig(db + "activate --robot ur10 --version 9").exit_code, 2);

  // Predict at measured joints: the active (version 1) model lands within its validation
  // error of the tracker's points.
  std::string joints = "pose,q1_deg,q2_deg,q3_deg,q4_deg,q5_deg,q6_deg\n";
  for (int k = 0; k < 20; ++k) {
    joints += original[k].id;
    for (int i = 0; i < 6; ++i)
      joints += fmt::format(",{:.12f}", original[k].joints_rad(i) * 180 / kPi);
    joints += "\n";
  }
  WriteText(dir.File("j.csv"), joints);
  const auto predicted = RunArmsig(db + "predict --robot ur10 --frame measurement --joints '" +
                                   dir.File("j.csv") + "' --out '" + dir.File("p.csv") + "'");
  ASSERT_EQ(predicted.exit_code, 0) << predicted.err;
  const auto p = io::ReadCsvFile(dir.File("p.csv"));
  ASSERT_EQ(p.rows().size(), 20u);
  double mean = 0;
  for (size_t k = 0; k < 20; ++k) {
    const Eigen::Vector3d x(p.Number(p.rows()[k], 1), p.Number(p.rows()[k], 2),
                            p.Number(p.rows()[k], 3));
    mean += (x - original[k].target_in_world).norm() / 20;
  }
  EXPECT_LT(mean, 1.0);

  // Compensate: joints for those predicted points; predicted back they land on them.
  std::string targets = "point,x_mm,y_mm,z_mm\n";
  for (size_t k = 0; k < 5; ++k) {
    targets += fmt::format("T{},{},{},{}\n", k, p.Text(p.rows()[k], 1), p.Text(p.rows()[k], 2),
                           p.Text(p.rows()[k], 3));
  }
  WriteText(dir.File("t.csv"), targets);
  std::string seed;
  for (int i = 0; i < 6; ++i)
    seed += fmt::format("{}{:.6f}", i ? "," : "", original[0].joints_rad(i) * 180 / kPi);
  const auto compensated =
      RunArmsig(db + "compensate --robot ur10 --frame measurement --seed-deg=" + seed +
                " --targets '" + dir.File("t.csv") + "' --out '" + dir.File("cj.csv") + "'");
  EXPECT_NE(compensated.exit_code, 2) << compensated.err;
  const auto cj = io::ReadCsvFile(dir.File("cj.csv"));
  ASSERT_EQ(cj.rows().size(), 5u);
  EXPECT_EQ(cj.Text(cj.rows()[0], cj.Column("status")), "ok");

  // Export the corrected model: it reads back as a model of the same robot.
  ASSERT_EQ(RunArmsig(db + "export --robot ur10 --format model --frame measurement --out '" +
                      dir.File("m.yaml") + "'")
                .exit_code,
            0);
  const auto corrected = io::LoadRobotModel(dir.File("m.yaml"));
  EXPECT_EQ(corrected.num_joints(), 6);
}

}  // namespace armsig::testing
