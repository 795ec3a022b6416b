// The recalibration report: every figure is a valid PNG (decoded with OpenCV, the same
// pixels as the file beside the page), and a real browser (headless Chromium, no
// JavaScript in the page) renders each of them: the screenshot contains every figure.
#include "workflows/report.h"

#include <gtest/gtest.h>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <random>

#include "calibration/simulation.h"
#include "test_support.h"
#include "workflows/calibration_run.h"

namespace armsig::testing {
namespace {

// RFC 4648 base64, written here independently of the product's encoder.
std::vector<uchar> DecodeBase64(const std::string& text) {
  auto value = [](char c) -> int {
    if (c >= 'A' && c <= 'Z') return c - 'A';
    if (c >= 'a' && c <= 'z') return c - 'a' + 26;
    if (c >= '0' && c <= '9') return c - '0' + 52;
    if (c == '+') return 62;
    if (c == '/') return 63;
    return -1;
  };
  std::vector<uchar> out;
  int bits = 0, buffer = 0;
  for (char c : text) {
    const int v = value(c);
    if (v < 0) continue;  // '=' padding
    buffer = (buffer << 6) | v;
    bits += 6;
    if (bits >= 8) {
      bits -= 8;
      out.push_back(static_cast<uchar>((buffer >> bits) & 0xff));
    }
  }
  return out;
}

struct Fixture {
  calibration::RobotModel model = Puma();
  std::vector<MeasuredPose> poses;
  workflows::CalibrationRun run;
  workflows::ReportInput input;

  Fixture() {
    std::mt19937 rng(7);
    poses = calibration::SimulatePoses(model, Eigen::Isometry3d::Identity(),
                                       calibration::PaperTable3Parameters(),
                                       calibration::RandomConfigurations(model, 120, rng), 0.02,
                                       rng);
    workflows::CalibrateSettings settings;
    settings.select = 60;
    run = workflows::RunCalibration(model, poses, {}, settings);
    input.robot = "puma <&> \"one\"";
    input.version = 2;
    input.decision = "stored as version 2 (active)";
    input.gates = {"validation mean: 0.0200 mm (limit 0.5000 mm) passed"};
    input.model = &model;
    input.run = &run;
    for (const auto& p : poses) {
      if (std::find(run.validation_pose_ids.begin(), run.validation_pose_ids.end(), p.id) !=
          run.validation_pose_ids.end())
        input.validation.push_back(p);
    }
    input.history = {{1, "2026-11-01T02:00:00Z", 0.03}, {2, "2026-11-02T02:00:00Z", 0.02}};
  }
};

}  // namespace

TEST(Report, EmbedsEveryFigureAsAValidPngIdenticalToItsFile) {
  Fixture f;
  TempDir dir;
  const std::string page = workflows::WriteReport(dir.File("report"), f.input);
  const std::string html = ReadText(page);
  // Names from the database are escaped, never markup.
  EXPECT_NE(html.find("puma &lt;&amp;&gt; &quot;one&quot;"), std::string::npos);
  EXPECT_EQ(html.find("<script"), std::string::npos) << "the page needs no JavaScript";
  // (std::regex recurses per character: no use on megabytes of base64.)
  const std::string prefix = "src=\"data:image/png;base64,";
  int figures = 0;
  for (size_t at = html.find(prefix); at != std::string::npos; at = html.find(prefix, at + 1)) {
    const size_t begin = at + prefix.size(), end = html.find('"', begin);
    ASSERT_NE(end, std::string::npos);
    const cv::Mat decoded =
        cv::imdecode(DecodeBase64(html.substr(begin, end - begin)), cv::IMREAD_COLOR);
    ASSERT_FALSE(decoded.empty()) << "figure " << figures << " is not a PNG";
    EXPECT_EQ(decoded.cols, 900);
    EXPECT_GT(decoded.rows, 200);
    cv::Scalar mean, stddev;
    cv::meanStdDev(decoded, mean, stddev);
    EXPECT_GT(stddev[0] + stddev[1] + stddev[2], 10.0) << "figure " << figures << " is blank";
    // The same pixels as one of the PNG files beside the page.
    bool same_as_a_file = false;
    for (const char* file : {"errors.png", "histogram.png", "vectors.png", "drift.png"}) {
      const cv::Mat on_disk = cv::imread(dir.File(std::string("report/") + file));
      same_as_a_file |= !on_disk.empty() && on_disk.size() == decoded.size() &&
                        cv::norm(on_disk, decoded, cv::NORM_INF) == 0.0;
    }
    EXPECT_TRUE(same_as_a_file) << "figure " << figures;
    ++figures;
  }
  EXPECT_EQ(figures, 4);  // errors, histogram, vectors, drift (history)
}

TEST(Report, HeadlessChromiumRendersEveryFigure) {
  if (std::system("command -v chromium > /dev/null 2>&1") != 0) {
    GTEST_SKIP() << "chromium is not installed (scripts/setup.sh installs it)";
  }
  Fixture f;
  TempDir dir;
  const std::string page = workflows::WriteReport(dir.File("report"), f.input);
  const std::string shot = dir.File("shot.png");
  const std::string chromium =
      "timeout 120 chromium --headless --no-sandbox --disable-gpu --disable-quic --no-first-run "
      "--disable-background-networking --disable-component-update --disable-sync "
      "--hide-scrollbars --force-device-scale-factor=1 --window-size=1200,9000 --user-data-dir='" +
      dir.File("profile") + "' --screenshot='" + shot + "' 'file://" + page + "' >/dev/null 2>&1";
  ASSERT_EQ(std::system(chromium.c_str()), 0);
  const cv::Mat screen = cv::imread(shot, cv::IMREAD_COLOR);
  ASSERT_FALSE(screen.empty());
  // Each figure, as a template, is found in the rendered page at 1:1 scale.
  for (const char* file : {"errors.png", "histogram.png", "vectors.png", "drift.png"}) {
    const cv::Mat figure = cv::imread(dir.File(std::string("report/") + file), cv::IMREAD_COLOR);
    ASSERT_FALSE(figure.empty()) << file;
    ASSERT_LE(figure.rows, screen.rows);
    cv::Mat score;
    cv::matchTemplate(screen, figure, score, cv::TM_CCOEFF_NORMED);
    double best = 0.0;
    cv::minMaxLoc(score, nullptr, &best);
    EXPECT_GT(best, 0.97) << file << " is not visible in the rendered page";
  }
}

}  // namespace armsig::testing
