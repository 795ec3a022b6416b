#include "demo/demo.h"

#include <gtest/gtest.h>

#include <atomic>
#include <nlohmann/json.hpp>
#include <numbers>
#include <regex>

#include "core/error.h"
#include "db/database.h"
#include "demo/demo_lab.h"
#include "io/builtin_models.h"
#include "io/model_yaml.h"
#include "test_support.h"

namespace armsig::demo {
namespace {

DemoLimits PumaLimits() {
  return DemoLimitsOf(io::ParseRobotModel(io::kPuma760Yaml, "built-in PUMA 760"), 1985);
}

std::string Refusal(int configurations, int select) {
  try {
    DemoSelectCount(configurations, select, PumaLimits());
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

}  // namespace

// The PUMA's 43 candidates with the target on the joint-6 axis: 29 identifiable (the
// paper's 25 geometric + h1…h4), so a fit needs 10 configurations (30 equations > 29),
// and the validation as many: 20 in all.
TEST(DemoLimits, ComeFromTheModelsIdentifiableParameters) {
  const DemoLimits limits = PumaLimits();
  EXPECT_EQ(limits.identifiable, 29);
  EXPECT_EQ(limits.min_fit, 10);
  EXPECT_EQ(limits.min_validation, 10);
  EXPECT_EQ(limits.min_configurations, 20);
}

TEST(DemoLimits, DefaultSelectionIsFortyPercentWithinTheLimits) {
  const DemoLimits limits = PumaLimits();
  EXPECT_EQ(DemoSelectCount(200, 0, limits), 80);  // the paper's 80 of ~200
  EXPECT_EQ(DemoSelectCount(60, 0, limits), 24);
  EXPECT_EQ(DemoSelectCount(20, 0, limits), 10);  // 8 would be too few to fit
  EXPECT_EQ(DemoSelectCount(60, 50, limits), 50);
  EXPECT_EQ(DemoSelectCount(60, 10, limits), 10);
}

TEST(DemoLimits, TooFewConfigurationsOrASelectionOutsideTheLimitsAreRefused) {
  const std::string few = Refusal(19, 0);
  EXPECT_NE(few.find("--configurations"), std::string::npos) << few;
  EXPECT_NE(few.find("at least 20"), std::string::npos) << few;
  const std::string many = Refusal(60, 51);  // leaves 9 to validate
  EXPECT_NE(many.find("--select"), std::string::npos) << many;
  EXPECT_NE(many.find("10…50"), std::string::npos) << many;
  EXPECT_NE(Refusal(60, 9).find("10…50"), std::string::npos);
  EXPECT_EQ(Refusal(60, 40), "");
}

// `demo --instrument tracker`: one virtual laser tracker on loopback TCP, its frame the
// lab frame (no orientation); the beam pointed by the operator for the first
// configurations, then by prediction through the fitted base; the paper's progression
// down to the tracker's noise floor. Stopped midway, it resumes with the tracker it was
// captured with; asked to resume with theodolites, it refuses.
TEST(Demo, TrackerLabRunsTheWholeChainWithoutOrientation) {
  testing::TempDir dir;
  DemoOptions o;
  o.db_path = dir.File("demo.db");
  o.instrument = "tracker";
  o.configurations = 40;
  o.time_scale = 0.05;
  std::atomic<bool> stop{false};
  o.stop = &stop;
  std::string narrative;
  DemoObserver observer;
  observer.say = [&](const std::string& text) { narrative += text; };
  observer.progress = [&](const acquisition::Progress& p) {
    if (p.done == 12) stop = true;
  };
  const DemoResult first = RunDemo(o, observer);
  ASSERT_FALSE(first.completed);
  ASSERT_GT(first.session, 0);
  // (The narrative is wrapped at 100 columns: read with its line breaks as spaces.)
  EXPECT_NE(std::regex_replace(narrative, std::regex(R"(\s+)"), " ")
                .find("needs no orientation by mutual pointings"),
            std::string::npos)
      << narrative;

  DemoOptions wrong = o;
  wrong.resume_session = first.session;
  wrong.instrument = "theodolites";
  wrong.stop = nullptr;
  EXPECT_THROW(RunDemo(wrong, {}), InputError);

  DemoOptions resume = o;
  resume.resume_session = first.session;
  resume.instrument.clear();
  resume.stop = nullptr;
  narrative.clear();
  observer.progress = nullptr;
  const DemoResult r = RunDemo(resume, observer);
  ASSERT_TRUE(r.completed) << narrative;
  const auto& j = r.json;
  EXPECT_EQ(j["session"]["instrument"], "tracker");
  EXPECT_EQ(j["session"]["stations"], 1);
  EXPECT_EQ(j["session"]["poses"], 40);
  ASSERT_EQ(j["stages"].size(), 3u);
  EXPECT_EQ(j["stages"][0]["rank"], 25);
  EXPECT_EQ(j["stages"][2]["rank"], 29);
  const double floor = j["session"]["noise_floor_mm"];
  EXPECT_LT(floor, 0.03);  // σ ≈ 0.008 mm per axis at 2–3.5 m
  const double all = j["stages"][2]["validation"]["mean_mm"];
  EXPECT_LT(all, 3.0 * floor);  // 16 fitted poses for 29 parameters, and the validation noise
  EXPECT_GT(j["stages"][0]["validation"]["mean_mm"].get<double>(), 10.0 * all);
  // Resumed from stored points: the base is fitted before the first new configuration.
  EXPECT_EQ(j["session"]["beam"]["operator"], 0);
  EXPECT_EQ(j["session"]["beam"]["predicted"], 28);
  EXPECT_NE(j["session"]["beam"]["base"].get<std::string>().find("base fitted to 40"),
            std::string::npos);
  db::Database db(o.db_path);
  EXPECT_EQ(db.sql().execAndGet("SELECT count(*) FROM observations WHERE temperature_c IS NULL")
                .getInt(),
            0);
  EXPECT_EQ(db.sql().execAndGet("SELECT count(*) FROM observations").getInt(), 40);
}

// `demo --robot NAME` of a robot on its controller's protocols with a laser tracker: 100
// configurations, 60 fitted, 100 times faster than physical time; from millimetres nominal
// down to the tracker's noise floor (issue 35's acceptance). Returns the narrative.
namespace {
std::string ExpectCapturedAndCalibratedToTheNoiseFloor(const std::string& robot,
                                                       const std::string& db_path,
                                                       double nominal_above_mm) {
  DemoOptions o;
  o.db_path = db_path;
  o.robot = robot;
  o.configurations = 100;
  o.select = 60;
  o.time_scale = 0.01;
  std::string narrative;
  DemoObserver observer;
  observer.say = [&](const std::string& text) { narrative += text; };
  const DemoResult r = RunDemo(o, observer);
  EXPECT_TRUE(r.completed) << narrative;
  if (!r.completed) return narrative;
  const auto& j = r.json;
  EXPECT_EQ(j["session"]["robot"], robot);
  EXPECT_EQ(j["session"]["instrument"], "tracker");
  EXPECT_EQ(j["session"]["poses"], 100);
  EXPECT_EQ(j["stages"].size(), 2u);
  EXPECT_EQ(j["stages"][0]["params"], "geometric");
  EXPECT_EQ(j["stages"][1]["params"], "all");
  const double floor = j["session"]["noise_floor_mm"];
  const double nominal = j["stages"][0]["nominal"]["mean_mm"];
  const double calibrated = j["stages"][1]["validation"]["mean_mm"];
  EXPECT_GT(nominal, nominal_above_mm);  // the hidden errors at the tool
  EXPECT_LT(calibrated, 0.1);            // the issue's acceptance
  EXPECT_LT(calibrated, 3.0 * floor);
  return narrative;
}
}  // namespace

// `demo --robot ur10`: the UR10's virtual controller speaking RTDE, the secondary and primary
// interfaces and the dashboard on loopback TCP; every configuration's joints from RTDE with
// the controller's time stamp, the controller's identity with the session.
TEST(Demo, Ur10IsCapturedOverItsControllersProtocolsAndCalibratedToTheNoiseFloor) {
  testing::TempDir dir;
  const std::string narrative =
      ExpectCapturedAndCalibratedToTheNoiseFloor("ur10", dir.File("demo.db"), 1.0);
  EXPECT_NE(narrative.find("RTDE"), std::string::npos) << narrative;
  db::Database db(dir.File("demo.db"));
  EXPECT_EQ(db.sql().execAndGet("SELECT count(*) FROM poses WHERE controller_time_s IS NOT NULL")
                .getInt(),
            100);
  EXPECT_EQ(db.sql().execAndGet("SELECT controller_model FROM sessions").getString(), "UR10");
  EXPECT_EQ(db.sql().execAndGet("SELECT count(*) FROM robots WHERE name = 'ur10-demo' AND "
                                "kinematics_checksum IS NOT NULL").getInt(),
            1);
}

// `demo --robot abb`: the IRB 4600's virtual OmniCore speaking Robot Web Services 2.0 over
// TLS (its certificate pinned by the lab file, its user's password in a credentials file of
// mode 0600), running the shipped RAPID module; a laser tracker; from millimetres nominal down
// to the tracker's noise floor. Run twice on one database: the same arm's next session.
TEST(Demo, AbbIsCapturedOverRobotWebServicesAndCalibratedToTheNoiseFloor) {
  testing::TempDir dir;
  const std::string narrative =
      ExpectCapturedAndCalibratedToTheNoiseFloor("abb", dir.File("demo.db"), 1.0);
  EXPECT_NE(narrative.find("Robot Web Services 2.0"), std::string::npos) << narrative;
  DemoOptions o;
  o.db_path = dir.File("demo.db");
  o.robot = "abb";
  o.time_scale = 0.01;
  db::Database db(o.db_path);
  EXPECT_EQ(db.sql().execAndGet("SELECT controller_model FROM sessions").getString(),
            "IRB 4600-40/2.55");
  EXPECT_EQ(db.sql().execAndGet("SELECT controller_serial FROM sessions").getString(),
            "4600-501234");
  o.configurations = 60;
  o.select = 30;
  const DemoResult again = RunDemo(o, {});
  EXPECT_TRUE(again.completed);
}

// `demo --robot kuka`: a KR 16-2 on its virtual KR C4, read and moved through the variable
// server and ARMSIG; the controller's identity with the session.
TEST(Demo, KukaIsCapturedThroughItsVariableServerAndCalibratedToTheNoiseFloor) {
  testing::TempDir dir;
  const std::string narrative =
      ExpectCapturedAndCalibratedToTheNoiseFloor("kuka", dir.File("demo.db"), 0.5);
  EXPECT_NE(narrative.find("KukaVarProxy"), std::string::npos) << narrative;  // one word: lines wrap
  db::Database db(dir.File("demo.db"));
  EXPECT_EQ(db.sql().execAndGet("SELECT controller_model FROM sessions").getString(), "KR16_2");
}

TEST(Demo, TrackerFromTheCommandLine) {
  testing::TempDir dir;
  const auto r = testing::RunArmsig("--db '" + dir.File("d.db") + "' demo --instrument tracker " +
                                    "--configurations 30 --time-scale 0.02 --json '" +
                                    dir.File("d.json") + "'");
  ASSERT_EQ(r.exit_code, 0) << r.err << r.out;
  EXPECT_NE(r.out.find("laser tracker"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("beam:"), std::string::npos) << r.out;
  const auto j = nlohmann::json::parse(testing::ReadText(dir.File("d.json")));
  EXPECT_EQ(j["session"]["instrument"], "tracker");
  EXPECT_LE(j["session"]["beam"]["operator"].get<int>(), 3);
  // The nightly job's report names the tracker's sigmas for what they are: each reading's
  // own, not a theodolite's a-priori arc seconds.
  const auto night = testing::RunArmsig("--db '" + dir.File("d.db") +
                                        "' recalibrate --robot puma760-demo --report '" +
                                        dir.File("report") + "'");
  ASSERT_TRUE(night.exit_code == 0 || night.exit_code == 3) << night.err;
  std::string html;
  for (const auto& e : std::filesystem::recursive_directory_iterator(dir.File("report")))
    if (e.path().extension() == ".html") html = testing::ReadText(e.path().string());
  EXPECT_NE(html.find("laser tracker, stationary mode 200 ms; sigmas: each reading&#39;s own"),
            std::string::npos);
  EXPECT_EQ(html.find("sigma hz 0.5"), std::string::npos);
  std::cout << "tracker demo, 30 configurations: " << j["session"]["software_ms_per_configuration"]
            << " ms software and " << j["session"]["store_ms_per_configuration"]
            << " ms storing per configuration\n";
  EXPECT_EQ(testing::RunArmsig("demo --instrument laser").exit_code, 2);
}

}  // namespace armsig::demo

namespace armsig::demo {
namespace {

// demo --change: each planted change becomes its parameter's shift in the model's units; a
// value a double cannot hold (1e-400, 1e400) or a joint number past an int is refused naming
// --change and the text, never "stod" or "stoi".
// Another day's set-up (`demo --serve --setup N`): the instruments stand elsewhere, so the
// robot's base lies elsewhere in their frame (turned 0.45 rad about the frame's vertical a
// place, and shifted); the robot itself, its errors, is the same one.
TEST(DemoLab, AnotherDaysSetUpMovesTheBaseNotTheRobot) {
  const calibration::RobotModel model = io::ParseRobotModel(io::kUr10Yaml, "built-in UR10");
  testing::TempDir dir;
  auto lab_at = [&](int setup) {
    DemoLabOptions o;
    o.robot = "ur10";
    o.tracker = true;
    o.time_scale = 0.05;
    o.setup = setup;
    o.folder = dir.File("setup" + std::to_string(setup));
    std::filesystem::create_directories(o.folder);
    return std::make_unique<DemoLab>(model, o);
  };
  const auto first = lab_at(0), third = lab_at(2);
  const simulation::VirtualRobot& a = first->robot_truth();
  const simulation::VirtualRobot& b = third->robot_truth();
  EXPECT_EQ(a.true_params, b.true_params);
  const Eigen::Isometry3d moved = b.world_from_base * a.world_from_base.inverse();
  EXPECT_NEAR(Eigen::AngleAxisd(moved.linear()).angle(), 0.9, 1e-9);
  EXPECT_NEAR(Eigen::AngleAxisd(moved.linear()).axis().z(), 1.0, 1e-9);
  EXPECT_GT((b.world_from_base.translation() - a.world_from_base.translation()).norm(), 500.0);
  EXPECT_NEAR(b.world_from_base.translation().norm(), a.world_from_base.translation().norm(), 400.0);
}

TEST(PlantedChanges, AreParsedInTheirUnitsAndAbsurdNumbersAreNamed) {
  const auto model = testing::Puma();
  const Eigen::VectorXd delta =
      ParsePlantedChanges(model, {"joint2_zero=0.02deg", "a3=-50um", "beta4=+1mrad"});
  EXPECT_NEAR(delta(model.IndexOf("gamma2")), 0.02 * std::numbers::pi / 180, 1e-15);
  EXPECT_NEAR(delta(model.IndexOf("a3")), -0.05, 1e-15);
  EXPECT_NEAR(delta(model.IndexOf("beta4")), 1e-3, 1e-15);
  EXPECT_EQ((delta.array() != 0).count(), 3);
  for (const std::string bad :
       {"a3=1e-400mm", "a3=1e400mm", "joint99999999999999_zero=1deg", "link99999999999_length=1mm"}) {
    try {
      ParsePlantedChanges(model, {bad});
      ADD_FAILURE() << bad << " was accepted";
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find("--change"), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find(bad.substr(0, 4)), std::string::npos) << e.what();
    }
  }
}

}  // namespace
}  // namespace armsig::demo
