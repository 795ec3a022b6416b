// The recalibration report: every figure is a valid PNG (decoded with OpenCV, the same
// pixels as the file beside the page), and a real browser (headless Chromium, no
// JavaScript in the page) renders each of them: the screenshot contains every figure.
// The header, the statistics, the worst poses and the change section carry the numbers a
// technician reads, each checked against an independent computation.
#include "report/report.h"

#include <SQLiteCpp/Transaction.h>
#include <fmt/format.h>
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <Eigen/QR>
#include <algorithm>
#include <cmath>
#include <iostream>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <random>

#include "calibration/drift.h"
#include "calibration/identifiability.h"
#include "calibration/synthetic.h"
#include "db/store.h"
#include "support/simulated_sessions.h"
#include "test_support.h"
#include "workflows/calibration_run.h"
#include "nightly/recalibrate.h"
#include "report/report_figures.h"
#include "report/report_page.h"

namespace armsig::testing {
namespace {

struct Fixture {
  calibration::RobotModel model = Puma();
  std::vector<MeasuredPose> poses;
  workflows::CalibrationRun run;
  report::ReportInput input;

  Fixture() {
    std::mt19937 rng(7);
    poses = calibration::SimulatePoses(
        model, Eigen::Isometry3d::Identity(), calibration::PaperTable3Parameters(),
        calibration::RandomConfigurations(model, 120, rng), 0.02, rng);
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
    // A laser tracker's air temperature with the validation poses, drifting 2 °C.
    for (size_t k = 0; k < run.validation_pose_ids.size(); ++k) {
      input.temperature_c[run.validation_pose_ids[k]] = 20.1 + 2.0 * k / 60.0 + 0.05 * std::sin(k);
    }
    input.history = {{1, "2026-11-01T02:00:00Z", 0.03, "all", false},
                     {2, "2026-11-02T02:00:00Z", 0.02, "geometric", true}};
    input.history[1].activations = {{"2026-11-02T02:00:00Z", "recalibrate"}};
    // Version 2 against version 1 (TEST(Report, DriftPanel…) draws it from real fits).
    input.drift_history.points = {{2, 1, 0.031, 0.012, 0.004, false}};
    input.drift_history.tolerance_mm = 0.05;
    input.drift_history.configurations = 50;
    input.generated_at = "2026-11-23T02:30:00Z";
    input.armsig_version = "9.8.7";
    input.sources.sessions = {{4, "2026-11-20T01:00:00.000Z", "2026-11-20T01:40:00.000Z",
                               "completed", "night shift", 60, 60}};
    input.sources.instruments = {{"station T1", "geocom on /dev/ttyUSB0", {4}}};
    input.sources.setups = {{4, "T1", 1.234, 9, "mutual+scale_bar"},
                            {4, "T2", std::nullopt, 0, ""}};
  }
};

const std::vector<std::string> kFigureFiles = {
    "errors.png",  "histogram.png", "vectors.png", "drift.png",       "joint_1.png",
    "joint_2.png", "joint_3.png",   "joint_4.png", "joint_5.png",     "joint_6.png",
    "residual_map.png", "temperature.png"};

// The text of the element with this id (up to its closing tag's '<').
std::string Cell(const std::string& html, const std::string& id) {
  const size_t at = html.find("id=\"" + id + "\"");
  if (at == std::string::npos) return "(no element " + id + ")";
  const size_t begin = html.find('>', at) + 1;
  return html.substr(begin, html.find("</td>", begin) - begin);
}

double CellNumber(const std::string& html, const std::string& id) {
  const std::string text = Cell(html, id);
  try {
    return std::stod(text);
  } catch (const std::exception&) {
    ADD_FAILURE() << id << ": not a number: " << text;
    return NAN;
  }
}

}  // namespace

// The fixture's robot is the model's own (PaperTable3Parameters): the map it tried is not
// used. The tests that want every figure say it is, to draw its chart too.
void UseTheMap(Fixture& f) {
  ASSERT_TRUE(f.run.residual_map.has_value());
  ASSERT_FALSE(f.run.residual_map->used);
  f.run.residual_map->used = true;
}

TEST(Report, EmbedsEveryFigureAsAValidPngIdenticalToItsFile) {
  Fixture f;
  UseTheMap(f);
  TempDir dir;
  const std::string page = report::WriteReport(dir.File("report"), f.input);
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
    EXPECT_TRUE(decoded.cols == 900 || decoded.cols == 440) << decoded.cols;  // joints: 440
    EXPECT_GT(decoded.rows, 200);
    cv::Scalar mean, stddev;
    cv::meanStdDev(decoded, mean, stddev);
    EXPECT_GT(stddev[0] + stddev[1] + stddev[2], 10.0) << "figure " << figures << " is blank";
    // The same pixels as one of the PNG files beside the page.
    bool same_as_a_file = false;
    for (const auto& file : kFigureFiles) {
      const cv::Mat on_disk = cv::imread(dir.File("report/" + file));
      same_as_a_file |= !on_disk.empty() && on_disk.size() == decoded.size() &&
                        cv::norm(on_disk, decoded, cv::NORM_INF) == 0.0;
    }
    EXPECT_TRUE(same_as_a_file) << "figure " << figures;
    ++figures;
  }
  // errors, histogram, vectors, drift (history), one per joint, the residual map's CV curve,
  // error against temperature
  EXPECT_EQ(figures, 12);
}

TEST(Report, HeadlessChromiumRendersEveryFigure) {
  if (std::system("command -v chromium > /dev/null 2>&1") != 0) {
    GTEST_SKIP() << "chromium is not installed (scripts/setup.sh installs it)";
  }
  Fixture f;
  UseTheMap(f);
  TempDir dir;
  const std::string page = report::WriteReport(dir.File("report"), f.input);
  const std::string shot = dir.File("shot.png");
  const std::string chromium =
      "timeout 120 chromium --headless --no-sandbox --disable-gpu --disable-quic --no-first-run "
      "--disable-background-networking --disable-component-update --disable-sync "
      "--hide-scrollbars --force-device-scale-factor=1 --window-size=1200,9000 --user-data-dir='" +
      dir.File("profile") + "' --screenshot='" + shot + "' 'file://" + page + "' >/dev/null 2>&1";
  ASSERT_EQ(std::system(chromium.c_str()), 0);
  const cv::Mat screen = cv::imread(shot, cv::IMREAD_COLOR);
  ASSERT_FALSE(screen.empty());
  // Where the page ends above the window's 9,000 rows: below its last row that is not all
  // the bottom row's colour every window is blank and scores no match, so a figure's search
  // stops where its top would pass that row (the best score found is the same or lower, never
  // higher). Each search makes two integral images of what it searches in double precision:
  // half a gigabyte for the whole window, faulted in anew for each of the 12 figures.
  const cv::Vec3b background = screen.at<cv::Vec3b>(screen.rows - 1, 0);
  auto blank_row = [&](int y) {
    for (int x = 0; x < screen.cols; ++x)
      if (screen.at<cv::Vec3b>(y, x) != background) return false;
    return true;
  };
  int page_rows = screen.rows;
  while (page_rows > 0 && blank_row(page_rows - 1)) --page_rows;
  std::cout << "the page: " << page_rows << " of the window's " << screen.rows << " rows\n";
  // Each figure, as a template, is found in the rendered page at 1:1 scale.
  for (const auto& file : kFigureFiles) {
    const cv::Mat figure = cv::imread(dir.File("report/" + file), cv::IMREAD_COLOR);
    ASSERT_FALSE(figure.empty()) << file;
    ASSERT_LE(figure.rows, screen.rows);
    cv::Mat score;
    const int searched_rows = std::min(screen.rows, page_rows + figure.rows);
    cv::matchTemplate(screen.rowRange(0, searched_rows), figure, score, cv::TM_CCOEFF_NORMED);
    double best = 0.0;
    cv::minMaxLoc(score, nullptr, &best);
    EXPECT_GT(best, 0.97) << file << " is not visible in the rendered page";
  }
}

TEST(Report, HeaderNamesDateVersionRobotSessionsInstrumentsSigma0RankAndUnidentified) {
  Fixture f;
  TempDir dir;
  const std::string html = ReadText(report::WriteReport(dir.File("report"), f.input));
  EXPECT_EQ(Cell(html, "generated-at"), "2026-11-23T02:30:00Z");
  EXPECT_EQ(Cell(html, "armsig-version"), "9.8.7");
  EXPECT_NE(Cell(html, "robot").find("puma &lt;&amp;&gt; &quot;one&quot;"), std::string::npos);
  EXPECT_NE(Cell(html, "robot").find("6 joints"), std::string::npos);
  const std::string sessions = Cell(html, "sessions");
  EXPECT_NE(sessions.find("session 4: 2026-11-20T01:00:00.000Z &ndash; 2026-11-20T01:40:00.000Z"),
            std::string::npos)
      << sessions;
  EXPECT_NE(sessions.find("60 fitted + 60 validation poses"), std::string::npos) << sessions;
  EXPECT_NE(Cell(html, "instruments").find("station T1: geocom on /dev/ttyUSB0 (session 4)"),
            std::string::npos);
  const std::string sigma0 = Cell(html, "sigma0");
  EXPECT_NE(sigma0.find("station T1: &sigma;<sub>0</sub> = 1.234 (9 dof, mutual+scale_bar)"),
            std::string::npos)
      << sigma0;
  EXPECT_NE(sigma0.find("station T2: &sigma;<sub>0</sub> not stored"), std::string::npos) << sigma0;
  // Rank: the PUMA's 25 identifiable geometric parameters (paper) plus its h-terms.
  const auto& id = f.run.estimate.identifiability;
  EXPECT_EQ(Cell(html, "rank")
                .rfind(std::to_string(id.rank) + " of " + std::to_string(id.candidates.size()) +
                           " candidate",
                       0),
            0u)
      << Cell(html, "rank");
  EXPECT_NEAR(CellNumber(html, "condition-number"), id.condition_number,
              1e-3 * id.condition_number);
  // The paper's 14 parameters kept at zero include gamma6 (the tool's roll about z6).
  const std::string unidentified = Cell(html, "not-identifiable");
  EXPECT_NE(unidentified.find("gamma6"), std::string::npos) << unidentified;
  const auto names = f.model.ParameterNames();
  for (int k : id.unidentified) EXPECT_NE(unidentified.find(names[k]), std::string::npos);
  EXPECT_EQ(std::count(unidentified.begin(), unidentified.end(), ','),
            static_cast<long>(id.unidentified.size()) - 1);
}

TEST(Report, PercentilesAndAxisStatisticsEqualAnIndependentComputation) {
  Fixture f;
  TempDir dir;
  const std::string html = ReadText(report::WriteReport(dir.File("report"), f.input));
  const auto& r = f.run.validation_residuals;
  ASSERT_GE(r.size(), 50u);
  for (int c = 0; c < 4; ++c) {
    const std::string name = c < 3 ? std::string("d") + "XYZ"[c] : "distance";
    std::vector<double> magnitude;
    double sum = 0.0;
    for (const auto& v : r) {
      const double x = c < 3 ? v(c) : v.norm();
      sum += x;
      magnitude.push_back(std::abs(x));
    }
    for (int percent : {50, 95, 99}) {
      // Nearest rank: the k-th smallest with k = ceil(percent/100 · n).
      std::vector<double> copy = magnitude;
      const size_t k = (percent * copy.size() + 99) / 100 - 1;
      std::nth_element(copy.begin(), copy.begin() + k, copy.end());
      EXPECT_NEAR(CellNumber(html, "stat-" + name + "-p" + std::to_string(percent)), copy[k],
                  0.5e-4)
          << name << " " << percent << " %";
    }
    EXPECT_NEAR(CellNumber(html, "stat-" + name + "-mean"), sum / r.size(), 0.5e-4) << name;
    EXPECT_NEAR(CellNumber(html, "stat-" + name + "-max"),
                *std::max_element(magnitude.begin(), magnitude.end()), 0.5e-4)
        << name;
  }
}

TEST(Report, PercentileIsTheNearestRankWithoutFloatingPointSlips) {
  std::vector<double> sixty;
  for (int i = 60; i >= 1; --i) sixty.push_back(i);  // unsorted on purpose
  EXPECT_EQ(report::PercentileNearestRank(sixty, 50), 30.0);
  EXPECT_EQ(report::PercentileNearestRank(sixty, 95), 57.0);  // 0.95 · 60 = 57 exactly
  EXPECT_EQ(report::PercentileNearestRank(sixty, 99), 60.0);  // ceil(59.4) = 60
  EXPECT_EQ(report::PercentileNearestRank({4.0}, 99), 4.0);
  EXPECT_TRUE(std::isnan(report::PercentileNearestRank({}, 50)));
}

TEST(Report, TenWorstPosesAreListedByIdLargestFirst) {
  Fixture f;
  TempDir dir;
  const std::string html = ReadText(report::WriteReport(dir.File("report"), f.input));
  std::vector<std::pair<double, std::string>> by_error;
  for (size_t i = 0; i < f.run.validation_residuals.size(); ++i)
    by_error.push_back({f.run.validation_residuals[i].norm(), f.run.validation_pose_ids[i]});
  std::sort(by_error.begin(), by_error.end(),
            [](const auto& a, const auto& b) { return a.first > b.first; });
  const size_t table = html.find("<table id=\"worst\">");
  ASSERT_NE(table, std::string::npos);
  const std::string worst = html.substr(table, html.find("</table>", table) - table);
  size_t previous = 0;
  for (int k = 0; k < 10; ++k) {
    const size_t at = worst.find("<td class=\"pose\">" + by_error[k].second + "</td>");
    ASSERT_NE(at, std::string::npos) << "rank " << k + 1 << ": " << by_error[k].second;
    EXPECT_GT(at, previous) << "rank " << k + 1 << " out of order";
    previous = at;
  }
  size_t rows = 0;
  for (size_t at = worst.find("class=\"pose\""); at != std::string::npos;
       at = worst.find("class=\"pose\"", at + 1))
    ++rows;
  EXPECT_EQ(rows, 10u);
}

// With the residual map, each of the worst poses says whether it lay inside the map's
// support (and the map's σ there) or outside it; without the map, neither column.
TEST(Report, WorstPosesSayWhetherTheMapAppliedAndItsSigma) {
  Fixture f;
  TempDir dir;
  auto worst_table = [&](const std::string& name) {
    const std::string html = ReadText(report::WriteReport(dir.File(name), f.input));
    const size_t table = html.find("<table id=\"worst\">");
    EXPECT_NE(table, std::string::npos);
    return html.substr(table, html.find("</table>", table) - table);
  };
  EXPECT_EQ(worst_table("plain").find("residual map"), std::string::npos);

  const size_t n = f.run.validation_residuals.size();
  f.run.validation_map_extrapolated.assign(n, 0);
  f.run.validation_map_sigma_mm.assign(n, 0.0);
  for (size_t i = 0; i < n; ++i) {
    f.run.validation_map_extrapolated[i] = i % 3 == 0;
    f.run.validation_map_sigma_mm[i] = 0.001 * static_cast<double>(i + 1);
  }
  const std::string worst = worst_table("map");
  EXPECT_NE(worst.find("<th>residual map</th>"), std::string::npos);
  int rows = 0;
  for (size_t i = 0; i < n; ++i) {
    const size_t at = worst.find("<td class=\"pose\">" + f.run.validation_pose_ids[i] + "</td>");
    if (at == std::string::npos) continue;  // not among the ten worst
    ++rows;
    const std::string row = worst.substr(at, worst.find("</tr>", at) - at);
    if (i % 3 == 0) {
      EXPECT_NE(row.find("<td class=\"map\">outside its support</td><td class=\"num\">&mdash;</td>"),
                std::string::npos)
          << row;
    } else {
      EXPECT_NE(row.find(fmt::format("<td class=\"map\">applied</td><td class=\"num\">{:.4f}</td>",
                                     0.001 * static_cast<double>(i + 1))),
                std::string::npos)
          << row;
    }
  }
  EXPECT_EQ(rows, 10);
}

TEST(Report, ChangeSectionIsNeverAnEmptyTableWithoutASentence) {
  Fixture f;
  TempDir dir;
  // No previous version.
  {
    const std::string html = ReadText(report::WriteReport(dir.File("first"), f.input));
    EXPECT_NE(Cell(html, "change-note").find("No previous version"), std::string::npos);
    EXPECT_EQ(html.find("<table id=\"changes\">"), std::string::npos);
  }
  // The previous set estimated another subset, and nothing is compared.
  f.input.previous_version = 1;
  f.input.previous_params_spec = "geometric";
  {
    const std::string html = ReadText(report::WriteReport(dir.File("subset"), f.input));
    const std::string note = Cell(html, "change-note");
    EXPECT_NE(note.find("--params geometric"), std::string::npos) << note;
    EXPECT_NE(note.find("different parameter subsets"), std::string::npos) << note;
    EXPECT_EQ(html.find("<table id=\"changes\">"), std::string::npos);
  }
  // Same subset, but no parameter with a sigma in both sets (z = 0 rows are left out).
  f.input.previous_params_spec = "all";
  f.input.changes = {{0, 0.0, 0.0}};
  {
    const std::string html = ReadText(report::WriteReport(dir.File("none"), f.input));
    EXPECT_NE(Cell(html, "change-note").find("share no parameter"), std::string::npos);
    EXPECT_EQ(html.find("<table id=\"changes\">"), std::string::npos);
  }
  // Real changes: a table, no apology.
  f.input.changes = {{1, 0.05, 2.5}};
  {
    const std::string html = ReadText(report::WriteReport(dir.File("changes"), f.input));
    EXPECT_EQ(html.find("id=\"change-note\""), std::string::npos);
    ASSERT_NE(html.find("<table id=\"changes\">"), std::string::npos);
    EXPECT_NE(html.find("0.0500 mm"), std::string::npos);
  }
}

TEST(Report, PrintsOnA4WithFiguresKeptWholeAndNumbersUnwrapped) {
  Fixture f;
  TempDir dir;
  const std::string html = ReadText(report::WriteReport(dir.File("report"), f.input));
  EXPECT_NE(html.find("@page{size:A4"), std::string::npos);
  EXPECT_NE(html.find("@media print{"), std::string::npos);
  EXPECT_NE(html.find("figure{margin:1em 0;break-inside:avoid;page-break-inside:avoid}"),
            std::string::npos);
  EXPECT_NE(html.find("td.num,th.num{text-align:right;white-space:nowrap"), std::string::npos);
  // Every figure sits in a <figure> (the unit kept whole on a page).
  size_t images = 0, figures = 0;
  for (size_t at = html.find("<img"); at != std::string::npos; at = html.find("<img", at + 1))
    ++images;
  for (size_t at = html.find("<figure><img"); at != std::string::npos;
       at = html.find("<figure><img", at + 1))
    ++figures;
  EXPECT_EQ(images, figures);
}

// Error against the air temperature: the slope printed is the least-squares slope of the
// validation error distances on the temperatures (solved here with Eigen's QR), with its
// sigma; without temperatures the section says why and there is no chart; over a span or
// from poses too few for a slope, the page says why there is none.
TEST(Report, ErrorAgainstTemperatureGivesTheLeastSquaresSlope) {
  Fixture f;
  TempDir dir;
  const std::string html = ReadText(report::WriteReport(dir.File("report"), f.input));
  const auto& ids = f.run.validation_pose_ids;
  Eigen::MatrixXd a(ids.size(), 2);
  Eigen::VectorXd b(ids.size());
  for (size_t k = 0; k < ids.size(); ++k) {
    a(k, 0) = 1.0;
    a(k, 1) = f.input.temperature_c.at(ids[k]);
    b(k) = f.run.validation_residuals[k].norm();
  }
  const Eigen::Vector2d line = a.colPivHouseholderQr().solve(b);
  // Its sigma: s² (AᵀA)⁻¹ of the same fit, printed to two significant digits; the slope to
  // the same decimal (within half a unit of it).
  const double s2 = (b - a * line).squaredNorm() / static_cast<double>(ids.size() - 2);
  const double sigma = std::sqrt(s2 * (a.transpose() * a).inverse()(1, 1));
  auto span_text = [&](const std::string& id) {
    const std::string marker = "id=\"" + id + "\">";
    const size_t at = html.find(marker);
    if (at == std::string::npos) return std::string();
    return html.substr(at + marker.size(), html.find('<', at + marker.size()) - at - marker.size());
  };
  const std::string slope = span_text("temperature-slope"),
                    shown_sigma = span_text("temperature-slope-sigma");
  ASSERT_FALSE(slope.empty()) << html;
  ASSERT_FALSE(shown_sigma.empty());
  const int decimals = static_cast<int>(slope.size() - slope.find('.') - 1);
  EXPECT_EQ(decimals, static_cast<int>(shown_sigma.size() - shown_sigma.find('.') - 1))
      << slope << " ± " << shown_sigma;
  EXPECT_NEAR(std::stod(slope), line(1), 0.5 * std::pow(10.0, -decimals) + 1e-12) << slope;
  EXPECT_NEAR(std::stod(shown_sigma), sigma, 0.05 * sigma) << shown_sigma;
  EXPECT_NE(html.find("id=\"temperature-slope-p\">"), std::string::npos);
  EXPECT_NE(html.find(std::to_string(ids.size()) + " of " + std::to_string(ids.size()) +
                      " validation poses have an air temperature"),
            std::string::npos);
  EXPECT_FALSE(cv::imread(dir.File("report/temperature.png")).empty());

  // No temperatures (theodolites): the section says why, and there is no empty chart.
  const auto temperatures = f.input.temperature_c;
  f.input.temperature_c.clear();
  const std::string none = ReadText(report::WriteReport(dir.File("none"), f.input));
  EXPECT_NE(none.find("No validation pose has an air temperature"), std::string::npos);
  EXPECT_EQ(none.find("temperature-slope"), std::string::npos);
  EXPECT_TRUE(cv::imread(dir.File("none/temperature.png")).empty());
  EXPECT_EQ(none.find("alt=\"Error against the air temperature\""), std::string::npos);

  // A steady room (0.01 °C): the points are drawn, but no slope over a span that cannot
  // show one, and the page says why.
  for (const auto& [id, t] : temperatures)
    f.input.temperature_c[id] = 20.0 + 0.01 * (t - 20.1) / 2.0;
  const std::string steady = ReadText(report::WriteReport(dir.File("steady"), f.input));
  EXPECT_EQ(steady.find("temperature-slope"), std::string::npos);
  EXPECT_NE(steady.find("the temperatures span only 0.01 °C; a slope needs at least 1 °C"),
            std::string::npos)
      << Cell(steady, "temperature-trend");
  EXPECT_FALSE(cv::imread(dir.File("steady/temperature.png")).empty());
  // Enough span but too few poses with a temperature.
  f.input.temperature_c.clear();
  for (size_t k = 0; k < 5; ++k) f.input.temperature_c[ids[k]] = 19.0 + k;
  const std::string few = ReadText(report::WriteReport(dir.File("few"), f.input));
  EXPECT_EQ(few.find("temperature-slope"), std::string::npos);
  EXPECT_NE(few.find("only 5 poses have a temperature; a slope needs at least 10"),
            std::string::npos);
  // One temperature for all: no slope to give.
  EXPECT_FALSE(report::LinearTrendOf({20.0, 20.0, 20.0}, {0.1, 0.2, 0.3}).has_value());
  const auto t = report::LinearTrendOf({19.0, 20.0, 21.0}, {0.1, 0.2, 0.3});
  ASSERT_TRUE(t.has_value());
  EXPECT_NEAR(t->slope, 0.1, 1e-12);
  EXPECT_NEAR(t->intercept, -1.8, 1e-12);
  EXPECT_NEAR(t->sigma_slope, 0.0, 1e-12);  // on the line: exact
  EXPECT_EQ(t->p_value, 0.0);
  // Scattered: slope 0.8, σ √(0.9 / 5), t² = 32/9 on 2 dof, whose two-sided p is
  // 1 − t / √(2 + t²) = 0.2 exactly (Student's t with 2 degrees of freedom).
  const auto scattered = report::LinearTrendOf({1.0, 2.0, 3.0, 4.0}, {1.0, 3.0, 2.0, 4.0});
  ASSERT_TRUE(scattered.has_value());
  EXPECT_NEAR(scattered->slope, 0.8, 1e-12);
  EXPECT_NEAR(scattered->sigma_slope, std::sqrt(0.9 / 5.0), 1e-12);
  EXPECT_NEAR(scattered->p_value, 0.2, 1e-9);
  // Two points: a slope, no significance.
  const auto two = report::LinearTrendOf({1.0, 2.0}, {1.0, 3.0});
  ASSERT_TRUE(two.has_value());
  EXPECT_TRUE(std::isnan(two->sigma_slope));
}

TEST(Report, OneErrorAgainstAngleFigurePerJoint) {
  Fixture f;
  TempDir dir;
  const std::string html = ReadText(report::WriteReport(dir.File("report"), f.input));
  for (int j = 1; j <= f.model.num_joints(); ++j) {
    EXPECT_NE(html.find("alt=\"Error against joint " + std::to_string(j) + "\""), std::string::npos)
        << j;
    const cv::Mat figure = cv::imread(dir.File("report/joint_" + std::to_string(j) + ".png"));
    EXPECT_FALSE(figure.empty()) << j;
  }
  EXPECT_TRUE(cv::imread(dir.File("report/joint_7.png")).empty());
}

TEST(Report, HistogramCountsAndTheirTicksAreIntegers) {
  EXPECT_EQ(report::IntegerTicks(3), (std::vector<int>{0, 1, 2, 3}));
  EXPECT_EQ(report::IntegerTicks(7), (std::vector<int>{0, 2, 4, 6, 8}));
  EXPECT_EQ(report::IntegerTicks(1), (std::vector<int>{0, 1}));
  EXPECT_EQ(report::IntegerTicks(0), (std::vector<int>{0, 1}));  // an empty histogram
  EXPECT_EQ(report::IntegerTicks(95).back(), 100);
  EXPECT_EQ(report::IntegerTicks(95)[1], 20);
  // The histogram drawn for the fixture's validation errors.
  Fixture f;
  const auto distances = calibration::Distances(f.run.validation_residuals);
  const auto h = report::HistogramOf(distances);
  int total = 0, most = 0;
  for (int c : h.counts) {
    total += c;
    most = std::max(most, c);
  }
  EXPECT_EQ(total, static_cast<int>(distances.size()));
  // Every bin counts the distances in [k·w, (k+1)·w), counted here independently.
  for (size_t b = 0; b < h.counts.size(); ++b) {
    const double lo = b * h.bin_width_mm, hi = (b + 1) * h.bin_width_mm;
    const bool last = b + 1 == h.counts.size();
    EXPECT_EQ(h.counts[b],
              std::count_if(distances.begin(), distances.end(),
                            [&](double d) { return d >= lo * (1 - 1e-12) && (d < hi || last); }))
        << "bin " << b;
  }
  ASSERT_GE(h.count_ticks.size(), 2u);
  EXPECT_EQ(h.count_ticks.front(), 0);
  EXPECT_GE(h.count_ticks.back(), most);
  const int step = h.count_ticks[1];
  EXPECT_GE(step, 1);
  for (size_t k = 1; k < h.count_ticks.size(); ++k)
    EXPECT_EQ(h.count_ticks[k] - h.count_ticks[k - 1], step);
  EXPECT_LT(h.count_ticks[h.count_ticks.size() - 2], most) << "one tick too many";
}

TEST(Report, ParameterSetKindsAreToldApart) {
  EXPECT_EQ(report::ParamsKind("all"), "all");
  EXPECT_EQ(report::ParamsKind("geometric"), "geometric");
  EXPECT_EQ(report::ParamsKind("auto"), "auto");
  EXPECT_EQ(report::ParamsKind("geometric,h3,h4"), "list");
  // In words on the page, never as the flag ("--params all (all)").
  EXPECT_EQ(report::ParamsInWords("all"), "every term of the model");
  EXPECT_EQ(report::ParamsInWords("geometric,h3,h4"), "the parameters geometric, h3, h4");
  EXPECT_EQ(report::ParamsInWords(""), "not known");
  // The drift figure's legend names each kind present; the version table lists them.
  Fixture f;
  TempDir dir;
  const std::string html = ReadText(report::WriteReport(dir.File("report"), f.input));
  EXPECT_EQ(Cell(html, "params").find("--params"), std::string::npos) << Cell(html, "params");
  EXPECT_EQ(Cell(html, "params").rfind(report::ParamsInWords(f.run.params_spec) + "; 60 poses fitted", 0), 0u)
      << Cell(html, "params");
  const size_t table = html.find("<table id=\"versions\">");
  ASSERT_NE(table, std::string::npos);
  EXPECT_NE(html.find("<td>geometric</td>", table), std::string::npos);
  EXPECT_NE(html.find("<td>all</td>", table), std::string::npos);
}

// Each instrument once: the lab file's station and the instrument that stood there (its
// stored name, serial and firmware) are one line; a second instrument read at no station of
// the lab file keeps its own line.
TEST(Report, EachInstrumentIsNamedOnceWithItsStation) {
  TempDir dir;
  db::Database database(dir.File("lab.db"));
  const std::string lab =
      "robot:\n  model: m.yaml\n  controller: {protocol: as, port: p}\n"
      "instruments:\n  - {station: T1, protocol: geocom, port: /dev/ttyS7}\n";
  AddSession(database, calibration::PaperTable3Parameters(), 30, 21, 0.0, lab);
  db::InstrumentRow tm30;
  tm30.name = "TM30 358120";
  tm30.kind = "theodolite";
  tm30.protocol = "geocom";
  tm30.port = "/dev/ttyS7";
  tm30.serial_number = "358120";
  tm30.firmware = "3.10";
  db::InstrumentRow other = tm30;
  other.name = "TM30 358121";
  other.serial_number = "358121";
  db::ObservationRow reading;
  reading.point = "P1";
  reading.station = "T1";
  reading.instrument_id = db::EnsureInstrument(database, tm30);
  db::ObservationRow second = reading;
  second.station = "T9";
  second.instrument_id = db::EnsureInstrument(database, other);
  db::InsertObservations(database, 1, {reading, second});
  const auto robot = db::FindRobot(database, "puma");
  ASSERT_TRUE(robot);
  workflows::CalibrationRun run;
  for (const auto& p : db::LoadRobotPoses(database, *robot, "")) run.fit_pose_ids.push_back(p.id);
  const auto sources = report::LoadReportSources(database, run);
  ASSERT_EQ(sources.instruments.size(), 2u);
  EXPECT_EQ(sources.instruments[0].name, "station T1: TM30 358120");
  EXPECT_EQ(sources.instruments[0].description.rfind("geocom on /dev/ttyS7", 0), 0u)
      << sources.instruments[0].description;
  EXPECT_NE(sources.instruments[0].description.find("serial 358120, firmware 3.10"),
            std::string::npos);
  EXPECT_EQ(sources.instruments[1].name, "station T9: TM30 358121");
  EXPECT_EQ(sources.instruments[1].description.rfind("theodolite, geocom, serial 358121", 0), 0u)
      << sources.instruments[1].description;
}

// The sources of a report come from the database: the sessions behind the pose ids with
// their stored dates, the lab file's instruments and the stations' orientation σ0.
TEST(Report, SourcesAreReadFromTheSessionsBehindThePoses) {
  TempDir dir;
  db::Database database(dir.File("lab.db"));
  const std::string lab =
      "robot:\n  model: m.yaml\n  controller: {protocol: as, port: p}\n"
      "instruments:\n  - {station: T1, protocol: geocom, port: /dev/ttyS7}\n";
  AddSession(database, calibration::PaperTable3Parameters(), 30, 21, 0.0, lab);
  AddSession(database, calibration::PaperTable3Parameters(), 20, 22);
  db::StationSetupRow setup;
  setup.station = "T1";
  setup.sigma0 = 0.875;
  setup.dof = 11;
  setup.method = "mutual+scale_bar";
  db::InsertStationSetup(database, 1, setup);
  const auto robot = db::FindRobot(database, "puma");
  ASSERT_TRUE(robot);
  const auto poses = db::LoadRobotPoses(database, *robot, "");
  ASSERT_EQ(poses.size(), 50u);
  workflows::CalibrationRun run;
  for (size_t i = 0; i < poses.size(); ++i)
    (i % 5 == 0 ? run.validation_pose_ids : run.fit_pose_ids).push_back(poses[i].id);
  const auto sources = report::LoadReportSources(database, run);
  ASSERT_EQ(sources.sessions.size(), 2u);
  int validation_of_first = 0;
  for (size_t i = 0; i < 30; i += 5) ++validation_of_first;
  EXPECT_EQ(sources.sessions[0].id, 1);
  EXPECT_EQ(sources.sessions[0].poses_validation, validation_of_first);
  EXPECT_EQ(sources.sessions[0].poses_fit, 30 - validation_of_first);
  EXPECT_EQ(sources.sessions[1].poses_fit + sources.sessions[1].poses_validation, 20);
  const std::string started =
      database.sql().execAndGet("SELECT started_at FROM sessions WHERE id = 2").getString();
  EXPECT_EQ(sources.sessions[1].started_at, started);
  EXPECT_EQ(sources.sessions[1].state, "completed");
  ASSERT_EQ(sources.instruments.size(), 1u);
  EXPECT_EQ(sources.instruments[0].name, "station T1");
  EXPECT_EQ(sources.instruments[0].description.rfind("geocom on /dev/ttyS7", 0), 0u);
  EXPECT_EQ(sources.instruments[0].sessions, (std::vector<int64_t>{1}));
  ASSERT_EQ(sources.setups.size(), 1u);  // only session 1 has a set-up
  EXPECT_EQ(sources.setups[0].session_id, 1);
  EXPECT_DOUBLE_EQ(sources.setups[0].sigma0.value(), 0.875);
  EXPECT_EQ(sources.setups[0].dof, 11);
}

// `recalibrate --report` fills the header from the database and the program's version.
TEST(Report, RecalibrateWritesTheHeaderFromTheDatabase) {
  TempDir dir;
  const std::string path = dir.File("lab.db");
  {
    db::Database database(path);
    AddSession(database, calibration::PaperTable3Parameters(), 150, 31);
  }
  nightly::RecalibrateOptions o;
  o.db_path = path;
  o.robot = "puma";
  o.report_dir = dir.File("report");
  const auto d = nightly::Recalibrate(o);
  ASSERT_FALSE(d.report_path.empty());
  const std::string html = ReadText(d.report_path);
  EXPECT_NE(Cell(html, "armsig-version"), "not known");
  EXPECT_EQ(Cell(html, "armsig-version").find_first_not_of("0123456789."), std::string::npos)
      << Cell(html, "armsig-version");
  EXPECT_NE(Cell(html, "sessions").find("session 1: "), std::string::npos);
  EXPECT_NE(Cell(html, "sessions").find("simulated"), std::string::npos);
  EXPECT_NE(Cell(html, "change-note").find("No previous version"), std::string::npos);
}

// The drift panel shows what drift is: how far version 2 moves the arm against version 1.
// Its numbers (largest and mean predicted-position difference) equal an independent
// computation: both sets' positions by the templated kinematics over the same spread
// configurations, version 2's aligned onto version 1's with Eigen's Umeyama. The tolerance
// is named, and the made-active marks lie below the plotting area, never among the data.
TEST(Report, DriftPanelShowsHowFarEachVersionMovedTheArm) {
  Fixture f;
  const auto& model = f.model;
  // Version 1: the fixture's fit; version 2: the same robot with joint 2's zero moved
  // 0.3 mrad, fitted on fresh poses.
  std::mt19937 rng(17);
  Eigen::VectorXd changed = calibration::PaperTable3Parameters();
  changed(6 * 1 + 5) += 3e-4;
  const auto poses =
      calibration::SimulatePoses(model, Eigen::Isometry3d::Identity(), changed,
                                 calibration::RandomConfigurations(model, 120, rng), 0.02, rng);
  workflows::CalibrateSettings settings;
  settings.select = 60;
  const auto second = workflows::RunCalibration(model, poses, {}, settings);
  const calibration::FittedSet a{f.run.estimate.params, f.run.estimate.identifiability.identified,
                                 f.run.estimate.covariance};
  const calibration::FittedSet b{second.estimate.params, second.estimate.identifiability.identified,
                                 second.estimate.covariance};
  const auto spread = calibration::SpreadConfigurations(model, 50);
  report::ReportDriftPoint point = report::DriftPointOf(model, a, b, spread);
  point.version = 2;
  point.against = 1;
  point.drift = true;
  f.input.drift_history.points = {point};
  f.input.drift_history.tolerance_mm = 0.05;
  TempDir dir;
  const std::string html = ReadText(report::WriteReport(dir.File("report"), f.input));

  // Independently: positions of both, b aligned onto a, the largest and mean distance.
  Eigen::Matrix3Xd xa(3, spread.size()), xb(3, spread.size());
  for (size_t i = 0; i < spread.size(); ++i) {
    xa.col(i) = calibration::TargetPosition<double>(model, Eigen::Isometry3d::Identity(),
                                                    a.params.data(), spread[i].data());
    xb.col(i) = calibration::TargetPosition<double>(model, Eigen::Isometry3d::Identity(),
                                                    b.params.data(), spread[i].data());
  }
  const Eigen::Matrix4d t = Eigen::umeyama(xb, xa, false);
  const Eigen::Matrix3Xd delta =
      ((t.topLeftCorner<3, 3>() * xb).colwise() + Eigen::Vector3d(t.topRightCorner<3, 1>())) - xa;
  const Eigen::VectorXd distances = delta.colwise().norm().transpose();
  EXPECT_NEAR(CellNumber(html, "drift-2-max"), distances.maxCoeff(), 0.5e-4);
  EXPECT_NEAR(CellNumber(html, "drift-2-mean"), distances.mean(), 0.5e-4);
  EXPECT_GT(distances.maxCoeff(), 0.2);  // the planted 0.3 mrad at a metre's reach
  const double sigma = CellNumber(html, "drift-2-sigma");
  EXPECT_GT(sigma, 0.0);
  EXPECT_LT(sigma, 0.1 * distances.maxCoeff());  // 0.02 mm noise on 60 poses each
  EXPECT_NE(html.find("id=\"drift-tolerance\">0.050<"), std::string::npos);
  EXPECT_NE(html.find("Drift is how far a new parameter set moves the arm"), std::string::npos);

  // The figure: made-active marks (the only green in it) below the frame's bottom edge and
  // its tick labels.
  const cv::Mat figure = cv::imread(dir.File("report/drift.png"), cv::IMREAD_COLOR);
  ASSERT_FALSE(figure.empty());
  int bottom = -1;  // the lowest row that is mostly the frame's ink
  for (int y = 0; y < figure.rows; ++y) {
    int ink = 0;
    for (int x = 0; x < figure.cols; ++x) {
      const cv::Vec3b p = figure.at<cv::Vec3b>(y, x);
      ink += p[0] == 40 && p[1] == 40 && p[2] == 40;
    }
    if (ink > figure.cols / 2) bottom = y;
  }
  ASSERT_GT(bottom, 0);
  int green = 0, green_above = 0;
  for (int y = 0; y < figure.rows; ++y) {
    for (int x = 0; x < figure.cols; ++x) {
      const cv::Vec3b p = figure.at<cv::Vec3b>(y, x);
      if (p[1] > 120 && p[0] < 110 && p[2] < 90) {  // kGreen (70, 150, 40), antialiased
        ++green;
        green_above += y <= bottom + 20;
      }
    }
  }
  EXPECT_GT(green, 20) << "no made-active mark";
  EXPECT_EQ(green_above, 0) << "a made-active mark among the data or the tick labels";

  // Nothing to compare (one version): no empty panel, a sentence instead.
  f.input.drift_history.points.clear();
  const std::string single = ReadText(report::WriteReport(dir.File("single"), f.input));
  EXPECT_TRUE(cv::imread(dir.File("single/drift.png")).empty());
  EXPECT_NE(single.find("No earlier parameter set to compare with"), std::string::npos);
}

// A map the cross-validation left out is its decision in one sentence, and no chart (nor the
// chart of an earlier report in the same folder).
TEST(Report, TheMapsChartOnlyWhenTheMapIsUsed) {
  Fixture f;
  TempDir dir;
  UseTheMap(f);
  report::WriteReport(dir.File("report"), f.input);
  ASSERT_FALSE(cv::imread(dir.File("report/residual_map.png")).empty());
  f.run.residual_map->used = false;
  const std::string html = ReadText(report::WriteReport(dir.File("report"), f.input));
  EXPECT_TRUE(cv::imread(dir.File("report/residual_map.png")).empty());
  EXPECT_NE(html.find("<p id=\"residual-map\">Not used: "), std::string::npos);
  int figures = 0;
  for (size_t at = html.find("<img"); at != std::string::npos; at = html.find("<img", at + 1))
    ++figures;
  EXPECT_EQ(figures, 11);
}

// One version far off (here 12 mm where the others moved the arm 0.03-0.04 mm) must not press
// the others onto the axis: the axis stops at three times what they and the tolerance reach,
// the far one is drawn at the top with its value.
TEST(ReportFigures, DriftAxisStopsShortOfAVersionFarOff) {
  report::ReportDrift drift;
  drift.tolerance_mm = 0.05;
  drift.points = {{2, 1, 0.03, 0.02, 0.0, false}, {3, 2, 0.04, 0.02, 0.0, false}};
  EXPECT_DOUBLE_EQ(report::DriftAxisTop(drift), 1.25 * 0.05);  // the tolerance line shows
  drift.points.push_back({4, 3, 12.0, 5.0, 0.0, true});
  EXPECT_DOUBLE_EQ(report::DriftAxisTop(drift), 3.0 * 1.25 * 0.05);
  // A far-off version among others as far off is not clipped.
  drift.points[1].max_mm = 10.0;
  EXPECT_DOUBLE_EQ(report::DriftAxisTop(drift), 12.0);
  // The chart with the far one: its value written at the top, the legend says so.
  drift.points[1].max_mm = 0.04;
  TempDir dir;
  const auto figure = report::DriftFigure(dir.path().string(), drift, {});
  ASSERT_TRUE(figure.has_value());
  const cv::Mat clipped = cv::imread(dir.File("drift.png"), cv::IMREAD_COLOR);
  drift.points.pop_back();
  report::DriftFigure(dir.path().string(), drift, {});
  const cv::Mat plain = cv::imread(dir.File("drift.png"), cv::IMREAD_COLOR);
  ASSERT_FALSE(clipped.empty());
  ASSERT_FALSE(plain.empty());
  EXPECT_GT(clipped.rows, plain.rows);  // the legend's row for what lies beyond the axis
}

// Parameter sigmas with two significant digits (never "± 0.000"), the value to the same
// decimal, each the fit's own within its rounding.
TEST(Report, ParameterSigmasHaveSignificantDigits) {
  Fixture f;
  TempDir dir;
  const std::string html = ReadText(report::WriteReport(dir.File("report"), f.input));
  EXPECT_EQ(html.find("&plusmn; 0.000<"), std::string::npos);
  const auto names = f.model.ParameterNames();
  int checked = 0;
  for (int k : f.run.estimate.identifiability.identified) {
    const std::string marker = "id=\"param-" + names[k] + "\">";
    const size_t at = html.find(marker);
    ASSERT_NE(at, std::string::npos) << names[k];
    std::string cell = html.substr(at + marker.size(), 80);
    if (k >= f.model.num_geometric()) cell = cell.substr(cell.find(" = ") + 3);  // "h1 = …"
    const size_t pm = cell.find(" &plusmn; ");
    ASSERT_NE(pm, std::string::npos) << cell;
    const std::string value = cell.substr(0, pm);
    std::string sigma = cell.substr(pm + 10);
    sigma = sigma.substr(0, sigma.find_first_of(" <"));
    const bool angle = f.model.UnitOf(k) == calibration::ParameterUnit::kRad;
    const double scale = angle ? 1e3 : 1.0;
    const double true_sigma = f.run.estimate.sigmas(k) * scale;
    EXPECT_NEAR(std::stod(sigma), true_sigma, 0.051 * true_sigma) << names[k] << ": " << cell;
    const size_t first = sigma.find_first_not_of("0.");
    int digits = 0;
    for (size_t i = first; i < sigma.size(); ++i) digits += sigma[i] != '.';
    if (sigma.find('.') != std::string::npos) {
      EXPECT_EQ(digits, 2) << names[k] << ": " << sigma;
    }
    const int decimals = static_cast<int>(value.size() - value.find('.') - 1);
    EXPECT_GE(decimals, 3) << value;
    EXPECT_NEAR(std::stod(value), f.run.estimate.params(k) * scale,
                0.5 * std::pow(10.0, -decimals) + 1e-12)
        << names[k];
    ++checked;
  }
  EXPECT_EQ(checked, f.run.estimate.identifiability.rank);
}

// Four nightly sessions whose one network gave all three stations the same σ0: one line,
// not twelve; a session whose σ0 differs keeps a line of its own.
TEST(Report, EqualOrientationSigma0sAreSaidOnce) {
  std::vector<report::ReportStationSetup> setups;
  for (int64_t session : {4, 5, 6, 7})
    for (const char* station : {"T1", "T2", "T3"})
      setups.push_back({session, station, 0.942, 25, "mutual+scale_bar"});
  for (const char* station : {"T1", "T2", "T3"})
    setups.push_back({8, station, 1.310, 25, "mutual+scale_bar"});
  const auto groups = report::Sigma0Groups(setups);
  ASSERT_EQ(groups.size(), 2u);
  EXPECT_EQ(groups[0].sessions, (std::vector<int64_t>{4, 5, 6, 7}));
  EXPECT_EQ(groups[0].stations, (std::vector<std::string>{"T1", "T2", "T3"}));
  EXPECT_EQ(groups[1].sessions, (std::vector<int64_t>{8}));
  // Within a session, stations with different figures stay apart.
  setups.push_back({9, "T1", 0.9, 25, "m"});
  setups.push_back({9, "T2", std::nullopt, 0, ""});
  EXPECT_EQ(report::Sigma0Groups(setups).size(), 4u);

  Fixture f;
  f.input.sources.setups.assign(setups.begin(), setups.begin() + 15);
  TempDir dir;
  const std::string html = ReadText(report::WriteReport(dir.File("report"), f.input));
  const std::string sigma0 = Cell(html, "sigma0");
  EXPECT_NE(sigma0.find("sessions 4, 5, 6, 7, stations T1, T2, T3: &sigma;<sub>0</sub> = 0.942 "
                        "(25 dof, mutual+scale_bar)"),
            std::string::npos)
      << sigma0;
  size_t lines = 0;
  for (size_t at = sigma0.find("<div>"); at != std::string::npos; at = sigma0.find("<div>", at + 1))
    ++lines;
  EXPECT_EQ(lines, 2u) << sigma0;
}

// Issue 38: a drift night was headlined in green like any stored set. The page opens with one
// word and the figure that matters for it: the validation error, how far the robot moved, or
// the gate that failed.
TEST(ReportBanner, SaysPassDriftDriftSuspectedOrRejectedWithTheFigureThatMatters) {
  workflows::CalibrationRun run;
  run.validation_residuals = {{0.03, 0.04, 0.0}, {0.0, 0.0, 0.1}};  // 0.05 and 0.10 mm
  report::ReportInput in;
  in.robot = "ur10";
  in.run = &run;
  in.version = 3;
  in.decision = "stored as version 3";
  auto banner = report::BannerOf(in);
  EXPECT_EQ(banner.word, "PASS");
  EXPECT_EQ(banner.css_class, "good");
  EXPECT_EQ(banner.figure, "version 3: validation mean 0.075 mm, max 0.100 mm on 2 configurations");
  in.drift = true;
  in.window = {{7, "", 30, 0.4, 0.612, 1e-9, true, false}, {8, "", 30, 0.2, 0.9, 0.5, false, false}};
  banner = report::BannerOf(in);
  EXPECT_EQ(banner.word, "DRIFT");
  EXPECT_EQ(banner.css_class, "warn");  // never green
  EXPECT_EQ(banner.figure,
            "the robot moved by up to 0.612 mm at the tool; version 3 follows it (validation mean "
            "0.075 mm, max 0.100 mm on 2 configurations)");
  in.version = 0;
  in.drift = false;
  in.previous_version = 2;
  in.gates = {"fit mean: 0.0400 mm (limit 0.5000 mm) passed",
              "validation mean: 0.9000 mm (limit 0.5000 mm) FAILED"};
  banner = report::BannerOf(in);
  EXPECT_EQ(banner.word, "REJECTED");
  EXPECT_EQ(banner.css_class, "bad");
  EXPECT_EQ(banner.figure, "validation mean: 0.9000 mm (limit 0.5000 mm) FAILED; nothing stored");
  in.run = nullptr;
  banner = report::BannerOf(in);
  EXPECT_EQ(banner.word, "DRIFT SUSPECTED");
  EXPECT_EQ(banner.figure,
            "the robot moved by up to 0.612 mm at the tool; nothing stored, version 2 stays active");
}

}  // namespace armsig::testing
