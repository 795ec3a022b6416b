// `armsig compensate --program` through the program, as a lab runs it: its exit codes
// (SPEC: 2 a file that is not the language, named by file, line and column; 3 a target
// refused and nothing written) and the check on the real UR10.
//
// The real check: series D of the UR10 laser-tracker data (tests/data/ur10-ipa, 632 goals,
// the centres and corners of 70 ISO 9283 cubes, each commanded as a TCP pose and measured
// once) is the program the robot ran. Written as URScript, compensated with the set the
// nightly job fits on series C (another day's random poses), where would the robot land?
// The robot is not here, but it was measured at the joints it reached for each goal (q_i,
// landing m_i): sent to the compensated joints instead it lands at m_i + J·Δq (J the
// nominal Jacobian at q_i, Δq the compensation's change of the controller's joints; the
// second-order rest is |Δq|²·1 m ≈ µm for the milliradian changes here). Before and after
// are the goals' distances from the landings after one rigid frame fit, as `iso9283
// evaluate --align` computes them.
#include <fmt/format.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <iostream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "calibration/iso9283_figures.h"
#include "calibration/model.h"
#include "calibration/validity.h"
#include "core/units.h"
#include "test_support.h"

namespace armsig {
namespace {

using testing::DataPath;
using testing::ReadText;
using testing::RunArmsig;
using testing::SourcePath;
using testing::TempDir;
using testing::WriteText;

// One row of series D: the goal's position (mm, UR's base frame), the joints the robot reached
// (rad) and the tracker's measurement of the probe there (mm, the tracker's frame). Read
// here on its own (';' fields, decimal comma), not through the importer under test.
struct Goal {
  Eigen::Vector3d position_mm, measured_mm;
  Eigen::VectorXd joints_rad = Eigen::VectorXd::Zero(6);
};

std::vector<Goal> SeriesD() {
  std::istringstream in(ReadText(DataPath("ur10-ipa/series_D-measurements_iso_cubes.csv")));
  std::string line;
  std::getline(in, line);  // the header
  std::vector<Goal> out;
  while (std::getline(in, line)) {
    if (line.empty() || line == "\r") continue;
    std::vector<double> v;
    std::stringstream fields(line);
    for (std::string f; std::getline(fields, f, ';');) {
      std::replace(f.begin(), f.end(), ',', '.');
      v.push_back(std::stod(f));
    }
    EXPECT_GE(v.size(), 19u);
    Goal g;
    g.position_mm = Eigen::Vector3d(v[1], v[2], v[3]) * 1000.0;
    for (int i = 0; i < 6; ++i) g.joints_rad(i) = v[7 + i];
    g.measured_mm = Eigen::Vector3d(v[14], v[16], v[18]);
    out.push_back(g);
  }
  return out;
}

// A pose as URScript writes it: metres and a rotation vector.
std::string UrPose(const Eigen::Isometry3d& pose) {
  const Eigen::AngleAxisd aa(pose.linear());
  const Eigen::Vector3d v = aa.angle() * aa.axis();
  const Eigen::Vector3d x = pose.translation() / 1000.0;
  return fmt::format("p[{:.7f}, {:.7f}, {:.7f}, {:.7f}, {:.7f}, {:.7f}]", x.x(), x.y(), x.z(), v.x(), v.y(), v.z());
}

double Mean(const std::vector<double>& v) {
  double s = 0.0;
  for (double x : v) s += x / static_cast<double>(v.size());
  return s;
}

// What it shows (the figures printed): series D lies outside what series C supports (joint
// 1 turns through a range C never visits, the elbow and wrist elsewhere), so every target is
// refused and nothing is written; forced with --allow-outside, the compensated program would
// not land closer than the original (its held-out σ does not cover another day's set-up
// there either). The refusal is what keeps the robot from being made worse.
TEST(ProgramCommands, RealUr10SeriesDProgramOutsideTheSeriesCSupportIsRefused) {
  TempDir dir;
  const std::string db = "--db '" + dir.File("lab.db") + "' ";
  ASSERT_EQ(RunArmsig(db + "robot add ur10 --model '" + SourcePath("models/ur10.yaml") + "'").exit_code, 0);
  ASSERT_EQ(RunArmsig(db + "import poses '" + DataPath("ur10-ipa/series_C-measurements_random_poses.csv") +
                      "' --preset ur-ipa --robot ur10")
                .exit_code,
            0);
  const auto night = RunArmsig(db + "recalibrate --robot ur10");
  ASSERT_EQ(night.exit_code, 0) << night.err << night.out;

  std::vector<Goal> goals = SeriesD();
  ASSERT_EQ(goals.size(), 632u);
  const calibration::RobotModel model = testing::Ur10();
  calibration::Kinematics kin(model);
  const Eigen::VectorXd zero = Eigen::VectorXd::Zero(model.num_parameters());
  // The probe is the TCP (the goals are its positions), on the flange's axis. The goals are
  // in UR's base frame, turned half a turn about z from the DH base the model and the
  // controller's inverse use. Their orientations are not the probe's as the robot reached
  // them (the wrist lands up to 0.02 rad from where they put it): each target's orientation
  // is the one the controller's model gives the joints the robot reached, so that it takes
  // the same branch.
  std::string text = "def series_d():\n  set_tcp(p[0, 0, 0.109, 0, 0, 0])\n  movej([";
  for (int i = 0; i < 6; ++i) text += fmt::format("{}{:.6f}", i ? ", " : "", goals[0].joints_rad(i));
  text += "])\n";
  const int first_goal_line = 4;
  const int head_goals = 20;
  std::string head;  // the program's first lines and its first 20 goals
  const Eigen::Matrix3d half_turn = Eigen::Vector3d(-1.0, -1.0, 1.0).asDiagonal();
  for (auto& g : goals) {
    g.position_mm = half_turn * g.position_mm;
    Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
    kin.Position(Eigen::Isometry3d::Identity(), zero, g.joints_rad.data());
    pose.linear() = kin.LastRotation();
    pose.translation() = g.position_mm;
    if (&g - goals.data() == head_goals) head = text + "end\n";
    text += "  movel(" + UrPose(pose) + ", a=1.2, v=0.25)\n";
  }
  text += "end\n";
  WriteText(dir.File("series_d.script"), text);
  WriteText(dir.File("series_d_head.script"), head);
  auto compensate = [&](const std::string& program, const std::string& report) {
    return db + "compensate --robot ur10 --program '" + dir.File(program) + "' --out '" +
           dir.File("compensated.script") + "' --json '" + dir.File(report) + "'";
  };

  // The whole program, forced with --allow-outside: every target's compensation and status.
  const auto all = RunArmsig(compensate("series_d.script", "report.json") + " --allow-outside");
  ASSERT_EQ(all.exit_code, 0) << all.err << all.out;
  const auto report = nlohmann::json::parse(ReadText(dir.File("report.json")));
  const int refused = report["refused"].get<int>();
  std::filesystem::remove(dir.File("compensated.script"));
  // Without --allow-outside (on its first goals: the same lines from the same start, so the
  // same statuses; the whole program again costs a minute under the sanitizers): targets
  // beyond what series C supports are refused, exit 3, and nothing is written.
  const auto strict = RunArmsig(compensate("series_d_head.script", "head.json"));
  const auto strict_report = nlohmann::json::parse(ReadText(dir.File("head.json")));
  EXPECT_EQ(strict.exit_code, 3) << strict.err;
  EXPECT_FALSE(std::filesystem::exists(dir.File("compensated.script")));
  EXPECT_EQ(strict_report["refused"].get<int>(), 1 + head_goals);
  ASSERT_EQ(strict_report["targets"].size(), static_cast<std::size_t>(1 + head_goals));
  for (int k = 0; k < 1 + head_goals; ++k) {
    const auto& a = strict_report["targets"][static_cast<std::size_t>(k)];
    const auto& b = report["targets"][static_cast<std::size_t>(k)];
    EXPECT_EQ(a["line"], b["line"]);
    EXPECT_EQ(a["status"], b["status"]) << "line " << a["line"];
    EXPECT_EQ(a["compensated_joints_rad"], b["compensated_joints_rad"]) << "line " << a["line"];
  }

  // The targets the signed robot reaches (the others are refused as out of reach, named).
  std::vector<Eigen::Vector3d> commanded, measured, shift;
  std::vector<bool> inside;
  std::vector<double> sigma;
  int unreached = 0, other_branch = 0;
  double worst_nominal_rad = 0.0;
  for (const auto& t : report["targets"]) {
    const int k = t["line"].get<int>() - first_goal_line;
    if (k < 0) continue;  // the starting movej
    ASSERT_LT(k, static_cast<int>(goals.size()));
    if (t["compensated_joints_rad"].size() != 6u) {
      EXPECT_EQ(t["status"], "out_of_reach") << t.dump();
      ++unreached;
      continue;
    }
    Eigen::VectorXd qc(6), qn(6);
    for (int i = 0; i < 6; ++i) {
      qc(i) = t["compensated_joints_rad"][i].get<double>();
      qn(i) = t["nominal_joints_rad"][i].get<double>();
    }
    const Goal& g = goals[static_cast<std::size_t>(k)];
    // The controller's model's solution is the robot's own but for its factory calibration
    // (milliradians): the real controller reaches a pose at qn + (q_i − qn), and the
    // compensated one at qc + (q_i − qn), so the robot lands at m_i + J·(qc − qn). Where the
    // nearest solution is another branch than the one the robot took (a wrist flipped), the
    // landing there is not known: counted and left out.
    double off = 0.0;
    for (int i = 0; i < 6; ++i) off = std::max(off, std::abs(std::remainder(qn(i) - g.joints_rad(i), 2 * kPi)));
    if (off > 0.01) {
      ++other_branch;
      continue;
    }
    worst_nominal_rad = std::max(worst_nominal_rad, off);
    kin.Position(Eigen::Isometry3d::Identity(), zero, g.joints_rad.data());
    commanded.push_back(g.position_mm);
    measured.push_back(g.measured_mm);
    shift.push_back(kin.JointJacobian() * (qc - qn));
    inside.push_back(t["inside_support"].get<bool>());
    sigma.push_back(t["sigma_mm"].is_number() ? t["sigma_mm"].get<double>() : NAN);
  }
  ASSERT_EQ(commanded.size() + static_cast<std::size_t>(unreached + other_branch), goals.size());
  ASSERT_GE(commanded.size(), 200u);
  EXPECT_LT(worst_nominal_rad, 0.01);
  // The tracker's frame into the robot's, fitted once on the program as it ran.
  const auto frame = calibration::iso9283::AlignRigidly(measured, commanded);
  ASSERT_TRUE(frame);
  std::vector<Eigen::Vector3d> landed;
  for (std::size_t k = 0; k < measured.size(); ++k)
    landed.push_back(frame->commanded_from_attained * measured[k] + shift[k]);
  const auto after = calibration::iso9283::AlignRigidly(landed, commanded);
  ASSERT_TRUE(after);
  std::vector<double> in_before, in_after, out_before, out_after;
  int covered = 0, with_sigma = 0;
  for (std::size_t k = 0; k < commanded.size(); ++k) {
    (inside[k] ? in_before : out_before).push_back(frame->residual_mm[k]);
    (inside[k] ? in_after : out_after).push_back(after->residual_mm[k]);
    if (std::isfinite(sigma[k])) {
      ++with_sigma;
      covered += after->residual_mm[k] <= calibration::kCoverageRadius * sigma[k];
    }
  }
  const double before_mean = Mean(frame->residual_mm), after_mean = Mean(after->residual_mm);
  std::cout << fmt::format(
      "UR10 series D program (632 goals) compensated with the series C set: {} refused without "
      "--allow-outside; {} out of reach of the signed robot, {} on another branch than the robot took; the other {}: before {:.3f} mm mean, after {:.3f} mm; "
      "inside the set's support {} ({:.3f} -> {:.3f} mm), outside {} ({:.3f} -> {:.3f} mm); {:.1f} % within "
      "{:.2f} sigma_mm; controller joints within {:.2e} rad of the recorded\n",
      refused, unreached, other_branch, commanded.size(), before_mean, after_mean, in_after.size(), Mean(in_before),
      Mean(in_after), out_after.size(), Mean(out_before), Mean(out_after),
      with_sigma ? 100.0 * covered / with_sigma : NAN, calibration::kCoverageRadius, worst_nominal_rad);
  // Every target refused without --allow-outside (633: the starting joints and the 632
  // goals), none inside the support; the figures forced out of it are printed, not promised.
  EXPECT_EQ(refused, 633);
  EXPECT_TRUE(in_after.empty());
  EXPECT_EQ(with_sigma, static_cast<int>(commanded.size()));  // every compensated target has its σ
}

// A file that is not URScript: exit 2, the file, line and column named, nothing written.
TEST(ProgramCommands, MalformedProgramsAreNamedByFileLineAndColumn) {
  TempDir dir;
  const std::string db = "--db '" + dir.File("lab.db") + "' ";
  struct Case {
    const char* name;
    const char* text;
    const char* where;
  };
  // An unterminated string at line 2, column 11; a block closed by ENDMODULE at 4:1; an
  // unterminated string at 2:9.
  const Case cases[] = {
      {"bad.script", "def f():\n  textmsg(\"never ends)\nend\n", "bad.script:2:11: "},
      {"bad.mod", "MODULE m\n  PROC main()\n    MoveL p10, v100, fine, tool0;\nENDMODULE\n", "bad.mod:4:1: "},
      {"bad.src", "DEF bad()\n  MSG = \"never ends\nEND\n", "bad.src:2:9: "},
  };
  ASSERT_EQ(RunArmsig(db + "robot add ur10 --model '" + SourcePath("models/ur10.yaml") + "'").exit_code, 0);
  for (const Case& c : cases) {
    WriteText(dir.File(c.name), c.text);
    const std::string out = dir.File(std::string("out") + std::filesystem::path(c.name).extension().string());
    const auto r = RunArmsig(db + "compensate --robot ur10 --program '" + dir.File(c.name) + "' --out '" + out + "'");
    EXPECT_EQ(r.exit_code, 2) << c.name << ": " << r.err;
    EXPECT_NE(r.err.find(c.where), std::string::npos) << r.err;
    EXPECT_FALSE(std::filesystem::exists(out)) << c.name;
  }
}

}  // namespace
}  // namespace armsig
