#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <iostream>
#include <nlohmann/json.hpp>
#include <random>

#include "calibration/synthetic.h"
#include "core/units.h"
#include "io/model_yaml.h"
#include "io/poses_csv.h"
#include "test_support.h"

namespace armsig::testing {
namespace {

class CalibrateCommand : public ::testing::Test {
 protected:
  void SetUp() override {
    const auto model = Puma();
    std::mt19937 rng(31);
    Eigen::Isometry3d base = Eigen::Isometry3d::Identity();
    base.translation() << 1800, -2200, 400;
    base.rotate(Eigen::AngleAxisd(-1.2, Eigen::Vector3d::UnitZ()));
    const auto truth = calibration::PaperTable3Parameters();
    poses_ = calibration::SimulatePoses(
        model, base, truth, calibration::RandomConfigurations(model, 160, rng), 0.02, rng);
    holdout_ = calibration::SimulatePoses(
        model, base, truth, calibration::RandomConfigurations(model, 50, rng), 0.02, rng);
    WriteText(dir_.File("poses.csv"), io::FormatPosesCsv(poses_));
    WriteText(dir_.File("holdout.csv"), io::FormatPosesCsv(holdout_));
  }

  std::string Model() const { return "--model '" + SourcePath("models/puma760.yaml") + "' "; }

  TempDir dir_;
  std::vector<MeasuredPose> poses_, holdout_;
};

}  // namespace

TEST_F(CalibrateCommand, FitsSelectsValidatesAndWritesJson) {
  const auto r = RunArmsig("calibrate " + Model() + "--poses '" + dir_.File("poses.csv") +
                           "' --select 80 --json '" + dir_.File("out.json") + "'");
  ASSERT_EQ(r.exit_code, 0) << r.err << r.out;
  EXPECT_NE(r.out.find("alpha_i (1e-3 rad)"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("calibrated, validation"), std::string::npos);
  const auto j = nlohmann::json::parse(ReadText(dir_.File("out.json")));
  EXPECT_EQ(j["rank"], 29);
  EXPECT_EQ(j["poses_used"], 80);
  EXPECT_EQ(j["validation"]["poses"], 80);
  EXPECT_EQ(j["parameters"].size(), 43u);
  EXPECT_EQ(j["parameters"][0]["name"], "a1");
  EXPECT_EQ(j["parameters"][0]["unit"], "mm");
  EXPECT_EQ(j["parameters"][3]["unit"], "rad");
  EXPECT_GT(j["nominal"]["mean_mm"].get<double>(), 1.0);
  EXPECT_LT(j["validation"]["mean_mm"].get<double>(), 0.05);
  EXPECT_EQ(j["selection"]["criterion"], "D-optimal");
  int identified = 0;
  for (const auto& p : j["parameters"]) {
    identified += p["identified"].get<bool>();
    if (!p["identified"].get<bool>()) {
      EXPECT_TRUE(p["sigma"].is_null());
    }
  }
  EXPECT_EQ(identified, 29);
}

TEST_F(CalibrateCommand, ValidatesOnAHoldoutFileAndHonoursParams) {
  const auto r = RunArmsig("calibrate " + Model() + "--poses '" + dir_.File("poses.csv") +
                           "' --validate '" + dir_.File("holdout.csv") +
                           "' --params geometric,h3,h4 --json '" + dir_.File("o.json") + "'");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto j = nlohmann::json::parse(ReadText(dir_.File("o.json")));
  EXPECT_EQ(j["rank"], 27);
  EXPECT_EQ(j["validation"]["poses"], 50);
  EXPECT_FALSE(j["parameters"][39]["identified"].get<bool>());  // h1 not asked for
}

TEST_F(CalibrateCommand, MalformedPosesNameFileLineAndColumnAndWriteNothing) {
  std::string text = io::FormatPosesCsv(poses_);
  // Break line 5 (4th data row): replace its x value with garbage.
  size_t pos = 0;
  for (int line = 1; line < 5; ++line) pos = text.find('\n', pos) + 1;
  const size_t end = text.find('\n', pos);
  std::string row = text.substr(pos, end - pos);
  const size_t comma = row.rfind(',', row.rfind(',') - 1);
  const size_t comma2 = row.rfind(',', comma - 1);
  row = row.substr(0, comma2 + 1) + "12.5.3" + row.substr(comma);
  text.replace(pos, end - pos, row);
  WriteText(dir_.File("bad.csv"), text);
  const auto r = RunArmsig("calibrate " + Model() + "--poses '" + dir_.File("bad.csv") +
                           "' --json '" + dir_.File("bad.json") + "'");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("bad.csv:5:8 (x_mm)"), std::string::npos) << r.err;
  EXPECT_FALSE(std::filesystem::exists(dir_.File("bad.json")));
}

TEST_F(CalibrateCommand, NanIsRejected) {
  WriteText(dir_.File("nan.csv"),
            "pose,q1_deg,q2_deg,q3_deg,q4_deg,q5_deg,q6_deg,x_mm,y_mm,z_mm\n"
            "A,1,2,3,4,5,6,nan,0,0\n");
  const auto r = RunArmsig("calibrate " + Model() + "--poses '" + dir_.File("nan.csv") + "'");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("nan.csv:2:8"), std::string::npos) << r.err;
}

TEST_F(CalibrateCommand, UnknownParameterNameIsAnInputError) {
  const auto r = RunArmsig("calibrate " + Model() + "--poses '" + dir_.File("poses.csv") +
                           "' --params geometric,h7 --json '" + dir_.File("x.json") + "'");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("unknown parameter 'h7'"), std::string::npos) << r.err;
  EXPECT_FALSE(std::filesystem::exists(dir_.File("x.json")));
}

// The PUMA with its target on a machined adapter (tool_mounting: known): calibrate says the
// mounting and what it holds, fits the flange's turn, and refuses a held parameter by name.
TEST_F(CalibrateCommand, AKnownToolMountingFitsTheFlangeTurnAndSaysWhatItHolds) {
  std::string text = ReadText(SourcePath("models/puma760.yaml"));
  const std::string tool = "tool_mm: [0, 0, 0]";
  text.replace(text.find(tool), tool.size(), "tool_mm: [40, 0, 235]\ntool_mounting: known");
  WriteText(dir_.File("known.yaml"), text);
  const calibration::RobotModel model = io::LoadRobotModel(dir_.File("known.yaml"));
  ASSERT_TRUE(model.known_mounting());
  std::mt19937 rng(36);
  Eigen::VectorXd truth = Eigen::VectorXd::Zero(model.num_parameters());
  truth(model.IndexOf("alpha7")) = 0.8e-3;
  truth(model.IndexOf("beta7")) = -0.6e-3;
  truth(model.IndexOf("alpha2")) = 0.3e-3;
  Eigen::Isometry3d base = Eigen::Isometry3d::Identity();
  base.translation() << 1800, -2200, 400;
  const auto poses = calibration::SimulatePoses(
      model, base, truth, calibration::RandomConfigurations(model, 120, rng), 0.01, rng);
  WriteText(dir_.File("known.csv"), io::FormatPosesCsv(poses));
  const std::string command = "calibrate --model '" + dir_.File("known.yaml") + "' --poses '" + dir_.File("known.csv") + "'";
  const auto r = RunArmsig(command + " --params geometric --json '" + dir_.File("known.json") + "'");
  ASSERT_EQ(r.exit_code, 0) << r.err << r.out;
  EXPECT_NE(r.out.find("tool_mounting: known"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("its turn about the lever arm is not identifiable; held at zero: gamma6 a7 b7 c7"),
            std::string::npos)
      << r.out;
  const auto j = nlohmann::json::parse(ReadText(dir_.File("known.json")));
  EXPECT_EQ(j["tool_mounting"], "known");
  EXPECT_EQ(j["tool"]["held"], (nlohmann::json{"gamma6", "a7", "b7", "c7"}));
  EXPECT_EQ(j["parameters"].size(), 45u);
  EXPECT_EQ(j["parameters"][39]["name"], "alpha7");
  EXPECT_EQ(j["parameters"][39]["unit"], "rad");
  EXPECT_TRUE(j["parameters"][39]["identified"].get<bool>());
  EXPECT_NEAR(j["parameters"][39]["value"].get<double>(), 0.8e-3, 3 * j["parameters"][39]["sigma"].get<double>());
  EXPECT_FALSE(j["parameters"][36]["identified"].get<bool>());  // a7

  const auto held = RunArmsig(command + " --params geometric,a7");
  EXPECT_EQ(held.exit_code, 2);
  EXPECT_NE(held.err.find("'a7' is held at zero with 'tool_mounting: known'"), std::string::npos) << held.err;
  // A fitted mounting says so too.
  const auto fitted = RunArmsig("calibrate " + Model() + "--poses '" + dir_.File("poses.csv") + "'");
  EXPECT_NE(fitted.out.find("tool_mounting: fitted"), std::string::npos) << fitted.out;
}

TEST_F(CalibrateCommand, TooFewPosesIsAnInputError) {
  std::vector<MeasuredPose> few(poses_.begin(), poses_.begin() + 8);
  WriteText(dir_.File("few.csv"), io::FormatPosesCsv(few));
  const auto r = RunArmsig("calibrate " + Model() + "--poses '" + dir_.File("few.csv") +
                           "' --json '" + dir_.File("few.json") + "'");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("24 equations"), std::string::npos) << r.err;
  EXPECT_FALSE(std::filesystem::exists(dir_.File("few.json")));
}

TEST_F(CalibrateCommand, MalformedModelNamesItsLine) {
  WriteText(dir_.File("m.yaml"), "name: x\nlinks:\n  - [[1,0,0,0],[0,1,0,0]]\n");
  const auto r = RunArmsig("calibrate --model '" + dir_.File("m.yaml") + "' --poses '" +
                           dir_.File("poses.csv") + "'");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("m.yaml:3"), std::string::npos) << r.err;
}

TEST_F(CalibrateCommand, MissingFileIsAnInputError) {
  const auto r = RunArmsig("calibrate " + Model() + "--poses /nonexistent/poses.csv");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("/nonexistent/poses.csv"), std::string::npos);
}

}  // namespace armsig::testing

namespace armsig::testing {

// The issue-13 split of the real UR10 (series C) through `calibrate`: terms chosen by
// --params auto and the residual map, held out on the last 1,000 poses of the fixed
// permutation. The map is used because cross-validation on the fit poses says it helps,
// and the held-out error (never seen by the fit, the terms or the hyperparameters) agrees.
TEST(CalibrateResidualMap, RealUr10SplitHeldOutThroughTheCommand) {
  TempDir dir;
  const auto poses =
      io::ImportPoses(DataPath("ur10-ipa/series_C-measurements_random_poses.csv"),
                      io::PoseImportOptions::UrIpa());
  std::ifstream file(DataPath("ur10-ipa-split/series_C-permutation.txt"));
  std::vector<int> permutation;
  for (int i; file >> i;) permutation.push_back(i);
  ASSERT_EQ(permutation.size(), poses.size());
  std::vector<MeasuredPose> fit, held_out;
  for (size_t k = 0; k < poses.size(); ++k)
    (k < poses.size() - 1000 ? fit : held_out).push_back(poses[permutation[k]]);
  WriteText(dir.File("fit.csv"), io::FormatPosesCsv(fit));
  WriteText(dir.File("held.csv"), io::FormatPosesCsv(held_out));
  const std::string args = "calibrate --model '" + SourcePath("models/ur10.yaml") +
                           "' --poses '" + dir.File("fit.csv") + "' --validate '" +
                           dir.File("held.csv") + "' --params auto ";
  const auto r = RunArmsig(args + "--json '" + dir.File("auto.json") + "'");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("with map, validation"), std::string::npos) << r.out;
  const auto j = nlohmann::json::parse(ReadText(dir.File("auto.json")));
  const auto& m = j["residual_model"];
  EXPECT_TRUE(m["used"].get<bool>());
  EXPECT_EQ(m["kind"], "gaussian_kernel_ridge");
  EXPECT_LT(m["cv_mean_mm_with_map"].get<double>(),
            0.98 * m["cv_mean_mm_parametric"].get<double>());
  EXPECT_GT(m["hyperparameters"]["length_scale"].get<double>(), 0.0);
  EXPECT_EQ(m["hyperparameters"]["centres"], 1773);
  // `validation` has the map applied; the parametric figure is kept beside it.
  EXPECT_TRUE(j["validation"]["map_applied"].get<bool>());
  const double with_map = j["validation"]["mean_mm"].get<double>();
  const double parametric = j["validation"]["parametric"]["mean_mm"].get<double>();
  EXPECT_EQ(j["validation"]["poses"], 1000);
  EXPECT_LT(parametric, 0.46);   // the geometric floor of this robot, 0.449 mm
  EXPECT_LE(with_map, 0.37);     // the figure to reach
  EXPECT_LT(with_map, 0.8 * parametric);
  // One predictive σ per held-out pose; the few outside the map's support are named.
  EXPECT_EQ(j["validation"]["map_sigma_mm"].size(), 1000u);
  EXPECT_LT(j["validation"]["map_extrapolated"].size(), 20u);

  // The files carry the T-Mac's orientations: the held-out orientation error is reported.
  EXPECT_EQ(j["validation"]["orientation"]["poses"], 1000);
  const double held_out_deg = j["validation"]["orientation"]["mean_rad"].get<double>() * 180 / kPi;
  EXPECT_GT(held_out_deg, 0.03);
  EXPECT_LT(held_out_deg, 0.07);
  std::cout << "UR10 split through calibrate --params auto with 6-DoF data: parametric "
            << parametric << " mm, with map " << with_map << " mm, orientation " << held_out_deg
            << " deg held out\n";
  // --orientation off fits the positions alone: the figures of the same poses without their
  // orientations, to the last digit.
  std::vector<MeasuredPose> fit_positions = fit, held_positions = held_out;
  for (auto& p : fit_positions) p.orientation.reset();
  for (auto& p : held_positions) p.orientation.reset();
  WriteText(dir.File("fit-xyz.csv"), io::FormatPosesCsv(fit_positions));
  WriteText(dir.File("held-xyz.csv"), io::FormatPosesCsv(held_positions));
  const auto ignored = RunArmsig(args + "--orientation off --json '" + dir.File("ignored.json") + "'");
  ASSERT_EQ(ignored.exit_code, 0) << ignored.err;
  const auto plain = RunArmsig("calibrate --model '" + SourcePath("models/ur10.yaml") +
                               "' --poses '" + dir.File("fit-xyz.csv") + "' --validate '" +
                               dir.File("held-xyz.csv") + "' --params auto --json '" +
                               dir.File("plain.json") + "'");
  ASSERT_EQ(plain.exit_code, 0) << plain.err;
  const auto ji = nlohmann::json::parse(ReadText(dir.File("ignored.json")));
  const auto jp = nlohmann::json::parse(ReadText(dir.File("plain.json")));
  EXPECT_EQ(ji["validation"]["mean_mm"], jp["validation"]["mean_mm"]);
  EXPECT_EQ(ji["parameters"], jp["parameters"]);
  EXPECT_FALSE(ji["fit"].contains("orientation"));
  EXPECT_FALSE(jp["validation"].contains("orientation"));
  std::cout << "the same, positions only: with map " << jp["validation"]["mean_mm"] << " mm\n";

  const auto off = RunArmsig(args + "--residual-model off --json '" + dir.File("off.json") + "'");
  ASSERT_EQ(off.exit_code, 0) << off.err;
  const auto o = nlohmann::json::parse(ReadText(dir.File("off.json")));
  EXPECT_FALSE(o["residual_model"]["used"].get<bool>());
  EXPECT_FALSE(o["validation"]["map_applied"].get<bool>());
  EXPECT_NEAR(o["validation"]["mean_mm"].get<double>(), parametric, 1e-9);
  EXPECT_EQ(RunArmsig(args + "--residual-model maybe").exit_code, 2);
}

}  // namespace armsig::testing
