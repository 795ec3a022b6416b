// The recalibration report: every figure is a valid PNG (decoded with OpenCV, the same
// pixels as the file beside the page), and a real browser (headless Chromium, no
// JavaScript in the page) renders each of them: the screenshot contains every figure.
// The header, the statistics, the worst poses and the change section carry the numbers a
// technician reads, each checked against an independent computation.
#include "workflows/report.h"

#include <SQLiteCpp/Transaction.h>
#include <gtest/gtest.h>

#include <Eigen/QR>
#include <algorithm>
#include <cmath>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <random>

#include "calibration/simulation.h"
#include "db/store.h"
#include "support/simulated_sessions.h"
#include "test_support.h"
#include "workflows/calibration_run.h"
#include "workflows/recalibrate.h"

namespace armsig::testing {
namespace {

struct Fixture {
  calibration::RobotModel model = Puma();
  std::vector<MeasuredPose> poses;
  workflows::CalibrationRun run;
  workflows::ReportInput input;

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
    // A laser tracker's air temperature with the validation poses, drifting 0.8 °C.
    for (size_t k = 0; k < run.validation_pose_ids.size(); ++k) {
      input.temperature_c[run.validation_pose_ids[k]] = 20.1 + 0.8 * k / 60.0 + 0.05 * std::sin(k);
    }
    input.history = {{1, "2026-11-01T02:00:00Z", 0.03, "all", false},
                     {2, "2026-11-02T02:00:00Z", 0.02, "geometric", true}};
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
  for (const auto& file : kFigureFiles) {
    const cv::Mat figure = cv::imread(dir.File("report/" + file), cv::IMREAD_COLOR);
    ASSERT_FALSE(figure.empty()) << file;
    ASSERT_LE(figure.rows, screen.rows);
    cv::Mat score;
    cv::matchTemplate(screen, figure, score, cv::TM_CCOEFF_NORMED);
    double best = 0.0;
    cv::minMaxLoc(score, nullptr, &best);
    EXPECT_GT(best, 0.97) << file << " is not visible in the rendered page";
  }
}

TEST(Report, HeaderNamesDateVersionRobotSessionsInstrumentsSigma0RankAndUnidentified) {
  Fixture f;
  TempDir dir;
  const std::string html = ReadText(workflows::WriteReport(dir.File("report"), f.input));
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
  const std::string html = ReadText(workflows::WriteReport(dir.File("report"), f.input));
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
  EXPECT_EQ(workflows::PercentileNearestRank(sixty, 50), 30.0);
  EXPECT_EQ(workflows::PercentileNearestRank(sixty, 95), 57.0);  // 0.95 · 60 = 57 exactly
  EXPECT_EQ(workflows::PercentileNearestRank(sixty, 99), 60.0);  // ceil(59.4) = 60
  EXPECT_EQ(workflows::PercentileNearestRank({4.0}, 99), 4.0);
  EXPECT_TRUE(std::isnan(workflows::PercentileNearestRank({}, 50)));
}

TEST(Report, TenWorstPosesAreListedByIdLargestFirst) {
  Fixture f;
  TempDir dir;
  const std::string html = ReadText(workflows::WriteReport(dir.File("report"), f.input));
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

TEST(Report, ChangeSectionIsNeverAnEmptyTableWithoutASentence) {
  Fixture f;
  TempDir dir;
  // No previous version.
  {
    const std::string html = ReadText(workflows::WriteReport(dir.File("first"), f.input));
    EXPECT_NE(Cell(html, "change-note").find("No previous version"), std::string::npos);
    EXPECT_EQ(html.find("<table id=\"changes\">"), std::string::npos);
  }
  // The previous set estimated another subset, and nothing is compared.
  f.input.previous_version = 1;
  f.input.previous_params_spec = "geometric";
  {
    const std::string html = ReadText(workflows::WriteReport(dir.File("subset"), f.input));
    const std::string note = Cell(html, "change-note");
    EXPECT_NE(note.find("--params geometric"), std::string::npos) << note;
    EXPECT_NE(note.find("different parameter subsets"), std::string::npos) << note;
    EXPECT_EQ(html.find("<table id=\"changes\">"), std::string::npos);
  }
  // Same subset, but no parameter with a sigma in both sets (z = 0 rows are left out).
  f.input.previous_params_spec = "all";
  f.input.changes = {{0, 0.0, 0.0}};
  {
    const std::string html = ReadText(workflows::WriteReport(dir.File("none"), f.input));
    EXPECT_NE(Cell(html, "change-note").find("share no parameter"), std::string::npos);
    EXPECT_EQ(html.find("<table id=\"changes\">"), std::string::npos);
  }
  // Real changes: a table, no apology.
  f.input.changes = {{1, 0.05, 2.5}};
  {
    const std::string html = ReadText(workflows::WriteReport(dir.File("changes"), f.input));
    EXPECT_EQ(html.find("id=\"change-note\""), std::string::npos);
    ASSERT_NE(html.find("<table id=\"changes\">"), std::string::npos);
    EXPECT_NE(html.find("0.0500 mm"), std::string::npos);
  }
}

TEST(Report, PrintsOnA4WithFiguresKeptWholeAndNumbersUnwrapped) {
  Fixture f;
  TempDir dir;
  const std::string html = ReadText(workflows::WriteReport(dir.File("report"), f.input));
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
// validation error distances on the temperatures (solved here with Eigen's QR); without
// temperatures the section says why and the figure says so.
TEST(Report, ErrorAgainstTemperatureGivesTheLeastSquaresSlope) {
  Fixture f;
  TempDir dir;
  const std::string html = ReadText(workflows::WriteReport(dir.File("report"), f.input));
  const auto& ids = f.run.validation_pose_ids;
  Eigen::MatrixXd a(ids.size(), 2);
  Eigen::VectorXd b(ids.size());
  for (size_t k = 0; k < ids.size(); ++k) {
    a(k, 0) = 1.0;
    a(k, 1) = f.input.temperature_c.at(ids[k]);
    b(k) = f.run.validation_residuals[k].norm();
  }
  const Eigen::Vector2d line = a.colPivHouseholderQr().solve(b);
  const std::string marker = "id=\"temperature-slope\">";
  ASSERT_NE(html.find(marker), std::string::npos);
  const std::string slope = html.substr(html.find(marker) + marker.size(), 20);
  EXPECT_NEAR(std::stod(slope), line(1), 1e-6) << slope;
  // Its sigma: s² (AᵀA)⁻¹ of the same fit.
  const double s2 = (b - a * line).squaredNorm() / static_cast<double>(ids.size() - 2);
  const double sigma = std::sqrt(s2 * (a.transpose() * a).inverse()(1, 1));
  const std::string sigma_marker = "id=\"temperature-slope-sigma\">";
  ASSERT_NE(html.find(sigma_marker), std::string::npos);
  EXPECT_NEAR(std::stod(html.substr(html.find(sigma_marker) + sigma_marker.size(), 20)), sigma,
              1e-6);
  EXPECT_NE(html.find("id=\"temperature-slope-p\">"), std::string::npos);
  EXPECT_NE(html.find(std::to_string(ids.size()) + " of " + std::to_string(ids.size()) +
                      " validation poses have an air temperature"),
            std::string::npos);
  EXPECT_FALSE(cv::imread(dir.File("report/temperature.png")).empty());

  f.input.temperature_c.clear();
  const std::string none = ReadText(workflows::WriteReport(dir.File("none"), f.input));
  EXPECT_NE(none.find("No validation pose has an air temperature"), std::string::npos);
  EXPECT_EQ(none.find("temperature-slope"), std::string::npos);
  EXPECT_FALSE(cv::imread(dir.File("none/temperature.png")).empty());
  // One temperature for all: no slope to give.
  EXPECT_FALSE(workflows::LinearTrendOf({20.0, 20.0, 20.0}, {0.1, 0.2, 0.3}).has_value());
  const auto t = workflows::LinearTrendOf({19.0, 20.0, 21.0}, {0.1, 0.2, 0.3});
  ASSERT_TRUE(t.has_value());
  EXPECT_NEAR(t->slope, 0.1, 1e-12);
  EXPECT_NEAR(t->intercept, -1.8, 1e-12);
  EXPECT_NEAR(t->sigma_slope, 0.0, 1e-12);  // on the line: exact
  EXPECT_EQ(t->p_value, 0.0);
  // Scattered: slope 0.8, σ √(0.9 / 5), t² = 32/9 on 2 dof, whose two-sided p is
  // 1 − t / √(2 + t²) = 0.2 exactly (Student's t with 2 degrees of freedom).
  const auto scattered = workflows::LinearTrendOf({1.0, 2.0, 3.0, 4.0}, {1.0, 3.0, 2.0, 4.0});
  ASSERT_TRUE(scattered.has_value());
  EXPECT_NEAR(scattered->slope, 0.8, 1e-12);
  EXPECT_NEAR(scattered->sigma_slope, std::sqrt(0.9 / 5.0), 1e-12);
  EXPECT_NEAR(scattered->p_value, 0.2, 1e-9);
  // Two points: a slope, no significance.
  const auto two = workflows::LinearTrendOf({1.0, 2.0}, {1.0, 3.0});
  ASSERT_TRUE(two.has_value());
  EXPECT_TRUE(std::isnan(two->sigma_slope));
}

TEST(Report, OneErrorAgainstAngleFigurePerJoint) {
  Fixture f;
  TempDir dir;
  const std::string html = ReadText(workflows::WriteReport(dir.File("report"), f.input));
  for (int j = 1; j <= f.model.num_joints(); ++j) {
    EXPECT_NE(html.find("alt=\"Error against joint " + std::to_string(j) + "\""), std::string::npos)
        << j;
    const cv::Mat figure = cv::imread(dir.File("report/joint_" + std::to_string(j) + ".png"));
    EXPECT_FALSE(figure.empty()) << j;
  }
  EXPECT_TRUE(cv::imread(dir.File("report/joint_7.png")).empty());
}

TEST(Report, HistogramCountsAndTheirTicksAreIntegers) {
  EXPECT_EQ(workflows::IntegerTicks(3), (std::vector<int>{0, 1, 2, 3}));
  EXPECT_EQ(workflows::IntegerTicks(7), (std::vector<int>{0, 2, 4, 6, 8}));
  EXPECT_EQ(workflows::IntegerTicks(1), (std::vector<int>{0, 1}));
  EXPECT_EQ(workflows::IntegerTicks(0), (std::vector<int>{0, 1}));  // an empty histogram
  EXPECT_EQ(workflows::IntegerTicks(95).back(), 100);
  EXPECT_EQ(workflows::IntegerTicks(95)[1], 20);
  // The histogram drawn for the fixture's validation errors.
  Fixture f;
  const auto distances = calibration::Distances(f.run.validation_residuals);
  const auto h = workflows::HistogramOf(distances);
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
  EXPECT_EQ(workflows::ParamsKind("all"), "all");
  EXPECT_EQ(workflows::ParamsKind("geometric"), "geometric");
  EXPECT_EQ(workflows::ParamsKind("auto"), "auto");
  EXPECT_EQ(workflows::ParamsKind("geometric,h3,h4"), "list");
  // The drift figure's legend names each kind present; the version table lists them.
  Fixture f;
  TempDir dir;
  const std::string html = ReadText(workflows::WriteReport(dir.File("report"), f.input));
  const size_t table = html.find("<table id=\"versions\">");
  ASSERT_NE(table, std::string::npos);
  EXPECT_NE(html.find("<td>geometric</td>", table), std::string::npos);
  EXPECT_NE(html.find("<td>all</td>", table), std::string::npos);
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
  const auto sources = workflows::LoadReportSources(database, run);
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
  workflows::RecalibrateOptions o;
  o.db_path = path;
  o.robot = "puma";
  o.report_dir = dir.File("report");
  const auto d = workflows::Recalibrate(o);
  ASSERT_FALSE(d.report_path.empty());
  const std::string html = ReadText(d.report_path);
  EXPECT_NE(Cell(html, "armsig-version"), "not known");
  EXPECT_EQ(Cell(html, "armsig-version").find_first_not_of("0123456789."), std::string::npos)
      << Cell(html, "armsig-version");
  EXPECT_NE(Cell(html, "sessions").find("session 1: "), std::string::npos);
  EXPECT_NE(Cell(html, "sessions").find("simulated"), std::string::npos);
  EXPECT_NE(Cell(html, "change-note").find("No previous version"), std::string::npos);
}

}  // namespace armsig::testing
