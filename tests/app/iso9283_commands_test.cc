// The ISO 9283 commands through the program: a plan for a registered robot, its poses
// measured elsewhere and imported as a session, the report (refused without a frame, then
// with the reported rigid fit), the file evaluation, and what each refuses with exit 2.
#include <fmt/format.h>
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <random>

#include "calibration/iso9283_path.h"
#include "calibration/synthetic.h"
#include "core/units.h"
#include "iso9283/iso9283_csv.h"
#include "test_support.h"

namespace armsig::testing {
namespace {

// RP = l̄ + 3 S_l (S_l on n − 1), written out here.
double RpOf(const std::vector<Eigen::Vector3d>& x) {
  Eigen::Vector3d b = Eigen::Vector3d::Zero();
  for (const auto& p : x) b += p / static_cast<double>(x.size());
  std::vector<double> l;
  double mean = 0.0;
  for (const auto& p : x) {
    l.push_back((p - b).norm());
    mean += l.back() / static_cast<double>(x.size());
  }
  double squares = 0.0;
  for (double v : l) squares += (v - mean) * (v - mean);
  return mean + 3.0 * std::sqrt(squares / static_cast<double>(x.size() - 1));
}

TEST(Iso9283Commands, PlanMeasureImportReportAndEvaluate) {
  TempDir dir;
  const std::string db = "--db '" + dir.File("lab.db") + "' ";
  ASSERT_EQ(RunArmsig(db + "robot add puma --model '" + SourcePath("models/puma760.yaml") + "'")
                .exit_code,
            0);
  const auto plan =
      RunArmsig(db + "iso9283 plan --robot puma --cube 600,100,700,400 --cycles 6 --out '" +
                dir.File("plan.csv") + "'");
  ASSERT_EQ(plan.exit_code, 0) << plan.err;
  EXPECT_NE(plan.out.find("30 configurations"), std::string::npos) << plan.out;
  EXPECT_NE(plan.out.find("distance P2-P4: 554.256 mm"), std::string::npos) << plan.out;
  // The conditions on the output, the file the header and its rows (no '#' line a
  // spreadsheet would read as a row).
  EXPECT_NE(plan.out.find("ISO 9283 test cube of robot puma (model puma760): centre (600.000, "
                          "100.000, 700.000) mm, edge 400.0 mm\nmeasuring plane C1-C2-C7-C8"),
            std::string::npos)
      << plan.out;
  EXPECT_EQ(ReadText(dir.File("plan.csv")).rfind("pose,point,cycle,approach,x_mm", 0), 0u);

  // Measured elsewhere: the true robot (the paper's errors) with 0.05 mm of scatter, in a
  // tracker frame 2 m away and turned; the poses CSV keeps the plan's labels.
  const auto model = Puma();
  const auto rows = iso9283::ReadIso9283PlanCsv(dir.File("plan.csv"), 6);
  Eigen::Isometry3d tracker_from_robot = Eigen::Isometry3d::Identity();
  tracker_from_robot.translate(Eigen::Vector3d(2000.0, -300.0, 100.0));
  tracker_from_robot.rotate(Eigen::AngleAxisd(1.1, Eigen::Vector3d::UnitZ()));
  std::mt19937 rng(4);
  std::normal_distribution<double> noise(0.0, 0.05);
  calibration::Kinematics kin(model);
  const Eigen::VectorXd truth = calibration::PaperTable3Parameters();
  std::string poses = "pose,q1_deg,q2_deg,q3_deg,q4_deg,q5_deg,q6_deg,x_mm,y_mm,z_mm\n";
  std::map<std::string, std::vector<Eigen::Vector3d>> attained;
  for (const auto& r : rows) {
    const Eigen::Vector3d x =
        tracker_from_robot *
        (kin.Position(Eigen::Isometry3d::Identity(), truth, r.joints_rad.data()) +
         Eigen::Vector3d(noise(rng), noise(rng), noise(rng)));
    attained[r.point].push_back(x);
    poses += r.pose;
    for (int i = 0; i < 6; ++i) poses += fmt::format(",{:.10f}", r.joints_rad(i) / kRadPerDeg);
    poses += fmt::format(",{:.6f},{:.6f},{:.6f}\n", x.x(), x.y(), x.z());
  }
  WriteText(dir.File("measured.csv"), poses);
  const auto imported = RunArmsig(db + "import poses '" + dir.File("measured.csv") +
                                  "' --robot puma --id pose --joint-columns "
                                  "q1_deg,q2_deg,q3_deg,q4_deg,q5_deg,q6_deg --joint-unit deg "
                                  "--xyz-columns x_mm,y_mm,z_mm");
  ASSERT_EQ(imported.exit_code, 0) << imported.err;

  // No signature, no lab file: the robot's frame is unknown, and the report says how to go on.
  const auto unframed =
      RunArmsig(db + "iso9283 report --robot puma --session 1 --out '" + dir.File("r0") + "'");
  EXPECT_EQ(unframed.exit_code, 2);
  EXPECT_NE(unframed.err.find("--align"), std::string::npos) << unframed.err;
  EXPECT_FALSE(std::filesystem::exists(dir.File("r0/index.html")));

  const auto report =
      RunArmsig(db + "iso9283 report --robot puma --session 1 --align --speed-percent 100 --out '" +
                dir.File("report") + "' --json '" + dir.File("report.json") + "'");
  ASSERT_EQ(report.exit_code, 0) << report.err;
  EXPECT_NE(report.out.find("rigid best fit"), std::string::npos) << report.out;
  EXPECT_TRUE(std::filesystem::exists(dir.File("report/index.html")));
  const auto j = nlohmann::json::parse(ReadText(dir.File("report.json")));
  ASSERT_EQ(j["points"].size(), 5u);
  for (const auto& p : j["points"]) {
    EXPECT_EQ(p["n"], 6);
    // RP does not depend on the frame: the tracker-frame positions give it directly.
    EXPECT_NEAR(p["RP_mm"].get<double>(), RpOf(attained[p["point"]]), 1e-6) << p["point"];
  }
  EXPECT_EQ(j["alignment"]["method"], "rigid best fit");
  EXPECT_EQ(j["conditions"]["speed_percent"], 100.0);
  EXPECT_EQ(j["distance"]["from"], "P2");
  // The imported session kept no targets: the nominal positions of the planned joints stand
  // in (said in a note), which for a nominal plan are the plan's targets: --commanded agrees.
  EXPECT_NE(j["notes"].dump().find("no stored target"), std::string::npos) << j["notes"];

  // Pass / fail against stated limits, judged on RP computed here from the tracker's points:
  // a limit above every point's RP passes; one below the largest fails at that point (exit 3,
  // the page and the JSON written, the figure named).
  double worst_rp = 0.0;
  std::string worst_point;
  for (const auto& [point, xs] : attained) {
    if (RpOf(xs) > worst_rp) worst_rp = RpOf(xs), worst_point = point;
  }
  const std::string judged = db + "iso9283 report --robot puma --session 1 --align "
                                  "--limits-from 'customer acceptance' --limit RP=";
  const auto pass = RunArmsig(judged + fmt::format("{:.6f}", worst_rp + 1e-3) + " --out '" +
                              dir.File("pass") + "' --json '" + dir.File("pass.json") + "'");
  EXPECT_EQ(pass.exit_code, 0) << pass.err;
  EXPECT_NE(pass.out.find("PASS: all 5 figures within the stated limits (limits: customer "
                          "acceptance)"),
            std::string::npos)
      << pass.out;
  const auto fail = RunArmsig(judged + fmt::format("{:.6f}", worst_rp - 1e-3) +
                              " --limit AP=1000 --out '" + dir.File("fail") + "' --json '" +
                              dir.File("fail.json") + "'");
  EXPECT_EQ(fail.exit_code, 3) << fail.err;
  const auto jf = nlohmann::json::parse(ReadText(dir.File("fail.json")));
  EXPECT_FALSE(jf["verdict"]["pass"].get<bool>());
  EXPECT_EQ(jf["verdict"]["checks"].size(), 10u);  // AP and RP at five points
  int failed = 0;
  for (const auto& c : jf["verdict"]["checks"]) {
    if (c["pass"].get<bool>()) continue;
    ++failed;
    EXPECT_EQ(c["figure"], "RP");
    EXPECT_EQ(c["where"], worst_point);
    EXPECT_NEAR(c["value_mm"].get<double>(), worst_rp, 1e-6);
  }
  EXPECT_EQ(failed, 1);
  const std::string page = ReadText(dir.File("fail/index.html"));
  EXPECT_NE(page.find("id=\"verdict\"><b>FAIL</b> &mdash; RP at " + worst_point), std::string::npos);
  for (const char* wrong : {"RP", "RP=", "RP=-1", "RP=0.1mm", "XY=1", "RP=nan"}) {
    const auto refused = RunArmsig(db + "iso9283 report --robot puma --session 1 --align --limit '" +
                                   wrong + "' --out '" + dir.File("refused") + "'");
    EXPECT_EQ(refused.exit_code, 2) << wrong;
    EXPECT_NE(refused.err.find("--limit: '" + std::string(wrong) + "': expected KEY=MM"),
              std::string::npos)
        << refused.err;
  }
  EXPECT_FALSE(std::filesystem::exists(dir.File("refused/index.html")));
  const auto given = RunArmsig(
      db + "iso9283 report --robot puma --session 1 --align --commanded '" + dir.File("plan.csv") +
      "' --out '" + dir.File("report2") + "' --json '" + dir.File("report2.json") + "'");
  ASSERT_EQ(given.exit_code, 0) << given.err;
  const auto j2 = nlohmann::json::parse(ReadText(dir.File("report2.json")));
  for (int k = 0; k < 5; ++k)
    EXPECT_NEAR(j2["points"][k]["AP_mm"].get<double>(), j["points"][k]["AP_mm"].get<double>(),
                1e-4);

  // The same data as files: commanded P1…P5 and the attained cycles.
  std::string commanded = "point,x_mm,y_mm,z_mm\n", cycles = "point,cycle,x_mm,y_mm,z_mm\n";
  for (const auto& r : rows) {
    if (r.cycle == 1)
      commanded +=
          fmt::format("{},{},{},{}\n", r.point, r.target_mm.x(), r.target_mm.y(), r.target_mm.z());
  }
  std::map<std::string, int> cycle;
  for (const auto& r : rows) {
    const Eigen::Vector3d& x = attained[r.point][cycle[r.point]++];
    cycles += fmt::format("{},{},{:.6f},{:.6f},{:.6f}\n", r.point, r.cycle, x.x(), x.y(), x.z());
  }
  WriteText(dir.File("commanded.csv"), commanded);
  WriteText(dir.File("attained.csv"), cycles);
  const auto evaluated =
      RunArmsig("iso9283 evaluate --commanded '" + dir.File("commanded.csv") + "' --attained '" +
                dir.File("attained.csv") + "' --align --json '" + dir.File("e.json") + "'");
  ASSERT_EQ(evaluated.exit_code, 0) << evaluated.err;
  const auto je = nlohmann::json::parse(ReadText(dir.File("e.json")));
  ASSERT_EQ(je["points"].size(), 5u);
  for (const auto& p : je["points"]) {  // in the file's order: P1 P5 P4 P3 P2
    const auto& q = j2["points"][p["point"].get<std::string>()[1] - '1'];
    ASSERT_EQ(q["point"], p["point"]);
    EXPECT_NEAR(p["AP_mm"].get<double>(), q["AP_mm"].get<double>(), 1e-4);
    EXPECT_NEAR(p["RP_mm"].get<double>(), q["RP_mm"].get<double>(), 1e-5);
  }
  EXPECT_NEAR(je["distance"]["AD_mm"].get<double>(), j2["distance"]["AD_mm"].get<double>(), 1e-4);
}

TEST(Iso9283Commands, RefusalsAreExitTwoNamingWhatIsWrong) {
  TempDir dir;
  const std::string db = "--db '" + dir.File("lab.db") + "' ";
  ASSERT_EQ(RunArmsig(db + "robot add puma --model '" + SourcePath("models/puma760.yaml") + "'")
                .exit_code,
            0);
  const std::string out = " --out '" + dir.File("p.csv") + "'";
  const auto far = RunArmsig(db + "iso9283 plan --robot puma --cube 5000,0,0,100" + out);
  EXPECT_EQ(far.exit_code, 2);
  EXPECT_NE(far.err.find("cannot be reached"), std::string::npos) << far.err;
  // Issue 38: a cube of 1e-300 mm made a plan of five coinciding points, exit 0.
  for (const char* edge : {"0", "-100", "1e-300", "9.99"}) {
    const auto tiny =
        RunArmsig(db + "iso9283 plan --robot puma --cube 600,100,700," + edge + out);
    EXPECT_EQ(tiny.exit_code, 2) << edge;
    EXPECT_NE(tiny.err.find("--cube: an edge of "), std::string::npos) << tiny.err;
    EXPECT_NE(tiny.err.find("mm is no test of the working space (ISO 9283: the largest cube it "
                            "holds; expected at least 10 mm)"),
              std::string::npos)
        << tiny.err;
  }
  const auto three = RunArmsig(db + "iso9283 plan --robot puma --cube 600,100,700" + out);
  EXPECT_EQ(three.exit_code, 2);
  EXPECT_NE(three.err.find("expected 4 numbers, got 3"), std::string::npos) << three.err;
  const auto both = RunArmsig(db + "iso9283 plan --robot puma --cube 600,100,700,400 --auto" + out);
  EXPECT_EQ(both.exit_code, 2);
  const auto neither = RunArmsig(db + "iso9283 plan --robot puma" + out);
  EXPECT_EQ(neither.exit_code, 2);
  EXPECT_NE(neither.err.find("--auto"), std::string::npos) << neither.err;
  const auto uncalibrated =
      RunArmsig(db + "iso9283 plan --robot puma --cube 600,100,700,400 --compensated" + out);
  EXPECT_EQ(uncalibrated.exit_code, 2);
  EXPECT_NE(uncalibrated.err.find("no active parameter set"), std::string::npos)
      << uncalibrated.err;
  EXPECT_FALSE(std::filesystem::exists(dir.File("p.csv")));
  const auto unknown = RunArmsig(db + "iso9283 report --robot puma --session 9 --align --out '" +
                                 dir.File("r") + "'");
  EXPECT_EQ(unknown.exit_code, 2);
  EXPECT_NE(unknown.err.find("no session 9"), std::string::npos) << unknown.err;
  WriteText(dir.File("c.csv"), "point,x_mm,y_mm,z_mm\nP1,0,0,0\n");
  WriteText(dir.File("a.csv"), "point,cycle,x_mm,y_mm,z_mm\nP1,1,0,0,0\nP1,x,0,0,0\n");
  const auto bad =
      RunArmsig("iso9283 evaluate --commanded '" + dir.File("c.csv") + "' --attained '" +
                dir.File("a.csv") + "' --json '" + dir.File("e.json") + "'");
  EXPECT_EQ(bad.exit_code, 2);
  EXPECT_NE(bad.err.find("a.csv:3"), std::string::npos) << bad.err;
  EXPECT_FALSE(std::filesystem::exists(dir.File("e.json")));
  // Three commanded points on one line cannot fix a frame.
  WriteText(dir.File("line.csv"), "point,x_mm,y_mm,z_mm\nA,0,0,0\nB,1,0,0\nC,2,0,0\n");
  WriteText(dir.File("on.csv"), "point,x_mm,y_mm,z_mm\nA,0,0,0\nB,1,0,0\nC,2,0,0\n");
  const auto line =
      RunArmsig("iso9283 evaluate --commanded '" + dir.File("line.csv") + "' --attained '" +
                dir.File("on.csv") + "' --align --json '" + dir.File("e.json") + "'");
  EXPECT_EQ(line.exit_code, 2);
  EXPECT_NE(line.err.find("not on one"), std::string::npos) << line.err;
}

// `iso9283 plan --path`: the standard's line and rectangle in the cube's measuring plane, 10
// cycles unless told (the standard's number for paths), every vertex's joints putting the
// nominal model on it, the first of each cycle a joint move and the rest linear moves at the
// speed; what does not make a path plan is exit 2 naming the option.
TEST(Iso9283Commands, APathPlanIsTheStandardsLineAndRectangleAsLinearMoves) {
  TempDir dir;
  const std::string db = "--db '" + dir.File("lab.db") + "' ";
  ASSERT_EQ(RunArmsig(db + "robot add puma --model '" + SourcePath("models/puma760.yaml") + "'")
                .exit_code,
            0);
  const auto plan = RunArmsig(db + "iso9283 plan --robot puma --cube 600,100,700,400 --path "
                                   "line,rectangle --speed 200 --out '" + dir.File("path.csv") + "'");
  ASSERT_EQ(plan.exit_code, 0) << plan.err;
  EXPECT_NE(plan.out.find("path test: 10 cycles of line, rectangle at 200 mm/s"), std::string::npos)
      << plan.out;
  EXPECT_NE(plan.out.find("capture --on-the-move"), std::string::npos) << plan.out;
  const auto rows = iso9283::ReadIso9283PlanCsv(dir.File("path.csv"), 6);
  ASSERT_EQ(rows.size(), 10u * (2 + 6));  // the line's 2 vertices, the rectangle's 6
  const calibration::iso9283::TestPaths paths =
      calibration::iso9283::BuildTestPaths({Eigen::Vector3d(600, 100, 700), 400.0});
  const auto model = Puma();
  calibration::Kinematics kin(model);
  const Eigen::VectorXd zero = Eigen::VectorXd::Zero(model.num_parameters());
  for (size_t i = 0; i < rows.size(); ++i) {
    const bool line = i < 20;
    const size_t k = line ? i % 2 : (i - 20) % 6;
    const auto& vertices = line ? paths.line_mm : paths.rectangle_mm;
    EXPECT_EQ(rows[i].pose, fmt::format("{}-{:02d}-v{}", line ? "line" : "rectangle",
                                        (line ? i / 2 : (i - 20) / 6) + 1, k + 1));
    EXPECT_LT((rows[i].target_mm - vertices[k]).norm(), 1e-5) << rows[i].pose;
    EXPECT_LT((kin.Position(Eigen::Isometry3d::Identity(), zero, rows[i].joints_rad.data()) -
               vertices[k]).norm(), 1e-4)
        << rows[i].pose;
    EXPECT_EQ(rows[i].speed_mm_s.has_value(), k > 0) << rows[i].pose;
    if (k > 0) EXPECT_DOUBLE_EQ(*rows[i].speed_mm_s, 200.0);
  }
  // A circle: its start, then via its quarter points to its half and back (two circular
  // moves), every vertex on the standard's circle about P1.
  const auto circle = RunArmsig(db + "iso9283 plan --robot puma --cube 600,100,700,400 --path "
                                     "circle-small --cycles 2 --out '" + dir.File("circle.csv") + "'");
  ASSERT_EQ(circle.exit_code, 0) << circle.err;
  EXPECT_NE(ReadText(dir.File("circle.csv")).find(",speed_mm_s,motion\n"), std::string::npos);
  const auto circle_rows = iso9283::ReadIso9283PlanCsv(dir.File("circle.csv"), 6);
  ASSERT_EQ(circle_rows.size(), 10u);
  const char* motions[] = {"", "via", "circular", "via", "circular"};
  for (size_t i = 0; i < circle_rows.size(); ++i) {
    EXPECT_EQ(circle_rows[i].motion, motions[i % 5]) << circle_rows[i].pose;
    EXPECT_LT((circle_rows[i].target_mm - paths.small_circle_mm[90 * (i % 5)]).norm(), 1e-5);
    EXPECT_LT((kin.Position(Eigen::Isometry3d::Identity(), zero, circle_rows[i].joints_rad.data()) -
               circle_rows[i].target_mm).norm(), 1e-4);
  }
  for (const auto& [args, option] : std::vector<std::pair<std::string, std::string>>{
           {"--path circle", "--path"},
           {"--path line,line", "given twice"},
           {"--path line --approach", "--approach"},
           {"--speed 200", "--speed"},
           {"--path line --speed 0", "--speed"}}) {
    const auto refused = RunArmsig(db + "iso9283 plan --robot puma --cube 600,100,700,400 " + args +
                                   " --out '" + dir.File("bad.csv") + "'");
    EXPECT_EQ(refused.exit_code, 2) << args;
    EXPECT_NE(refused.err.find(option), std::string::npos) << args << ": " << refused.err;
    EXPECT_FALSE(std::filesystem::exists(dir.File("bad.csv"))) << args;
  }
}

// `iso9283 evaluate-path`: a straight commanded path and three cycles written by the test
// at a planted offset across the path (0.3 mm in z: AT), along it (5 mm: not AT), a planted
// speed (2 % above the command: AV) and a planted repeatability (one cycle 0.1 mm higher:
// RT = l̄ + 3 S by hand); a rectangle's corner cut (CR); files with a typo are exit 2 naming
// the file, line and column.
TEST(Iso9283Commands, EvaluatePathFromFiles) {
  TempDir dir;
  WriteText(dir.File("line.csv"), "vertex,x_mm,y_mm,z_mm\nA,0,0,0\nB,400,0,0\n");
  const double v = 250.0 * 1.02;
  const double z[3] = {0.3, 0.3, 0.4};
  std::string cycles = "cycle,t_s,x_mm,y_mm,z_mm\n";
  for (int c = 0; c < 3; ++c) {
    for (int k = 0; k * 2.0 <= 380.0; ++k) {
      const double x = 5.0 + 2.0 * k;  // 5 mm along the path: no path error
      cycles += fmt::format("{},{:.9f},{:.6f},0,{:.6f}\n", c + 1, 10.0 * c + x / v, x, z[c]);
    }
  }
  WriteText(dir.File("cycles.csv"), cycles);
  const auto r = RunArmsig("iso9283 evaluate-path --commanded '" + dir.File("line.csv") +
                           "' --attained '" + dir.File("cycles.csv") + "' --speed 250 --json '" +
                           dir.File("p.json") + "'");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("path accuracy AT"), std::string::npos) << r.out;
  const auto j = nlohmann::json::parse(ReadText(dir.File("p.json")));
  EXPECT_EQ(j["cycles"], 3);
  const double mean_z = (0.3 + 0.3 + 0.4) / 3.0;
  EXPECT_NEAR(j["AT_mm"].get<double>(), mean_z, 1e-6);
  // l_j: |z_j − z̄| = 1/30, 1/30, 2/30; l̄ = 4/90; S on n − 1.
  const double l[3] = {1.0 / 30, 1.0 / 30, 2.0 / 30};
  const double lbar = (l[0] + l[1] + l[2]) / 3.0;
  double ss = 0.0;
  for (double li : l) ss += (li - lbar) * (li - lbar);
  EXPECT_NEAR(j["RT_mm"].get<double>(), lbar + 3.0 * std::sqrt(ss / 2.0), 1e-6);
  EXPECT_NEAR(j["AV_percent"].get<double>(), 2.0, 1e-4);  // times written to the ns
  EXPECT_TRUE(j["corners"].empty());

  WriteText(dir.File("typo.csv"), "cycle,t_s,x_mm,y_mm,z_mm\n1,0.0,1,0,0\n1,0.1,2,0,zero\n");
  const auto typo = RunArmsig("iso9283 evaluate-path --commanded '" + dir.File("line.csv") +
                              "' --attained '" + dir.File("typo.csv") + "' --speed 250 --json '" +
                              dir.File("q.json") + "'");
  EXPECT_EQ(typo.exit_code, 2);
  EXPECT_NE(typo.err.find("typo.csv:3:"), std::string::npos) << typo.err;
  WriteText(dir.File("back.csv"), "cycle,t_s,x_mm,y_mm,z_mm\n1,0.2,1,0,0\n1,0.1,2,0,0\n");
  const auto back = RunArmsig("iso9283 evaluate-path --commanded '" + dir.File("line.csv") +
                              "' --attained '" + dir.File("back.csv") + "' --speed 250 --json '" +
                              dir.File("q.json") + "'");
  EXPECT_EQ(back.exit_code, 2);
  EXPECT_NE(back.err.find("does not follow"), std::string::npos) << back.err;
}

}  // namespace
}  // namespace armsig::testing
