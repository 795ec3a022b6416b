// Programs that land, checked by running them: a virtual UR10, a KUKA KR 16-sized and an
// ABB IRB 4600-sized arm with planted errors are measured by a virtual tracker, the nightly
// job fits and stores their signature in a real SQLite store, `compensate --program`
// (CompensateProgramFiles) rewrites a URScript, a KRL and a RAPID program, and the virtual
// controllers run the original and the compensated program (their own inverse kinematics on
// their nominal models, simulation/program_runner.h). The tracker measures where every target
// lands; after a rigid fit of the frames the compensated program lands within the noise floor
// where the original misses by millimetres. And the ISO 9283 pose accuracy of a test cube
// run from a compensated URScript program.
#include "workflows/program_compensation.h"

#include <fmt/format.h>
#include <gtest/gtest.h>

#include <filesystem>
#include <iostream>
#include <nlohmann/json.hpp>
#include <random>

#include "calibration/iso9283_cube.h"
#include "calibration/iso9283_figures.h"
#include "calibration/synthetic.h"
#include "core/units.h"
#include "db/observations.h"
#include "db/robots.h"
#include "db/sessions.h"
#include "db/store.h"
#include "io/model_export.h"
#include "programs/krl.h"
#include "programs/rapid.h"
#include "programs/urscript.h"
#include "simulation/program_runner.h"
#include "simulation/virtual_arms.h"
#include "test_support.h"
#include "workflows/iso9283.h"
#include "workflows/lifecycle.h"
#include "workflows/recalibrate.h"

namespace armsig::workflows {
namespace {

using programs::ControllerKind;
using programs::ControllerModel;

constexpr double kTrackerNoiseMm = 0.01;  // σ per coordinate of the calibration's points

Eigen::Isometry3d LabFromBase() {  // where the robot stands in the tracker's frame
  Eigen::Isometry3d t = Eigen::Isometry3d::Identity();
  t.translate(Eigen::Vector3d(1800.0, -600.0, -300.0));
  t.rotate(Eigen::AngleAxisd(2.4, Eigen::Vector3d::UnitZ()));
  return t;
}

// A gripper 180 mm out from the flange, its TCP 10 mm off the axis and tilted.
Eigen::Isometry3d Gripper() {
  Eigen::Isometry3d tool = Eigen::Isometry3d::Identity();
  tool.translate(Eigen::Vector3d(0.0, 10.0, 180.0));
  tool.rotate(Eigen::AngleAxisd(0.2, Eigen::Vector3d::UnitX()));
  return tool;
}

class ProgramsOnVirtualRobots : public ::testing::Test {
 protected:
  testing::TempDir dir_;
  std::string db_path_ = dir_.File("lab.db");

  // Registers the arm, measures `count` random configurations of its truth (the calibration
  // point, σ 0.01 mm; with `six_dof` a 6-DoF probe's orientation too, σ 0.005°) and lets the
  // nightly job fit and store its signature.
  void Calibrate(const std::string& robot, const calibration::RobotModel& model, const Eigen::VectorXd& truth,
                 int count, unsigned seed, bool six_dof) {
    const std::string model_path = dir_.File(robot + ".yaml");
    testing::WriteText(model_path, io::FormatRobotModelYaml(model, robot));
    {
      db::Database db(db_path_);
      ASSERT_TRUE(RegisterRobot(db, robot, model_path));
      std::mt19937 rng(seed);
      const auto configurations = calibration::RandomConfigurations(model, count, rng);
      const auto poses = six_dof ? calibration::SimulateSixDofPoses(model, LabFromBase(), truth,
                                                                    Eigen::Matrix3d::Identity(), configurations,
                                                                    kTrackerNoiseMm, 5e-3 * kRadPerDeg, rng)
                                 : calibration::SimulatePoses(model, LabFromBase(), truth, configurations,
                                                              kTrackerNoiseMm, rng);
      db::WriteTransaction tx(db);
      const int64_t id = *db::FindRobot(db, robot);
      const int64_t session = db::CreateSession(db, id, "", "", "completed", "simulated");
      for (int i = 0; i < static_cast<int>(poses.size()); ++i) {
        db::PointRow point;
        point.pose_id = db::InsertPose(db, session, i, poses[i].id, poses[i].joints_rad, "measured", 1);
        point.point = "target";
        point.position_mm = poses[i].target_in_world;
        point.covariance_mm2 = Eigen::Matrix3d::Constant(NAN);
        point.rays = 1;
        point.orientation = poses[i].orientation;
        db::InsertPoint(db, session, point);
      }
      tx.commit();
    }
    RecalibrateOptions fit;
    fit.db_path = db_path_;
    fit.robot = robot;
    fit.residual_model = "off";
    const auto decision = Recalibrate(fit);
    ASSERT_EQ(decision.outcome, RecalibrationDecision::Outcome::kStored) << decision.Describe();
  }

  ProgramCompensationRun Compensate(const std::string& robot, const std::string& in, const std::string& out,
                                    const std::string& config_dat = "") {
    db::Database db(db_path_, db::OpenMode::kReadOnly);
    ProgramCompensationOptions o;
    o.robot = robot;
    o.program_path = in;
    o.out_path = out;
    o.config_dat = config_dat;
    return CompensateProgramFiles(db, o);
  }

  struct Landing {
    double mean_mm = 0.0, max_mm = 0.0;
    int targets = 0;
  };
  // Runs the program on the virtual controller, measures where each target lands and fits
  // the measured points rigidly onto what `original` commands.
  static Landing Land(const programs::Program& program, const programs::Program& original,
                      const ControllerModel& c, const simulation::VirtualCell& cell, const Eigen::VectorXd& start) {
    const auto run = simulation::RunProgram(program, c, start);
    const auto intended = simulation::RunProgram(original, c, start);
    EXPECT_TRUE(run.skipped.empty()) << run.skipped.front().why;
    EXPECT_EQ(run.targets.size(), intended.targets.size());
    std::vector<Eigen::Vector3d> commanded;
    for (const auto& e : intended.targets) commanded.push_back(e.commanded.translation());
    const auto fit = calibration::iso9283::AlignRigidly(simulation::MeasureLandings(cell, run), commanded);
    EXPECT_TRUE(fit);
    Landing out;
    out.targets = static_cast<int>(fit->residual_mm.size());
    for (double d : fit->residual_mm) {
      out.mean_mm += d / out.targets;
      out.max_mm = std::max(out.max_mm, d);
    }
    return out;
  }

  static std::vector<programs::ProgramFile> ReadProgram(const std::vector<std::string>& paths) {
    std::vector<programs::ProgramFile> files;
    for (const auto& p : paths) files.push_back({p, testing::ReadText(p)});
    return files;
  }
};

// Planted errors of an uncalibrated arm's size: lengths 1 mm, angles 2 mrad, the model's own
// non-geometric terms 0.5 mrad (the UR10's joint harmonics among them): millimetres at the
// TCP after the best rigid fit of the frames, as real arms show.
Eigen::VectorXd Planted(const calibration::RobotModel& model, unsigned seed) {
  std::mt19937 rng(seed);
  return calibration::RandomParameters(model, 1.0, 2e-3, 5e-4, rng);
}

std::string UrPose(const Eigen::Isometry3d& pose) {
  const Eigen::AngleAxisd aa(pose.linear());
  const Eigen::Vector3d r = aa.angle() * aa.axis();
  const Eigen::Vector3d x = pose.translation() / 1000.0;
  return fmt::format("p[{:.12f}, {:.12f}, {:.12f}, {:.12f}, {:.12f}, {:.12f}]", x.x(), x.y(), x.z(), r.x(), r.y(), r.z());
}

std::string UrJoints(const Eigen::VectorXd& q) {
  return fmt::format("[{:.12f}, {:.12f}, {:.12f}, {:.12f}, {:.12f}, {:.12f}]", q(0), q(1), q(2), q(3), q(4), q(5));
}

// Taught configurations in front of the arm, the wrist off its singularity.
std::vector<Eigen::VectorXd> Taught(int count, unsigned seed, const Eigen::VectorXd& centre, double spread) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  std::vector<Eigen::VectorXd> out;
  for (int k = 0; k < count; ++k) {
    Eigen::VectorXd q = centre;
    for (int i = 0; i < 6; ++i) q(i) += spread * u(rng);
    out.push_back(q);
  }
  return out;
}

TEST_F(ProgramsOnVirtualRobots, Ur10CompensatedUrScriptLandsWithinTheNoiseFloor) {
  const auto model = testing::Ur10();
  const Eigen::VectorXd truth = Planted(model, 11);
  Calibrate("ur10", model, truth, 300, 12, /*six_dof=*/true);  // the gripper is 71 mm beyond the probe
  const ControllerModel c = programs::NominalController(model, ControllerKind::kUniversalRobots, "nominal ur10");

  // A PolyScope-style program: the TCP, waypoints as pose + taught joints, MoveL literals.
  Eigen::VectorXd centre(6);
  centre << 0.0, -1.2, 1.3, -1.6, -1.57, 0.0;
  const auto taught = Taught(24, 13, centre, 0.35);
  std::string text = "def checked():\n  set_tcp(" + UrPose(Gripper()) + ")\n";
  for (int k = 0; k < 6; ++k) {
    text += fmt::format("  global Waypoint_{0}_p={1}\n  global Waypoint_{0}_q={2}\n", k + 1,
                        UrPose(programs::TcpPose(c, taught[static_cast<std::size_t>(k)], Gripper())),
                        UrJoints(taught[static_cast<std::size_t>(k)]));
  }
  text += "  while (True):\n";
  for (int k = 0; k < 6; ++k)
    text += fmt::format("    movej(get_inverse_kin(Waypoint_{0}_p, qnear=Waypoint_{0}_q), a=1.39, v=1.04)\n", k + 1);
  for (std::size_t k = 6; k < taught.size(); ++k)
    text += "    movel(" + UrPose(programs::TcpPose(c, taught[k], Gripper())) + ", a=1.2, v=0.25)\n";
  text += "    movej(" + UrJoints(taught[3]) + ")\n  end\nend\n";
  testing::WriteText(dir_.File("checked.script"), text);

  const auto run = Compensate("ur10", dir_.File("checked.script"), dir_.File("compensated.script"));
  ASSERT_EQ(run.result.refused, 0) << FormatProgramCompensation(run);
  ASSERT_EQ(run.result.targets.size(), 25u);
  for (const auto& t : run.result.targets) {
    EXPECT_EQ(t.status, programs::TargetStatus::kOk) << t.why;
    // Inside what the set was fitted on, and promised to the tracker's noise.
    EXPECT_TRUE(t.inside_support) << t.support;
    EXPECT_LT(t.sigma_mm, 0.05);
  }
  ASSERT_EQ(run.written.size(), 1u);
  EXPECT_NE(run.volume.find("300 configurations"), std::string::npos) << run.volume;
  EXPECT_NE(run.volume.find("stored with the set"), std::string::npos) << run.volume;

  const auto original = programs::ParseUrScript({"checked.script", text});
  const auto compensated = programs::ParseUrScript(ReadProgram({dir_.File("compensated.script")})[0]);
  const simulation::VirtualCell cell{{model, truth}, LabFromBase(), {}, 0.0, 21};
  const Landing before = Land(original, original, c, cell, taught[0]);
  const Landing after = Land(compensated, original, c, cell, taught[0]);
  EXPECT_EQ(after.targets, 25);
  EXPECT_GT(before.mean_mm, 1.0);
  EXPECT_LE(after.mean_mm, 0.05);
  // Only the targets' numbers changed: the lines are the same, in the same order.
  EXPECT_EQ(std::count(text.begin(), text.end(), '\n'),
            std::count(compensated.files[0].text.begin(), compensated.files[0].text.end(), '\n'));
  std::cout << fmt::format("UR10 URScript: original {:.3f} mm mean ({:.3f} worst), compensated {:.4f} mm ({:.4f})\n",
                           before.mean_mm, before.max_mm, after.mean_mm, after.max_mm);
  RecordProperty("before_mean_mm", fmt::format("{:.3f}", before.mean_mm));
  RecordProperty("after_mean_mm", fmt::format("{:.4f}", after.mean_mm));
}

TEST_F(ProgramsOnVirtualRobots, KukaCompensatedKrlLandsWithinTheNoiseFloor) {
  // Position-only data: the TCP of the program's tool is the calibration reflector's place
  // (150 mm out on the flange axis), where the set knows the arm.
  auto model = simulation::KukaKr16Like();
  Eigen::Isometry3d reflector = Eigen::Isometry3d::Identity();
  reflector.translate(Eigen::Vector3d(0.0, 0.0, 150.0));
  model.tool_mm = model.flange * reflector.translation();
  const Eigen::VectorXd truth = Planted(model, 31);
  Calibrate("kr16", model, truth, 300, 32, /*six_dof=*/false);
  const ControllerModel c = programs::NominalController(model, ControllerKind::kKuka, "nominal kr16-like");

  Eigen::VectorXd centre(6);
  centre << 0.0, -1.3, 1.7, 0.6, 0.9, 0.6;  // A4 and A6 away from 0, where their Turn bits flip
  const auto taught = Taught(20, 33, centre, 0.3);
  // The tool is TOOL_DATA[1] of the robot's $config.dat; base 0.
  const Eigen::Vector3d abc_tool = programs::KukaAbcFromRotation(reflector.linear(), Eigen::Vector3d::Zero()) / kRadPerDeg;
  testing::WriteText(dir_.File("$config.dat"),
                     fmt::format("DEFDAT $CONFIG\nDECL FRAME TOOL_DATA[16]\nTOOL_DATA[1]={{X {:.4f},Y {:.4f},Z {:.4f},A "
                                 "{:.6f},B {:.6f},C {:.6f}}}\nENDDAT\n",
                                 reflector.translation().x(), reflector.translation().y(), reflector.translation().z(),
                                 abc_tool.x(), abc_tool.y(), abc_tool.z()));
  std::string src = "&ACCESS RVP\n&REL 1\nDEF checked( )\n;FOLD INI;%{PE}\n  BAS (#INITMOV,0 )\n;ENDFOLD (INI)\n";
  std::string dat = "&ACCESS RVP\n&REL 1\nDEFDAT  checked\n";
  for (std::size_t k = 0; k < taught.size(); ++k) {
    const Eigen::Isometry3d pose = programs::TcpPose(c, taught[k], reflector);
    const Eigen::Vector3d abc = programs::KukaAbcFromRotation(pose.linear(), Eigen::Vector3d::Zero()) / kRadPerDeg;
    const auto a = programs::ConfigurationOf(c, taught[k]);
    const bool lin = k % 3 == 2;
    src += fmt::format(
        ";FOLD {0} P{1} Vel=100 % PDAT{1} Tool[1] Base[0];%{{PE}}\n$BWDSTART=FALSE\nPDAT_ACT=PPDAT{1}\n"
        "FDAT_ACT=FP{1}\nBAS(#{2},100)\n{0} XP{1}\n;ENDFOLD\n",
        lin ? "LIN" : "PTP", k + 1, lin ? "CP_PARAMS" : "PTP_PARAMS");
    dat += fmt::format(
        "DECL E6POS XP{}={{X {:.4f},Y {:.4f},Z {:.4f},A {:.5f},B {:.5f},C {:.5f},S {},T {},E1 0.0,E2 0.0,E3 0.0,E4 0.0,"
        "E5 0.0,E6 0.0}}\nDECL FDAT FP{}={{TOOL_NO 1,BASE_NO 0,IPO_FRAME #BASE,POINT2[] \" \",TQ_STATE FALSE}}\n",
        k + 1, pose.translation().x(), pose.translation().y(), pose.translation().z(), abc.x(), abc.y(), abc.z(),
        a.kuka_status, a.kuka_turn, k + 1);
  }
  src += fmt::format("PTP {{A1 {:.4f}, A2 {:.4f}, A3 {:.4f}, A4 {:.4f}, A5 {:.4f}, A6 {:.4f}}}\nEND\n",
                     taught[0](0) / kRadPerDeg, taught[0](1) / kRadPerDeg, taught[0](2) / kRadPerDeg,
                     taught[0](3) / kRadPerDeg, taught[0](4) / kRadPerDeg, taught[0](5) / kRadPerDeg);
  dat += "ENDDAT\n";
  testing::WriteText(dir_.File("checked.src"), src);
  testing::WriteText(dir_.File("checked.dat"), dat);

  std::filesystem::create_directories(dir_.File("out"));
  const auto run = Compensate("kr16", dir_.File("checked.src"), dir_.File("out/checked.src"), dir_.File("$config.dat"));
  ASSERT_EQ(run.result.refused, 0) << FormatProgramCompensation(run);
  ASSERT_EQ(run.result.targets.size(), 21u);
  for (const auto& t : run.result.targets) EXPECT_EQ(t.status, programs::TargetStatus::kOk) << t.why;
  ASSERT_EQ(run.written.size(), 2u);  // the .src and its .dat
  // The .src's motions are not the numbers: it comes back unchanged but for the axis literal.
  const auto files = ReadProgram({dir_.File("out/checked.src"), dir_.File("out/checked.dat")});
  EXPECT_EQ(files[0].text.substr(0, src.rfind("PTP {A1")), src.substr(0, src.rfind("PTP {A1")));

  const programs::KrlControllerData config = programs::ParseKrlConfigDat({"$config.dat", testing::ReadText(dir_.File("$config.dat"))});
  const auto original = programs::ParseKrl({"checked.src", src}, programs::ProgramFile{"checked.dat", dat}, &config);
  const auto compensated = programs::ParseKrl(files[0], files[1], &config);
  const simulation::VirtualCell cell{{model, truth}, LabFromBase(), {}, 0.0, 41};
  const Landing before = Land(original, original, c, cell, taught[0]);
  const Landing after = Land(compensated, original, c, cell, taught[0]);
  EXPECT_EQ(after.targets, 21);
  EXPECT_GT(before.mean_mm, 1.0);
  EXPECT_LE(after.mean_mm, 0.05);
  std::cout << fmt::format("{}: original {:.3f} mm mean ({:.3f} worst), compensated {:.4f} mm ({:.4f})\n", "KUKA KRL",
                           before.mean_mm, before.max_mm, after.mean_mm, after.max_mm);
}

TEST_F(ProgramsOnVirtualRobots, AbbCompensatedRapidLandsWithinTheNoiseFloor) {
  const auto model = simulation::AbbIrb4600Like();
  const Eigen::VectorXd truth = Planted(model, 51);
  Calibrate("irb4600", model, truth, 300, 52, /*six_dof=*/true);
  const ControllerModel c = programs::NominalController(model, ControllerKind::kAbb, "nominal irb4600-like");

  Eigen::VectorXd centre(6);
  centre << 0.0, 0.3, -0.2, 0.0, 0.9, 0.0;
  const auto taught = Taught(20, 53, centre, 0.3);
  // The targets in a work object on a table: uframe 1.2 m out, turned 90° about z.
  Eigen::Isometry3d table = Eigen::Isometry3d::Identity();
  table.translate(Eigen::Vector3d(1200.0, -300.0, 400.0));
  table.rotate(Eigen::AngleAxisd(kPi / 2, Eigen::Vector3d::UnitZ()));
  const Eigen::Quaterniond tq(Gripper().linear()), uq(table.linear());
  std::string mod = fmt::format(
      "MODULE Checked\n  PERS tooldata tGripper:=[TRUE,[[{:.4f},{:.4f},{:.4f}],[{:.9f},{:.9f},{:.9f},{:.9f}]],"
      "[2,[0,0,100],[1,0,0,0],0,0,0]];\n  TASK PERS wobjdata wTable:=[FALSE,TRUE,\"\",[[{:.4f},{:.4f},{:.4f}],"
      "[{:.9f},{:.9f},{:.9f},{:.9f}]],[[0,0,0],[1,0,0,0]]];\n",
      Gripper().translation().x(), Gripper().translation().y(), Gripper().translation().z(), tq.w(), tq.x(), tq.y(),
      tq.z(), table.translation().x(), table.translation().y(), table.translation().z(), uq.w(), uq.x(), uq.y(), uq.z());
  for (std::size_t k = 0; k < taught.size(); ++k) {
    const Eigen::Isometry3d pose = table.inverse() * programs::TcpPose(c, taught[k], Gripper());
    const Eigen::Quaterniond q(pose.linear());
    const auto cf = programs::ConfigurationOf(c, taught[k]).abb_cf;
    mod += fmt::format("  CONST robtarget p{}:=[[{:.4f},{:.4f},{:.4f}],[{:.9f},{:.9f},{:.9f},{:.9f}],[{},{},{},{}],"
                       "[9E+09,9E+09,9E+09,9E+09,9E+09,9E+09]];\n",
                       k + 1, pose.translation().x(), pose.translation().y(), pose.translation().z(), q.w(), q.x(),
                       q.y(), q.z(), cf[0], cf[1], cf[2], cf[3]);
  }
  mod += fmt::format("  CONST jointtarget jStart:=[[{:.4f},{:.4f},{:.4f},{:.4f},{:.4f},{:.4f}],[9E9,9E9,9E9,9E9,9E9,9E9]];\n",
                     taught[0](0) / kRadPerDeg, taught[0](1) / kRadPerDeg, taught[0](2) / kRadPerDeg,
                     taught[0](3) / kRadPerDeg, taught[0](4) / kRadPerDeg, taught[0](5) / kRadPerDeg);
  mod += "  PROC main()\n    MoveAbsJ jStart\\NoEOffs, v1000, fine, tGripper;\n";
  for (std::size_t k = 0; k < taught.size(); ++k)
    mod += fmt::format("    Move{} p{}, v500, fine, tGripper\\WObj:=wTable;\n", k % 2 ? "L" : "J", k + 1);
  mod += "  ENDPROC\nENDMODULE\n";
  testing::WriteText(dir_.File("Checked.mod"), mod);

  const auto run = Compensate("irb4600", dir_.File("Checked.mod"), dir_.File("Compensated.mod"));
  ASSERT_EQ(run.result.refused, 0) << FormatProgramCompensation(run);
  ASSERT_EQ(run.result.targets.size(), 21u);
  for (const auto& t : run.result.targets) EXPECT_EQ(t.status, programs::TargetStatus::kOk) << t.why;

  const auto original = programs::ParseRapid({"Checked.mod", mod});
  const auto compensated = programs::ParseRapid(ReadProgram({dir_.File("Compensated.mod")})[0]);
  const simulation::VirtualCell cell{{model, truth}, LabFromBase(), {}, 0.0, 61};
  const Landing before = Land(original, original, c, cell, taught[0]);
  const Landing after = Land(compensated, original, c, cell, taught[0]);
  EXPECT_EQ(after.targets, 21);
  // The same planted errors leave less after the frame fit over this arm's smaller region
  // of targets (0.4 mm): the compensated program still takes nine tenths of it off.
  EXPECT_GT(before.mean_mm, 0.3);
  EXPECT_LE(after.mean_mm, 0.05);
  EXPECT_LT(after.mean_mm, 0.1 * before.mean_mm);
  std::cout << fmt::format("{}: original {:.3f} mm mean ({:.3f} worst), compensated {:.4f} mm ({:.4f})\n", "ABB RAPID",
                           before.mean_mm, before.max_mm, after.mean_mm, after.max_mm);
}

}  // namespace
}  // namespace armsig::workflows
