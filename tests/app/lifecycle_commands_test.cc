// The lab's life cycle from the command line, on real data: a UR10 measured by a laser
// tracker (IPA series C) registered, its tracker export imported as a session,
// recalibrated, predicted, compensated, exported, listed and rolled back.
#include <fmt/format.h>
#include <gtest/gtest.h>

#include <SQLiteCpp/SQLiteCpp.h>

#include <algorithm>
#include <filesystem>
#include <map>
#include <nlohmann/json.hpp>
#include <random>

#include "calibration/iso9283_figures.h"
#include "calibration/synthetic.h"
#include "calibration/validity.h"
#include "core/rotation.h"
#include "core/units.h"
#include "io/csv.h"
#include "io/model_yaml.h"
#include "io/poses_csv.h"
#include "db/database.h"
#include "support/stores.h"
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
    // The T-Mac's orientation and its sigmas come back too.
    ASSERT_TRUE(back[k].orientation && original[k].orientation) << back[k].id;
    EXPECT_LT((back[k].orientation->world_from_target -
               original[k].orientation->world_from_target)
                  .norm(),
              1e-9);
    ASSERT_TRUE(back[k].orientation->sigma_rad && original[k].orientation->sigma_rad);
    EXPECT_LT((*back[k].orientation->sigma_rad - *original[k].orientation->sigma_rad).norm(),
              1e-12);
  }
  // …as the file's angles: the first row's measurement_rx/ry/rz, -90,179563;-20,112975;
  // -90,157388 (deg), std 0,0024569;0,0065397;0,008348 (deg = 8.84484, 23.54292, 30.0528″).
  const auto exported = io::ReadCsvFile(dir.File("back.csv"));
  const auto& row1 = exported.rows().at(0);
  EXPECT_NEAR(exported.Number(row1, exported.Column("rx_deg")), -90.179563, 1e-9);
  EXPECT_NEAR(exported.Number(row1, exported.Column("ry_deg")), -20.112975, 1e-9);
  EXPECT_NEAR(exported.Number(row1, exported.Column("rz_deg")), -90.157388, 1e-9);
  EXPECT_NEAR(exported.Number(row1, exported.Column("sigma_rz_arcsec")), 30.0528, 1e-7);
  EXPECT_EQ(RunArmsig(db + "session export 99 --poses '" + dir.File("x.csv") + "'").exit_code, 2);

  // Two nights' fits, then a roll-back.
  const std::string recal =
      db + "recalibrate --robot ur10 --params geometric --max-validation-mean-mm 0.8 ";
  const auto first = RunArmsig(recal + "--json '" + dir.File("1.json") + "'");
  ASSERT_EQ(first.exit_code, 0) << first.err;
  const auto j1 = nlohmann::json::parse(ReadText(dir.File("1.json")));
  EXPECT_EQ(j1["version"], 1);
  // 60 % fitted: the residual map has its joint curves (0.083 mm on the issue-13 split), far
  // below the geometric model's floor of 0.45 mm and above the tracker's noise.
  EXPECT_EQ(j1["poses"], 2773);
  EXPECT_EQ(j1["fit"]["poses"], 2773 * 6 / 10);
  EXPECT_GT(j1["validation"]["mean_mm"].get<double>(), 0.05);
  EXPECT_LT(j1["validation"]["mean_mm"].get<double>(), 0.15);
  // The session carries the T-Mac's orientations: the fit and the validation say how well
  // the signature turns the probe (about 0.05°; docs/explanation/transfer.md).
  const double deg = 180.0 / kPi;
  EXPECT_EQ(j1["fit"]["orientation"]["poses"], j1["fit"]["poses"]);
  EXPECT_LT(j1["validation"]["orientation"]["mean_rad"].get<double>() * deg, 0.1);
  EXPECT_GT(j1["fit"]["orientation"]["weight_mm_per_rad"].get<double>(), 0.0);
  const auto second = RunArmsig(recal + "--select 1200");
  ASSERT_EQ(second.exit_code, 0) << second.err;
  auto versions = nlohmann::json::parse(RunArmsig(db + "versions --robot ur10 --json").out);
  ASSERT_EQ(versions.size(), 2u);
  EXPECT_FALSE(versions[0]["active"].get<bool>());
  EXPECT_TRUE(versions[1]["active"].get<bool>());
  EXPECT_EQ(versions[1]["sessions"], nlohmann::json::array({1}));
  EXPECT_EQ(versions[1]["poses_fit"], 1200);
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
  double mean = 0, turn = 0;
  for (size_t k = 0; k < 20; ++k) {
    const Eigen::Vector3d x(p.Number(p.rows()[k], 1), p.Number(p.rows()[k], 2),
                            p.Number(p.rows()[k], 3));
    mean += (x - original[k].target_in_world).norm() / 20;
    // The set was fitted to orientations: the probe's predicted orientation too.
    const Eigen::Vector3d angles(p.Number(p.rows()[k], p.Column("rx_deg")),
                                 p.Number(p.rows()[k], p.Column("ry_deg")),
                                 p.Number(p.rows()[k], p.Column("rz_deg")));
    const Eigen::Matrix3d r = RotationFromRxRyRz(angles / deg);
    turn += Eigen::AngleAxisd(original[k].orientation->world_from_target.transpose() * r)
                .angle() * deg / 20;
  }
  EXPECT_LT(mean, 1.0);
  EXPECT_LT(turn, 0.15);  // degrees

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
  // Reached; from this seed the solution's wrist 2 may sit just outside the angles the map's
  // joint curves saw (C has q5 ≥ 0), which the status says rather than hides.
  const std::string status = cj.Text(cj.rows()[0], cj.Column("status"));
  EXPECT_TRUE(status == "ok" || status == "ok_outside_map") << status;
  EXPECT_LT(cj.Number(cj.rows()[0], cj.Column("residual_mm")), 0.01);

  // Export the corrected model: it reads back as a model of the same robot.
  ASSERT_EQ(RunArmsig(db + "export --robot ur10 --format model --frame measurement --out '" +
                      dir.File("m.yaml") + "'")
                .exit_code,
            0);
  const auto corrected = io::LoadRobotModel(dir.File("m.yaml"));
  EXPECT_EQ(corrected.num_joints(), 6);
}

// Fitted on series C, used on series B (another day, the tracker moved; almost every B pose
// has the wrist and half of them the elbow on the other branch, joint 1 in a range C never
// visits): the nightly path with C as one session and 30 B poses spread through its file as
// a new session, which places the new set-up (its base and the probe's rotation are fitted
// with the signature), then `predict --frame measurement` on B's other 1,465 poses. The
// nightly job's own selection (86 configurations, D-optimal over both sessions), so the run
// costs a few seconds; docs/explanation/transfer.md has the figures of the full fits.
// Issue 37's acceptance on the real UR10, the nightly job exactly as installed (no option):
//  1. fitted on series C alone, its default set is used on series B (another day: the
//     tracker moved, the probe remounted), B placed by one rigid frame fit of all its
//     measured positions: at most 0.80 mm mean (the uncalibrated robot: 2.84 mm; the default
//     before it kept only terms that travel: 8.55 mm), no pose worse than twice its nominal
//     error plus 1 mm, and C's own held-out poses still at most 0.10 mm;
//  2. with 30 of B's poses imported as the new set-up's session, the next night's set
//     predicts B's other 1,465 within 0.35 mm in B's own frame.
TEST(LifecycleCommands, RealUr10DefaultSignatureNeverMakesSeriesBWorse) {
  TempDir dir;
  const std::string db = "--db '" + dir.File("lab.db") + "' ";
  ASSERT_EQ(RunArmsig(db + "robot add ur10 --model '" + SourcePath("models/ur10.yaml") + "'")
                .exit_code,
            0);
  ASSERT_EQ(RunArmsig(db + "import poses '" +
                      DataPath("ur10-ipa/series_C-measurements_random_poses.csv") +
                      "' --preset ur-ipa --robot ur10")
                .exit_code,
            0);
  const auto b = io::ImportPoses(
      DataPath("ur10-ipa/series_B-measurements_joint_configurations.csv"),
      io::PoseImportOptions::UrIpa());
  ASSERT_EQ(b.size(), 1495u);
  auto joints_csv = [](const std::vector<MeasuredPose>& poses) {
    std::string joints = "pose,q1_deg,q2_deg,q3_deg,q4_deg,q5_deg,q6_deg\n";
    for (const auto& p : poses) {
      joints += p.id;
      for (int i = 0; i < 6; ++i) joints += fmt::format(",{:.15g}", p.joints_rad(i) * 180 / kPi);
      joints += "\n";
    }
    return joints;
  };
  auto positions = [](const io::CsvTable& t, const char* x, const char* y, const char* z) {
    std::vector<Eigen::Vector3d> out;
    for (const auto& row : t.rows())
      out.emplace_back(t.Number(row, t.Column(x)), t.Number(row, t.Column(y)),
                       t.Number(row, t.Column(z)));
    return out;
  };

  // 1. The first night: series C alone.
  const auto first = RunArmsig(db + "recalibrate --robot ur10 --json '" + dir.File("c.json") + "'");
  ASSERT_EQ(first.exit_code, 0) << first.err << first.out;
  const auto cj = nlohmann::json::parse(ReadText(dir.File("c.json")));
  EXPECT_EQ(cj["decision"], "stored");
  const double c_held_out = cj["validation"]["mean_mm"].get<double>();
  WriteText(dir.File("b.csv"), joints_csv(b));
  ASSERT_EQ(RunArmsig(db + "predict --robot ur10 --frame robot --joints '" + dir.File("b.csv") +
                      "' --out '" + dir.File("b_pred.csv") + "'")
                .exit_code,
            0);
  const auto table = io::ReadCsvFile(dir.File("b_pred.csv"));
  ASSERT_EQ(table.rows().size(), b.size());
  std::vector<Eigen::Vector3d> measured;
  for (const auto& p : b) measured.push_back(p.target_in_world);
  // One rigid frame for all of B, fitted to the calibrated and to the nominal predictions.
  const auto calibrated =
      calibration::iso9283::AlignRigidly(measured, positions(table, "x_mm", "y_mm", "z_mm"));
  const auto nominal = calibration::iso9283::AlignRigidly(
      measured, positions(table, "nominal_x_mm", "nominal_y_mm", "nominal_z_mm"));
  ASSERT_TRUE(calibrated && nominal);
  double mean = 0.0, nominal_mean = 0.0, worst_excess = -1e9;
  int worse = 0, covered = 0;
  const int sigma_col = table.Column("sigma_mm");
  for (size_t i = 0; i < b.size(); ++i) {
    mean += calibrated->residual_mm[i] / b.size();
    nominal_mean += nominal->residual_mm[i] / b.size();
    const double limit = 2.0 * nominal->residual_mm[i] + 1.0;
    worst_excess = std::max(worst_excess, calibrated->residual_mm[i] - limit);
    worse += calibrated->residual_mm[i] > limit;
    covered += calibrated->residual_mm[i] <=
               calibration::kCoverageRadius * table.Number(table.rows()[i], sigma_col);
  }
  std::cout << fmt::format(
      "UR10 default set fitted on series C: C held out {:.4f} mm; on series B (one rigid frame): "
      "{:.4f} mm mean, nominal {:.4f} mm, {} poses beyond 2 x nominal + 1 mm, {:.1f} % within "
      "{:.2f} sigma_mm\n",
      c_held_out, mean, nominal_mean, worse, 100.0 * covered / b.size(),
      calibration::kCoverageRadius);
  EXPECT_LE(c_held_out, 0.10);
  EXPECT_LE(mean, 0.80);
  EXPECT_GT(nominal_mean, 2.0);  // the test means something: the robot is millimetres off
  EXPECT_EQ(worse, 0) << "worst excess " << worst_excess << " mm";

  // 2. The next day's set-up: 30 of B's poses spread through the file as a new session.
  const int n = static_cast<int>(b.size()), count = 30;
  std::vector<char> placing(n, 0);
  for (int k = 0; k < count; ++k) placing[static_cast<int>((k + 0.5) * n / count)] = 1;
  std::vector<MeasuredPose> place, rest;
  for (int i = 0; i < n; ++i) (placing[i] ? place : rest).push_back(b[i]);
  WriteText(dir.File("place.csv"), io::FormatPosesCsv(place));
  ASSERT_EQ(RunArmsig(db + "import poses '" + dir.File("place.csv") + "' --robot ur10").exit_code,
            0);
  const auto night = RunArmsig(db + "recalibrate --robot ur10 --json '" +
                               dir.File("night.json") + "'");
  ASSERT_EQ(night.exit_code, 0) << night.err << night.out;
  EXPECT_EQ(nlohmann::json::parse(ReadText(dir.File("night.json")))["decision"], "stored");
  WriteText(dir.File("rest.csv"), joints_csv(rest));
  ASSERT_EQ(RunArmsig(db + "predict --robot ur10 --frame measurement --joints '" +
                      dir.File("rest.csv") + "' --out '" + dir.File("pred.csv") + "'")
                .exit_code,
            0);
  const auto predicted = io::ReadCsvFile(dir.File("pred.csv"));
  ASSERT_EQ(predicted.rows().size(), rest.size());
  const auto x = positions(predicted, "x_mm", "y_mm", "z_mm");
  double placed = 0.0, turn = 0.0;
  for (size_t k = 0; k < rest.size(); ++k) {
    const auto& row = predicted.rows()[k];
    placed += (x[k] - rest[k].target_in_world).norm() / static_cast<double>(rest.size());
    // The probe's orientation in B's frame: B's own tool rotation, fitted from 30 poses.
    const Eigen::Vector3d angles(predicted.Number(row, predicted.Column("rx_deg")),
                                 predicted.Number(row, predicted.Column("ry_deg")),
                                 predicted.Number(row, predicted.Column("rz_deg")));
    turn += Eigen::AngleAxisd(rest[k].orientation->world_from_target.transpose() *
                              RotationFromRxRyRz(angles * kPi / 180))
                .angle() * 180 / kPi / static_cast<double>(rest.size());
  }
  std::cout << fmt::format("UR10 fitted on series C, used on series B placed by 30 poses: "
                           "{:.4f} mm, {:.4f} deg on the other 1,465\n", placed, turn);
  EXPECT_LE(placed, 0.35);
  EXPECT_LE(turn, 0.15);
}

// The nightly path on the real UR10 (IPA series C, measured by a laser tracker): the
// tracker's export imported as a session of the registered robot, recalibrated with 1773
// well-spread fit poses and validated on the other 1000. The held-out mean is the figure
// the data are known for (0.44–0.45 mm with the geometric model, README "Figures"); the
// stored set's own predictions at the validation poses reproduce it; compensate and export
// work from the active set.
// On either store: the same figure from the plant's server as from the lab's file.
class LifecycleOnStore : public ::testing::TestWithParam<db::Backend> {};

TEST_P(LifecycleOnStore, RealUr10NightlyPathReproducesTheHeldOutFigure) {
  TempDir dir;
  const std::string store = NewStore(GetParam(), dir, "lab");
  const std::string db = "--db '" + store + "' ";
  ASSERT_EQ(RunArmsig(db + "robot add ur10 --model '" + SourcePath("models/ur10.yaml") + "'")
                .exit_code,
            0);
  const std::string data = DataPath("ur10-ipa/series_C-measurements_random_poses.csv");
  ASSERT_EQ(RunArmsig(db + "import poses '" + data + "' --preset ur-ipa --robot ur10 --out '" +
                      dir.File("c.csv") + "'")
                .exit_code,
            0);
  const auto night = RunArmsig(db +
                               // The parametric figure: the residual map (on by default)
                               // would bring it to 0.39 mm.
                               "recalibrate --robot ur10 --params geometric --select 1773 "
                               "--residual-model off "
                               "--max-validation-mean-mm 0.6 --json '" +
                               dir.File("night.json") + "' --report '" + dir.File("report") + "'");
  ASSERT_EQ(night.exit_code, 0) << night.err << night.out;
  const auto j = nlohmann::json::parse(ReadText(dir.File("night.json")));
  EXPECT_EQ(j["decision"], "stored");
  EXPECT_EQ(j["rank"], 25);
  EXPECT_EQ(j["validation"]["poses"], 1000);
  const double held_out = j["validation"]["mean_mm"];
  EXPECT_GT(held_out, 0.43);
  EXPECT_LT(held_out, 0.46);
  std::cout << "UR10 series C, 1773 fitted, 1000 held out: validation mean " << held_out
            << " mm, max " << j["validation"]["max_mm"] << " mm (nominal "
            << j["nominal"]["mean_mm"] << " mm)\n";

  // The held-out poses, predicted by the stored active set in the measuring frame: the
  // same mean error, from the database's parameters instead of the fit in memory.
  const auto poses = io::ReadPosesCsv(dir.File("c.csv"), 6);
  std::map<std::string, const MeasuredPose*> by_id;
  for (const auto& p : poses) by_id[p.id] = &p;
  db::Database sql(store, db::OpenMode::kReadOnly);
  auto q = sql.connection().Prepare(
      "SELECT pose_label FROM validation_residuals WHERE role = 'validation' ORDER BY id");
  std::string joints = "pose,q1_deg,q2_deg,q3_deg,q4_deg,q5_deg,q6_deg\n";
  std::vector<const MeasuredPose*> held;
  while (q->Step()) {
    std::string label = q->Text(0);
    label = label.substr(label.find(':') + 1);  // "<session>:<label>"
    ASSERT_TRUE(by_id.count(label)) << label;
    held.push_back(by_id[label]);
    joints += label;
    for (int i = 0; i < 6; ++i)
      joints += fmt::format(",{:.15g}", held.back()->joints_rad(i) * 180 / kPi);
    joints += "\n";
  }
  ASSERT_EQ(held.size(), 1000u);
  WriteText(dir.File("held.csv"), joints);
  ASSERT_EQ(RunArmsig(db + "predict --robot ur10 --frame measurement --joints '" +
                      dir.File("held.csv") + "' --out '" + dir.File("pred.csv") + "'")
                .exit_code,
            0);
  const auto p = io::ReadCsvFile(dir.File("pred.csv"));
  ASSERT_EQ(p.rows().size(), 1000u);
  double mean = 0.0;
  for (size_t k = 0; k < held.size(); ++k) {
    const Eigen::Vector3d x(p.Number(p.rows()[k], 1), p.Number(p.rows()[k], 2),
                            p.Number(p.rows()[k], 3));
    mean += (x - held[k]->target_in_world).norm() / held.size();
  }
  EXPECT_NEAR(mean, held_out, 1e-4);

  // Compensate a held-out target and export the signature for a robot program.
  WriteText(dir.File("t.csv"), fmt::format("point,x_mm,y_mm,z_mm\nH1,{},{},{}\n",
                                           p.Text(p.rows()[0], 1), p.Text(p.rows()[0], 2),
                                           p.Text(p.rows()[0], 3)));
  std::string seed;
  for (int i = 0; i < 6; ++i)
    seed += fmt::format("{}{:.6f}", i ? "," : "", held[0]->joints_rad(i) * 180 / kPi);
  const auto compensated =
      RunArmsig(db + "compensate --robot ur10 --frame measurement --seed-deg=" + seed +
                " --targets '" + dir.File("t.csv") + "' --out '" + dir.File("cj.csv") + "'");
  ASSERT_EQ(compensated.exit_code, 0) << compensated.err;
  const auto cj = io::ReadCsvFile(dir.File("cj.csv"));
  // Reached; from this seed the solution's wrist 2 may sit just outside the angles the map's
  // joint curves saw (C has q5 ≥ 0), which the status says rather than hides.
  const std::string status = cj.Text(cj.rows()[0], cj.Column("status"));
  EXPECT_TRUE(status == "ok" || status == "ok_outside_map") << status;
  EXPECT_LT(cj.Number(cj.rows()[0], cj.Column("residual_mm")), 0.01);
  ASSERT_EQ(RunArmsig(db + "export --robot ur10 --format json --frame measurement --out '" +
                      dir.File("sig.json") + "'")
                .exit_code,
            0);
  EXPECT_TRUE(std::filesystem::exists(dir.File("report/index.html")));
}

ARMSIG_BOTH_BACKENDS(LifecycleOnStore);

// A laser tracker's point table (title lines, metres, decimal commas, sigmas) and the
// robot's joint log joined by id into a session of the robot: the session gives back the
// simulated poses, its points carry the table's sigmas; an unmatched point is exit 2 at
// its line and stores nothing.
TEST(LifecycleCommands, ImportTrackerPointsAndJointLogIntoASession) {
  TempDir dir;
  const std::string db = "--db '" + dir.File("lab.db") + "' ";
  ASSERT_EQ(RunArmsig(db + "robot add puma --model '" + SourcePath("models/puma760.yaml") + "'")
                .exit_code,
            0);
  const auto model = Puma();
  std::mt19937 rng(21);
  const auto q = calibration::RandomConfigurations(model, 30, rng);
  calibration::Kinematics kin(model);
  Eigen::Isometry3d base = Eigen::Isometry3d::Identity();
  base.translate(Eigen::Vector3d(2500.0, -900.0, -400.0));
  std::string points = "Leica Tracker export\nUnits: Meter\nPoint\tX\tY\tZ\tsX\tsY\tsZ\n";
  std::string log = "pose;q1_deg;q2_deg;q3_deg;q4_deg;q5_deg;q6_deg\n";
  std::vector<Eigen::Vector3d> truth;
  for (size_t k = 0; k < q.size(); ++k) {
    truth.push_back(kin.Position(base, calibration::PaperTable3Parameters(), q[k].data()));
    auto comma = [](double v, int digits) {
      std::string s = fmt::format("{:.{}f}", v, digits);
      std::replace(s.begin(), s.end(), '.', ',');
      return s;
    };
    points += fmt::format("P{}\t{}\t{}\t{}\t0,000010\t0,000011\t0,000012\n", k + 1,
                          comma(truth[k].x() / 1000, 9), comma(truth[k].y() / 1000, 9),
                          comma(truth[k].z() / 1000, 9));
    log += "P" + std::to_string(k + 1);
    for (int i = 0; i < 6; ++i) log += ";" + comma(q[k](i) * 180 / kPi, 10);
    log += "\n";
  }
  WriteText(dir.File("pts.txt"), points);
  WriteText(dir.File("log.csv"), log);
  const auto imported = RunArmsig(db + "import poses --points '" + dir.File("pts.txt") +
                                  "' --joints '" + dir.File("log.csv") + "' --robot puma --out '" +
                                  dir.File("poses.csv") + "'");
  ASSERT_EQ(imported.exit_code, 0) << imported.err;
  EXPECT_NE(imported.out.find("session 1: 30 poses of robot puma"), std::string::npos)
      << imported.out;
  ASSERT_EQ(RunArmsig(db + "session export 1 --poses '" + dir.File("back.csv") + "'").exit_code, 0);
  const auto back = io::ReadPosesCsv(dir.File("back.csv"), 6);
  ASSERT_EQ(back.size(), 30u);
  for (size_t k = 0; k < back.size(); ++k) {
    EXPECT_EQ(back[k].id, "P" + std::to_string(k + 1));
    EXPECT_LT((back[k].joints_rad - q[k]).cwiseAbs().maxCoeff(), 1e-11);
    EXPECT_LT((back[k].target_in_world - truth[k]).norm(), 1e-5);
  }
  {
    SQLite::Database sql(dir.File("lab.db"), SQLite::OPEN_READONLY);
    EXPECT_NEAR(sql.execAndGet("SELECT avg(sz_mm) FROM points WHERE session_id = 1").getDouble(),
                0.012, 1e-12);
  }
  // Point P31 has no joint reading: exit 2 at its line, nothing stored.
  WriteText(dir.File("pts2.txt"), points + "P31\t1\t2\t3\t0,1\t0,1\t0,1\n");
  const auto unmatched = RunArmsig(db + "import poses --points '" + dir.File("pts2.txt") +
                                   "' --joints '" + dir.File("log.csv") + "' --robot puma");
  EXPECT_EQ(unmatched.exit_code, 2);
  EXPECT_NE(unmatched.err.find("pts2.txt:34: point 'P31' has no joint reading"),
            std::string::npos)
      << unmatched.err;
  // Joining by time needs times.
  const auto no_times = RunArmsig(db + "import poses --points '" + dir.File("pts.txt") +
                                  "' --joints '" + dir.File("log.csv") +
                                  "' --match time --out '" + dir.File("x.csv") + "'");
  EXPECT_EQ(no_times.exit_code, 2);
  EXPECT_NE(no_times.err.find("time column"), std::string::npos) << no_times.err;
  const auto sessions = nlohmann::json::parse(RunArmsig(db + "sessions --json").out);
  EXPECT_EQ(sessions.size(), 1u);
}

}  // namespace armsig::testing

namespace armsig::testing {

// The residual map in the life cycle: stored with the parameter set by
// `recalibrate`, applied by `predict` and `compensate`, carried by the JSON export and
// refused (with a warning) by the URDF, shown in the report.
TEST(LifecycleCommands, ResidualMapIsStoredAppliedExportedAndReported) {
  TempDir dir;
  const std::string db = "--db '" + dir.File("lab.db") + "' ";
  ASSERT_EQ(RunArmsig(db + "robot add ur10 --model '" + SourcePath("models/ur10.yaml") + "'")
                .exit_code,
            0);
  const std::string data = DataPath("ur10-ipa/series_C-measurements_random_poses.csv");
  ASSERT_EQ(RunArmsig(db + "import poses '" + data + "' --preset ur-ipa --robot ur10").exit_code, 0);
  const std::string recal = db + "recalibrate --robot ur10 --select 600 --max-validation-mean-mm 0.8 ";
  const auto off = RunArmsig(recal + "--residual-model off --json '" + dir.File("1.json") + "'");
  ASSERT_EQ(off.exit_code, 0) << off.err;
  const auto on = RunArmsig(recal + "--json '" + dir.File("2.json") + "' --report '" +
                            dir.File("report") + "'");
  ASSERT_EQ(on.exit_code, 0) << on.err;  // another option: another fit, not "up to date"
  const auto j1 = nlohmann::json::parse(ReadText(dir.File("1.json")));
  const auto j2 = nlohmann::json::parse(ReadText(dir.File("2.json")));
  EXPECT_EQ(j2["version"], 2);
  EXPECT_FALSE(j1["residual_model"]["used"].get<bool>());
  ASSERT_TRUE(j2["residual_model"]["used"].get<bool>()) << j2["residual_model"].dump();
  // The same 2,173 held-out configurations (the selection depends on the poses only): the
  // map does not make them worse.
  EXPECT_EQ(j1["validation"]["poses"], j2["validation"]["poses"]);
  EXPECT_LE(j2["validation"]["mean_mm"].get<double>(), j1["validation"]["mean_mm"].get<double>());
  const std::string html = ReadText(dir.File("report/index.html"));
  EXPECT_NE(html.find("<h2>Residual map</h2>"), std::string::npos);
  EXPECT_NE(html.find("with the residual map, validation"), std::string::npos);
  EXPECT_TRUE(std::filesystem::exists(dir.File("report/residual_map.png")));

  // predict with the map's set (active) and with the parametric set: on the measured
  // configurations the map's predictions are closer to what the tracker measured.
  const auto measured = io::ImportPoses(data, io::PoseImportOptions::UrIpa());
  std::string joints = "pose,q1_deg,q2_deg,q3_deg,q4_deg,q5_deg,q6_deg\n";
  for (size_t k = 0; k < measured.size(); k += 7) {
    joints += measured[k].id;
    for (int i = 0; i < 6; ++i)
      joints += fmt::format(",{:.12f}", measured[k].joints_rad(i) * 180 / kPi);
    joints += "\n";
  }
  WriteText(dir.File("j.csv"), joints);
  auto predict_mean = [&](const std::string& out, int* applied) {
    const auto r = RunArmsig(db + "predict --robot ur10 --frame measurement --map-sigma --joints '" +
                             dir.File("j.csv") + "' --out '" + dir.File(out) + "'");
    EXPECT_EQ(r.exit_code, 0) << r.err;
    const auto p = io::ReadCsvFile(dir.File(out));
    double mean = 0.0;
    *applied = 0;
    for (size_t k = 0; k < p.rows().size(); ++k) {
      const Eigen::Vector3d x(p.Number(p.rows()[k], 1), p.Number(p.rows()[k], 2),
                              p.Number(p.rows()[k], 3));
      mean += (x - measured[7 * k].target_in_world).norm() / p.rows().size();
      const bool on = p.Text(p.rows()[k], p.Column("map")) == "applied";
      *applied += on ? 1 : 0;
      // The map's predictive σ when it is applied; nothing without a map.
      const std::string sigma = p.Text(p.rows()[k], p.Column("map_sigma_mm"));
      if (on) {
        EXPECT_GT(std::stod(sigma), 0.0);
      }
    }
    return mean;
  };
  int applied_map = 0, applied_none = 0;
  const double with_map = predict_mean("p2.csv", &applied_map);
  ASSERT_EQ(RunArmsig(db + "activate --robot ur10 --version 1").exit_code, 0);
  const double parametric = predict_mean("p1.csv", &applied_none);
  EXPECT_EQ(applied_none, 0);
  EXPECT_GT(applied_map, 350);  // of 397: the configurations inside the map's support
  EXPECT_LT(with_map, 0.95 * parametric);
  ASSERT_EQ(RunArmsig(db + "activate --robot ur10 --version 2").exit_code, 0);

  // compensate: joints for the map's own predictions; predicted back they land on them
  // (the Newton iteration includes the map).
  const auto p2 = io::ReadCsvFile(dir.File("p2.csv"));
  std::string targets = "point,x_mm,y_mm,z_mm";
  for (int i = 1; i <= 6; ++i) targets += fmt::format(",q{}_deg", i);
  targets += "\n";
  std::string back_joints = "pose,q1_deg,q2_deg,q3_deg,q4_deg,q5_deg,q6_deg\n";
  for (size_t k = 0; k < 6; ++k) {
    targets += fmt::format("T{},{},{},{}", k, p2.Text(p2.rows()[k], 1), p2.Text(p2.rows()[k], 2),
                           p2.Text(p2.rows()[k], 3));
    // The nominal program: the measured joints moved by a few tenths of a degree.
    for (int i = 0; i < 6; ++i)
      targets += fmt::format(",{:.6f}", measured[7 * k].joints_rad(i) * 180 / kPi + 0.3);
    targets += "\n";
  }
  WriteText(dir.File("t.csv"), targets);
  const auto c = RunArmsig(db + "compensate --robot ur10 --frame measurement --targets '" +
                           dir.File("t.csv") + "' --out '" + dir.File("c.csv") + "'");
  ASSERT_EQ(c.exit_code, 0) << c.err;
  const auto cj = io::ReadCsvFile(dir.File("c.csv"));
  for (size_t k = 0; k < 6; ++k) {
    EXPECT_EQ(cj.Text(cj.rows()[k], cj.Column("status")), "ok") << k;
    back_joints += fmt::format("T{}", k);
    for (int i = 1; i <= 6; ++i)
      back_joints += "," + cj.Text(cj.rows()[k], cj.Column(fmt::format("q{}_deg", i)));
    back_joints += "\n";
  }
  WriteText(dir.File("back.csv"), back_joints);
  ASSERT_EQ(RunArmsig(db + "predict --robot ur10 --frame measurement --joints '" +
                      dir.File("back.csv") + "' --out '" + dir.File("pb.csv") + "'")
                .exit_code,
            0);
  const auto pb = io::ReadCsvFile(dir.File("pb.csv"));
  for (size_t k = 0; k < 6; ++k) {
    const Eigen::Vector3d target(p2.Number(p2.rows()[k], 1), p2.Number(p2.rows()[k], 2),
                                 p2.Number(p2.rows()[k], 3));
    const Eigen::Vector3d back(pb.Number(pb.rows()[k], 1), pb.Number(pb.rows()[k], 2),
                               pb.Number(pb.rows()[k], 3));
    EXPECT_LT((back - target).norm(), 0.01) << k;
  }

  // Exports: the JSON carries the map; a URDF cannot, and the warning says so.
  ASSERT_EQ(RunArmsig(db + "export --robot ur10 --format json --out '" + dir.File("s.json") + "'")
                .exit_code,
            0);
  const auto s = nlohmann::json::parse(ReadText(dir.File("s.json")));
  EXPECT_EQ(s["residual_map"]["kind"], "gaussian_kernel_ridge");
  EXPECT_EQ(s["residual_map"]["centres_rad"].size(), 600u);
  const auto urdf =
      RunArmsig(db + "export --robot ur10 --format urdf --out '" + dir.File("r.urdf") + "'");
  EXPECT_EQ(urdf.exit_code, 0) << urdf.err;
  EXPECT_NE(urdf.err.find("residual map"), std::string::npos) << urdf.err;
}

}  // namespace armsig::testing

namespace armsig::testing {

// Issue 38: `activate --version N` was missing from the generated reference and the manual
// page (every option named "version" was taken for the program's own --version flag).
TEST(LifecycleCommands, ActivatesVersionOptionIsInTheReferenceAndTheManualPage) {
  const auto markdown = RunArmsig("generate markdown");
  ASSERT_EQ(markdown.exit_code, 0);
  EXPECT_NE(markdown.out.find("armsig activate --robot NAME --version N"), std::string::npos);
  EXPECT_NE(markdown.out.find("- `--version N` (required) — Version to activate."),
            std::string::npos);
  const auto man = RunArmsig("generate man");
  ASSERT_EQ(man.exit_code, 0);
  const size_t activate = man.out.find(".SS \"armsig activate\"");
  ASSERT_NE(activate, std::string::npos);
  EXPECT_NE(man.out.find(".B \\-\\-version N", activate), std::string::npos)
      << man.out.substr(activate, 300);
}

}  // namespace armsig::testing
