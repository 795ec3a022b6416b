// Names from the model file and the database (robot, h-term names, sessions,
// notes, instruments) reach index.html only escaped, and the report's files are written
// without following a symlink planted at a temporary name.
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>

#include <filesystem>
#include <random>

#include "calibration/synthetic.h"
#include "io/model_yaml.h"
#include "test_support.h"
#include "workflows/calibration_run.h"
#include "report/html.h"
#include "report/report.h"

namespace armsig::testing {
namespace {

const std::string kScript = "<img src=x onerror=alert(1)>";

struct HostileReport {
  calibration::RobotModel model = io::LoadRobotModel(DataPath("faults/model-term-script.yaml"));
  std::vector<MeasuredPose> poses;
  workflows::CalibrationRun run;
  report::ReportInput input;

  HostileReport() {
    std::mt19937 rng(3);
    Eigen::VectorXd truth = Eigen::VectorXd::Zero(model.num_parameters());
    truth(model.num_geometric()) = 2e-4;  // the hostile h-term, so that it is identified
    poses =
        calibration::SimulatePoses(model, Eigen::Isometry3d::Identity(), truth,
                                   calibration::RandomConfigurations(model, 80, rng), 0.02, rng);
    workflows::CalibrateSettings settings;
    settings.select = 50;
    run = workflows::RunCalibration(model, poses, {}, settings);
    input.robot = kScript;
    input.version = 2;
    input.decision = "stored " + kScript;
    input.gates = {kScript};
    input.model = &model;
    input.run = &run;
    for (const auto& p : poses) {
      if (std::find(run.validation_pose_ids.begin(), run.validation_pose_ids.end(), p.id) !=
          run.validation_pose_ids.end())
        input.validation.push_back(p);
    }
    input.history = {{1, kScript, 0.03, kScript, false}};
    input.previous_version = 1;
    input.previous_params_spec = kScript;
    input.changes_note = kScript;
    input.sources.sessions = {
        {4, kScript, kScript, kScript, "</td><script>alert(2)</script>", 40, 40}};
    input.sources.instruments = {{kScript, kScript, {4}}};
    input.sources.setups = {{4, kScript, 1.0, 9, kScript}};
  }
};

TEST(ReportEscaping, NamesFromTheModelAndTheDatabaseAreEscaped) {
  HostileReport f;
  // The hostile term is a parameter of the fit: its name is on the page.
  const auto names = f.model.ParameterNames();
  ASSERT_NE(std::find(names.begin(), names.end(), kScript), names.end());
  TempDir dir;
  const std::string html = ReadText(report::WriteReport(dir.File("report"), f.input));
  EXPECT_EQ(html.find("<img src=x"), std::string::npos);
  EXPECT_EQ(html.find("<script"), std::string::npos);
  EXPECT_NE(html.find("&lt;img src=x onerror=alert(1)&gt;"), std::string::npos);
  // Every <img on the page is one of the report's own figures:
  // <img alt="TITLE" src="data:image/png;base64,BASE64"> (checked by hand: std::regex
  // recurses per character and overflows the stack on a figure's base64).
  int images = 0;
  for (size_t at = html.find("<img"); at != std::string::npos; at = html.find("<img", at + 1)) {
    ++images;
    const std::string head = "<img alt=\"";
    ASSERT_EQ(html.compare(at, head.size(), head), 0) << html.substr(at, 80);
    const size_t alt_end = html.find('"', at + head.size());
    const std::string alt = html.substr(at + head.size(), alt_end - at - head.size());
    EXPECT_EQ(alt.find_first_of("<>"), std::string::npos) << alt;
    const std::string src = "\" src=\"data:image/png;base64,";
    ASSERT_EQ(html.compare(alt_end, src.size(), src), 0) << html.substr(alt_end, 80);
    const size_t data = alt_end + src.size();
    const size_t data_end = html.find_first_not_of(
        "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/=", data);
    EXPECT_EQ(html.compare(data_end, 2, "\">"), 0) << html.substr(data_end, 40);
  }
  EXPECT_GT(images, 0);
}

TEST(ReportEscaping, HtmlTextIsEscapedUnlessMarkedAsMarkup) {
  using report::Html;
  using report::HtmlFormat;
  const std::string name = "a<b>&\"c'";
  EXPECT_EQ(HtmlFormat("<td>{}</td>", name).str(), "<td>a&lt;b&gt;&amp;&quot;c&#39;</td>");
  EXPECT_EQ(HtmlFormat("<td>{}</td>", Html("<b>x</b>")).str(), "<td><b>x</b></td>");
  EXPECT_EQ(HtmlFormat("{:.2f} {}", 1.5, 3).str(), "1.50 3");
  EXPECT_EQ((Html("<p>") + Html::Text(name) + "</p>").str(), "<p>a&lt;b&gt;&amp;&quot;c&#39;</p>");
}

TEST(ReportEscaping, PlantedSymlinksAtTemporaryNamesAreNotFollowed) {
  HostileReport f;
  TempDir dir;
  const std::string report = dir.File("report");
  std::filesystem::create_directories(report);
  const std::string victim = dir.File("victim.txt");
  WriteText(victim, "precious\n");
  // The old predictable names (NAME.tmp.<pid>, for this and nearby pids) and other
  // plausible ones, for the page and for a figure.
  const pid_t pid = ::getpid();
  for (const std::string file : {"index.html", "errors.png"}) {
    for (pid_t p = pid - 2; p <= pid + 2; ++p) {
      std::filesystem::create_symlink(victim, report + "/" + file + ".tmp." + std::to_string(p));
    }
    std::filesystem::create_symlink(victim, report + "/" + file + ".tmp");
    std::filesystem::create_symlink(victim, report + "/" + file + "~");
  }
  report::WriteReport(report, f.input);
  EXPECT_EQ(ReadText(victim), "precious\n");
  EXPECT_TRUE(std::filesystem::is_regular_file(report + "/index.html"));
  EXPECT_FALSE(std::filesystem::is_symlink(report + "/index.html"));
  // No temporary file is left behind: only the page, the figures and the planted links.
  for (const auto& entry : std::filesystem::directory_iterator(report)) {
    const std::string name = entry.path().filename().string();
    if (std::filesystem::is_symlink(entry.symlink_status())) continue;
    EXPECT_TRUE(name == "index.html" || name.ends_with(".png")) << name;
  }
}

}  // namespace
}  // namespace armsig::testing
