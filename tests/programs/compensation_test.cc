// Program compensation against synthetic truth: a robot with planted errors, a signature
// that is that truth, the program run by the controller's own inverse (simulation/
// program_runner.h) and the true robot's TCP compared with what the program meant. Every
// refusal in a test of its own.
#include "programs/compensation.h"

#include <gtest/gtest.h>
#include <fmt/format.h>

#include <random>

#include "programs/krl.h"
#include "program_test_support.h"
#include "programs/rapid.h"
#include "programs/urscript.h"
#include "simulation/program_runner.h"

namespace armsig::programs {
namespace {

// The robot as a signature describes it: its model and parameters, no map, no stored
// support.
SignedRobot Signed(const calibration::RobotModel& model, Eigen::VectorXd params, bool orientation_measured) {
  SignedRobot robot;
  robot.model = &model;
  robot.params = std::move(params);
  robot.orientation_measured = orientation_measured;
  return robot;
}

Eigen::Isometry3d UrTool() {  // a gripper 180 mm out, its TCP turned about x
  Eigen::Isometry3d tool = Eigen::Isometry3d::Identity();
  tool.translate(Eigen::Vector3d(0.0, 10.0, 180.0));
  tool.rotate(Eigen::AngleAxisd(0.2, Eigen::Vector3d::UnitX()));
  return tool;
}

std::string PoseLiteral(const Eigen::Isometry3d& pose) {
  const Eigen::AngleAxisd aa(pose.linear());
  const Eigen::Vector3d r = aa.angle() * aa.axis();
  const Eigen::Vector3d x = pose.translation() / 1000.0;
  return fmt::format("p[{:.9f}, {:.9f}, {:.9f}, {:.9f}, {:.9f}, {:.9f}]", x.x(), x.y(), x.z(), r.x(), r.y(), r.z());
}

std::string JointLiteral(const Eigen::VectorXd& q) {
  return fmt::format("[{:.9f}, {:.9f}, {:.9f}, {:.9f}, {:.9f}, {:.9f}]", q(0), q(1), q(2), q(3), q(4), q(5));
}

// Taught configurations of a UR10: elbow up, wrist off its singularity, spread over the
// front half of the workspace.
std::vector<Eigen::VectorXd> UrConfigurations(int count, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  std::vector<Eigen::VectorXd> out;
  for (int k = 0; k < count; ++k) {
    Eigen::VectorXd q(6);
    q << 0.8 * u(rng), -1.2 + 0.4 * u(rng), 1.3 + 0.4 * u(rng), -1.6 + 0.5 * u(rng), -1.57 + 0.4 * u(rng),
        0.5 * u(rng);
    out.push_back(q);
  }
  return out;
}

// A URScript program: the TCP, a joint move home, then a MoveL to each pose (the
// controller's model at the taught joints).
std::string UrProgram(const ControllerModel& c, const std::vector<Eigen::VectorXd>& taught) {
  std::string text = "def test_program():\n  set_tcp(" + PoseLiteral(UrTool()) + ")\n";
  text += "  movej(" + JointLiteral(taught.front()) + ", a=1.4, v=1.05)\n";
  for (std::size_t k = 1; k < taught.size(); ++k)
    text += "  movel(" + PoseLiteral(TcpPose(c, taught[k], UrTool())) + ", a=1.2, v=0.25)\n";
  return text + "end\n";
}

struct Landed {
  double mean_mm = 0.0, max_mm = 0.0;
};

// Runs `program` on the controller and compares where the true robot's TCP lands with what
// `intended` (the original program's commands) states.
Landed Land(const Program& program, const ControllerModel& c, const simulation::TrueRobot& truth,
            const std::vector<Eigen::Isometry3d>& intended, const Eigen::VectorXd& start) {
  const simulation::Execution run = simulation::RunProgram(program, c, start);
  EXPECT_TRUE(run.skipped.empty());
  EXPECT_EQ(run.targets.size(), intended.size());
  Landed out;
  for (std::size_t k = 0; k < run.targets.size() && k < intended.size(); ++k) {
    const double d =
        (simulation::TrueTcp(truth, run.targets[k].tool, run.targets[k].joints_rad).translation() -
         intended[k].translation())
            .norm();
    out.mean_mm += d / static_cast<double>(intended.size());
    out.max_mm = std::max(out.max_mm, d);
  }
  return out;
}

std::vector<Eigen::Isometry3d> Commanded(const Program& program, const ControllerModel& c, const Eigen::VectorXd& start) {
  std::vector<Eigen::Isometry3d> out;
  for (const auto& e : simulation::RunProgram(program, c, start).targets) out.push_back(e.commanded);
  return out;
}

// With the signature equal to the truth, the compensated program puts the true robot on
// every target (to the numbers' written resolution); the original misses by the planted
// errors' millimetres.
TEST(CompensateProgram, ExactSignatureLandsOnEveryUrTarget) {
  const auto model = testing::Ur10();
  const ControllerModel c = NominalController(model, ControllerKind::kUniversalRobots, "nominal ur10");
  const simulation::TrueRobot truth{model, testing::PlantedErrors(model, 1), {}};
  const auto taught = UrConfigurations(12, 2);
  const Program program = ParseUrScript({"t.script", UrProgram(c, taught)});
  ASSERT_EQ(program.motions.size(), 12u);

  const SignedRobot robot = Signed(model, truth.params, true);
  const ProgramCompensation r = CompensateProgram(program, c, robot, nullptr);
  ASSERT_EQ(r.targets.size(), 12u);
  for (const auto& t : r.targets) {
    EXPECT_EQ(t.status, TargetStatus::kOk) << t.why;
    EXPECT_TRUE(t.written);
    EXPECT_GT(t.correction_mm, 0.05);  // the planted errors move every target
  }
  const Program compensated = ParseUrScript({"t.script", ApplyEdits(program.files, r.edits)[0]});
  const auto intended = Commanded(program, c, taught.front());
  const Landed before = Land(program, c, truth, intended, taught.front());
  const Landed after = Land(compensated, c, truth, intended, taught.front());
  EXPECT_GT(before.mean_mm, 0.5);
  EXPECT_LT(after.max_mm, 1e-5);  // the written numbers' resolution: 1 nm, 1e-9 rad
}

// A signature of zero changes nothing: the file comes back byte for byte.
TEST(CompensateProgram, ZeroSignatureChangesNoByte) {
  const auto model = testing::Ur10();
  const ControllerModel c = NominalController(model, ControllerKind::kUniversalRobots, "nominal ur10");
  const Program program = ParseUrScript({"t.script", UrProgram(c, UrConfigurations(8, 3))});
  const SignedRobot robot = Signed(model, Eigen::VectorXd::Zero(model.num_parameters()), false);
  const ProgramCompensation r = CompensateProgram(program, c, robot, nullptr);
  for (const auto& t : r.targets) EXPECT_EQ(t.status, TargetStatus::kOk) << t.why;
  EXPECT_TRUE(r.edits.empty());
  EXPECT_EQ(ApplyEdits(program.files, r.edits)[0], program.files[0].text);
}

// ---- Refusals ----

class UrRefusals : public ::testing::Test {
 protected:
  calibration::RobotModel model = testing::Ur10();
  ControllerModel c = NominalController(model, ControllerKind::kUniversalRobots, "nominal ur10");
  Eigen::VectorXd truth = testing::PlantedErrors(model, 4);
  SignedRobot robot = Signed(model, truth, false);

  // One MoveJ to the pose the controller's model gives these joints, those joints its qnear.
  Program OneTarget(const Eigen::VectorXd& q) {
    return ParseUrScript({"one.script", "set_tcp(" + PoseLiteral(UrTool()) + ")\nmovej(get_inverse_kin(" +
                                            PoseLiteral(TcpPose(c, q, UrTool())) + ", qnear=" +
                                            JointLiteral(q) + "))\n"});
  }
  // A volume of configurations around `centre` (±0.3 rad each), its points where the
  // signature puts its calibration point there.
  ValidatedVolume Around(const Eigen::VectorXd& centre) {
    std::mt19937 rng(9);
    std::uniform_real_distribution<double> u(-0.3, 0.3);
    std::vector<Eigen::VectorXd> joints;
    std::vector<Eigen::Vector3d> points;
    for (int k = 0; k < 200; ++k) {
      Eigen::VectorXd q = centre;
      for (int i = 0; i < 6; ++i) q(i) += u(rng);
      joints.push_back(q);
      points.push_back(SignedCalibrationPoint(robot, q));
    }
    return ValidatedVolume(calibration::ArcsCovering(joints, 6), points, "session 1: 200 configurations");
  }
};

TEST_F(UrRefusals, OutsideTheJointRangeIsRefusedAndNothingWritten) {
  Eigen::VectorXd q(6);
  q << 0.0, -1.2, 1.3, -1.6, -1.57, 0.0;
  Eigen::VectorXd far = q;
  far(0) = 1.0;  // joint 1 beyond the validated ±0.3 rad
  const ValidatedVolume volume = Around(q);
  const Program program = OneTarget(far);
  const ProgramCompensation r = CompensateProgram(program, c, robot, &volume);
  ASSERT_EQ(r.targets.size(), 1u);
  EXPECT_EQ(r.targets[0].status, TargetStatus::kOutsideJointRange);
  EXPECT_NE(r.targets[0].why.find("joint 1 at 57."), std::string::npos) << r.targets[0].why;
  EXPECT_NE(r.targets[0].why.find("session 1"), std::string::npos);
  EXPECT_EQ(r.refused, 1);
  EXPECT_FALSE(r.written());
  EXPECT_TRUE(r.edits.empty());
  // --allow-outside: written all the same.
  CompensationOptions allow;
  allow.allow_outside = true;
  const ProgramCompensation a = CompensateProgram(program, c, robot, &volume, allow);
  EXPECT_TRUE(a.written());
  EXPECT_TRUE(a.targets[0].written);
  EXPECT_FALSE(a.edits.empty());
  // Inside, the same program is written.
  const ProgramCompensation inside = CompensateProgram(OneTarget(q), c, robot, &volume);
  EXPECT_EQ(inside.targets[0].status, TargetStatus::kOk) << inside.targets[0].why;
  EXPECT_TRUE(inside.written());
}

// Each target carries what the set promises there: inside its support (the arcs it was
// fitted on), σ = √(σ_param² + s_inside²); outside, the larger held-out s_outside. σ_param
// checked against the parameter's derivative at the TCP by central differences.
TEST_F(UrRefusals, EachTargetCarriesItsSupportAndPredictedSigma) {
  Eigen::VectorXd q(6);
  q << 0.0, -1.2, 1.3, -1.6, -1.57, 0.0;
  const ValidatedVolume volume = Around(q);
  calibration::SetValidity validity;
  validity.term_arcs = volume.arcs();
  validity.sigma_inside_mm = 0.05;
  validity.sigma_outside_mm = 0.4;
  SignedRobot held = robot;
  held.validity = &validity;
  held.identified = {1};  // one parameter with a standard error of 0.2 (its unit: mm or rad)
  held.covariance = Eigen::MatrixXd::Constant(1, 1, 0.04);
  CompensationOptions allow;
  allow.allow_outside = true;

  const ProgramCompensation inside = CompensateProgram(OneTarget(q), c, held, &volume, allow);
  const TargetReport& t = inside.targets.at(0);
  ASSERT_EQ(t.status, TargetStatus::kOk) << t.why;
  EXPECT_TRUE(t.inside_support);
  EXPECT_EQ(t.support, "inside");
  const double h = 1e-6;
  SignedRobot plus = robot, minus = robot;
  plus.params(1) += h;
  minus.params(1) -= h;
  const Eigen::Vector3d d = (SignedTcp(plus, UrTool(), t.compensated_joints_rad).tcp.translation() -
                             SignedTcp(minus, UrTool(), t.compensated_joints_rad).tcp.translation()) /
                            (2 * h);
  const double parametric = d.norm() * 0.2 / std::sqrt(3.0);
  EXPECT_GT(parametric, 0.01);
  EXPECT_NEAR(t.sigma_mm, std::hypot(parametric, 0.05), 1e-6);

  Eigen::VectorXd far = q;
  far(0) = 1.0;  // joint 1 beyond its arc: refused, and with --allow-outside written with the outside σ
  const ProgramCompensation outside = CompensateProgram(OneTarget(far), c, held, &volume, allow);
  const TargetReport& o = outside.targets.at(0);
  EXPECT_EQ(o.status, TargetStatus::kOutsideJointRange);
  EXPECT_TRUE(o.written);
  EXPECT_FALSE(o.inside_support);
  EXPECT_NE(o.support.find("joint 1 at 57."), std::string::npos) << o.support;
  EXPECT_GT(o.sigma_mm, 0.4);
  EXPECT_LT(o.sigma_mm, std::hypot(0.4, 1.5 * parametric));

  // A set that stores no support nor σ promises nothing it cannot back: inside, σ unknown.
  const ProgramCompensation bare = CompensateProgram(OneTarget(q), c, robot, nullptr);
  EXPECT_TRUE(bare.targets.at(0).inside_support);
  EXPECT_TRUE(std::isnan(bare.targets.at(0).sigma_mm));
}

TEST_F(UrRefusals, OutsideTheMeasuredVolumeIsRefused) {
  Eigen::VectorXd q(6);
  q << 0.0, -1.2, 1.3, -1.6, -1.57, 0.0;
  // Every joint fitted over its whole turn, the points only in a small box far from the target.
  std::vector<Eigen::Vector3d> points = {{-500, -500, 1500}, {-400, -500, 1500}, {-500, -400, 1500}, {-500, -500, 1600}};
  const ValidatedVolume volume(std::vector<calibration::JointArc>(6), points, "session 2");
  const ProgramCompensation r = CompensateProgram(OneTarget(q), c, robot, &volume);
  EXPECT_EQ(r.targets[0].status, TargetStatus::kOutsideMeasuredVolume);
  EXPECT_NE(r.targets[0].why.find("mm outside the volume measured in session 2"), std::string::npos)
      << r.targets[0].why;
  EXPECT_FALSE(r.written());
}

TEST_F(UrRefusals, OutOfReachIsRefused) {
  const Program program = ParseUrScript({"far.script", "movel(p[3.0, 0.2, 0.5, 0, 3.14, 0])\n"});
  const ProgramCompensation r = CompensateProgram(program, c, robot, nullptr);
  EXPECT_EQ(r.targets[0].status, TargetStatus::kOutOfReach);
  EXPECT_NE(r.targets[0].why.find("out of reach"), std::string::npos) << r.targets[0].why;
  EXPECT_FALSE(r.written());
}

// A PolyScope waypoint whose q does not put the TCP on its p (taught with another TCP, or
// the controller's model is not the one assumed) is refused, not guessed.
TEST_F(UrRefusals, TaughtJointsThatMissTheirPoseAreRefused) {
  Eigen::VectorXd q(6);
  q << 0.1, -1.2, 1.3, -1.6, -1.57, 0.2;
  Eigen::Isometry3d pose = TcpPose(c, q, UrTool());
  const std::string agreeing = "set_tcp(" + PoseLiteral(UrTool()) + ")\nglobal W_p=" + PoseLiteral(pose) +
                               "\nglobal W_q=" + JointLiteral(q) + "\nmovej(get_inverse_kin(W_p, qnear=W_q))\n";
  const ProgramCompensation ok = CompensateProgram(ParseUrScript({"w.script", agreeing}), c, robot, nullptr);
  EXPECT_EQ(ok.targets[0].status, TargetStatus::kOk) << ok.targets[0].why;
  EXPECT_EQ(ok.edits.size(), 12u);  // the pose's 6 numbers and the waypoint's joints

  pose.translation().x() += 1.0;
  const std::string missing = "set_tcp(" + PoseLiteral(UrTool()) + ")\nglobal W_p=" + PoseLiteral(pose) +
                              "\nglobal W_q=" + JointLiteral(q) + "\nmovej(get_inverse_kin(W_p, qnear=W_q))\n";
  const ProgramCompensation r = CompensateProgram(ParseUrScript({"w.script", missing}), c, robot, nullptr);
  EXPECT_EQ(r.targets[0].status, TargetStatus::kTaughtJointsMissPose);
  EXPECT_NE(r.targets[0].why.find("its taught joints W_q put the TCP 1.000 mm"), std::string::npos)
      << r.targets[0].why;
  EXPECT_FALSE(r.written());
}

// A KUKA point taught with A1 just above 0 (Turn bit 0 clear) whose compensated A1 falls
// below 0 needs another Turn: refused.
TEST(CompensateProgram, KukaConfigurationChangeIsRefused) {
  const auto model = testing::Kr16_2();
  const ControllerModel c = NominalController(model, ControllerKind::kKuka, "nominal kr16_2");
  Eigen::VectorXd q(6);
  q << 0.001, -1.3, 1.6, 0.3, 0.9, 0.4;
  const ArmConfiguration a = ConfigurationOf(c, q);
  const Eigen::Isometry3d pose = TcpPose(c, q, Eigen::Isometry3d::Identity());
  const Eigen::Vector3d abc = KukaAbcFromRotation(pose.linear(), Eigen::Vector3d::Zero()) / kRadPerDeg;
  const std::string src = "DEF p()\n$TOOL = $NULLFRAME\n$BASE = $WORLD\nPTP XP1\nEND\n";
  const std::string dat = fmt::format(
      "DEFDAT p\nDECL E6POS XP1={{X {:.4f},Y {:.4f},Z {:.4f},A {:.5f},B {:.5f},C {:.5f},S {},T {}}}\nENDDAT\n",
      pose.translation().x(), pose.translation().y(), pose.translation().z(), abc.x(), abc.y(), abc.z(),
      a.kuka_status, a.kuka_turn);
  const Program program = ParseKrl({"p.src", src}, ProgramFile{"p.dat", dat});
  Eigen::VectorXd params = Eigen::VectorXd::Zero(model.num_parameters());
  const SignedRobot small = Signed(model, params, false);
  params(5) = 0.002;  // γ1: the real joint 1 stands 2 mrad further: A1 must go 2 mrad back
  const SignedRobot turned = Signed(model, params, false);
  EXPECT_EQ(CompensateProgram(program, c, small, nullptr).targets[0].status, TargetStatus::kOk);
  const ProgramCompensation r = CompensateProgram(program, c, turned, nullptr);
  EXPECT_EQ(r.targets[0].status, TargetStatus::kConfigurationChange);
  EXPECT_NE(r.targets[0].why.find(fmt::format("configuration S {} T {}, the program's S {} T {}", a.kuka_status,
                                              a.kuka_turn | 1, a.kuka_status, a.kuka_turn)),
            std::string::npos)
      << r.targets[0].why;
  EXPECT_FALSE(r.written());
}

// The report's σ and support describe the compensated joints whatever refuses the target:
// a target refused for its configuration, with its compensated joints in the report, carries
// the σ the set predicts there (its parameters' covariance through the chain's derivatives
// with the held-out figure), never a NaN beside joints it names. A set without a held-out
// figure beside its fit poses promises the one among them there, never less.
TEST(CompensateProgram, ATargetRefusedForItsConfigurationKeepsItsPromise) {
  const auto model = testing::Kr16_2();
  const ControllerModel c = NominalController(model, ControllerKind::kKuka, "nominal kr16_2");
  Eigen::VectorXd q(6);
  q << 0.001, -1.3, 1.6, 0.3, 0.9, 0.4;
  const ArmConfiguration a = ConfigurationOf(c, q);
  const Eigen::Isometry3d pose = TcpPose(c, q, Eigen::Isometry3d::Identity());
  const Eigen::Vector3d abc = KukaAbcFromRotation(pose.linear(), Eigen::Vector3d::Zero()) / kRadPerDeg;
  const std::string src = "DEF p()\n$TOOL = $NULLFRAME\n$BASE = $WORLD\nPTP XP1\nEND\n";
  const std::string dat = fmt::format(
      "DEFDAT p\nDECL E6POS XP1={{X {:.4f},Y {:.4f},Z {:.4f},A {:.5f},B {:.5f},C {:.5f},S {},T {}}}\nENDDAT\n",
      pose.translation().x(), pose.translation().y(), pose.translation().z(), abc.x(), abc.y(), abc.z(),
      a.kuka_status, a.kuka_turn);
  const Program program = ParseKrl({"p.src", src}, ProgramFile{"p.dat", dat});
  Eigen::VectorXd params = Eigen::VectorXd::Zero(model.num_parameters());
  params(5) = 0.002;  // γ1: A1 must go 2 mrad back, across 0: another Turn
  SignedRobot robot = Signed(model, params, false);
  // One identified parameter, the length of the first link's x (0.01 mm σ), and held-out
  // error among the fit poses only.
  calibration::SetValidity validity;
  validity.sigma_inside_mm = 0.02;
  robot.validity = &validity;
  robot.identified = {0};
  robot.covariance = Eigen::MatrixXd::Constant(1, 1, 1e-4);
  const ProgramCompensation r = CompensateProgram(program, c, robot, nullptr);
  ASSERT_EQ(r.targets[0].status, TargetStatus::kConfigurationChange);
  ASSERT_EQ(r.targets[0].compensated_joints_rad.size(), 6);
  // Independently: the first parameter's derivative at the TCP, through its σ.
  calibration::RobotModel at_tcp = model;
  at_tcp.tool_mm = model.flange.translation();
  calibration::Kinematics kin(at_tcp);
  Eigen::Matrix<double, 3, Eigen::Dynamic> j(3, model.num_parameters());
  kin.PositionAndJacobian(Eigen::Isometry3d::Identity(), params, r.targets[0].compensated_joints_rad.data(), j);
  const double parametric = 0.01 * j.col(0).norm() / std::sqrt(3.0);
  EXPECT_NEAR(r.targets[0].sigma_mm, std::hypot(parametric, 0.02), 1e-9);
  EXPECT_EQ(r.targets[0].support, "inside");
  // Beside the fit poses (no held-out figure there): the figure among them, not less.
  EXPECT_DOUBLE_EQ(calibration::PredictionSigmaMm(parametric, validity, false), std::hypot(parametric, 0.02));
  validity.sigma_outside_mm = 0.05;
  EXPECT_DOUBLE_EQ(calibration::PredictionSigmaMm(parametric, validity, false), std::hypot(parametric, 0.05));
}

// A robtarget whose confdata fits none of its pose's solutions is refused.
TEST(CompensateProgram, RapidConfdataThatMissesItsPoseIsRefused) {
  const auto model = testing::Irb4600();
  const ControllerModel c = NominalController(model, ControllerKind::kAbb, "nominal irb4600");
  Eigen::VectorXd q(6);
  q << 0.3, 0.2, -0.1, 0.4, 0.7, -0.2;
  const Eigen::Isometry3d pose = TcpPose(c, q, Eigen::Isometry3d::Identity());
  const Eigen::Quaterniond rot(pose.linear());
  const auto cf = ConfigurationOf(c, q).abb_cf;
  auto module = [&](int cf1) {
    return fmt::format(
        "MODULE M\n  CONST robtarget p1:=[[{:.4f},{:.4f},{:.4f}],[{:.9f},{:.9f},{:.9f},{:.9f}],[{},{},{},{}],"
        "[9E9,9E9,9E9,9E9,9E9,9E9]];\n  PROC main()\n    MoveJ p1, v100, fine, tool0;\n  ENDPROC\nENDMODULE\n",
        pose.translation().x(), pose.translation().y(), pose.translation().z(), rot.w(), rot.x(), rot.y(), rot.z(), cf1,
        cf[1], cf[2], cf[3]);
  };
  const SignedRobot robot = Signed(model, testing::PlantedErrors(model, 6), false);
  const ProgramCompensation ok = CompensateProgram(ParseRapid({"m.mod", module(cf[0])}), c, robot, nullptr);
  EXPECT_EQ(ok.targets[0].status, TargetStatus::kOk) << ok.targets[0].why;
  const ProgramCompensation r = CompensateProgram(ParseRapid({"m.mod", module(cf[0] + 2)}), c, robot, nullptr);
  EXPECT_EQ(r.targets[0].status, TargetStatus::kTaughtJointsMissPose);
  EXPECT_NE(r.targets[0].why.find("its configuration data cf ["), std::string::npos) << r.targets[0].why;
}

// A target whose tool the program leaves to the controller is named, not refused: the rest
// of the program is written.
TEST(CompensateProgram, UnknownToolIsNamedAndTheRestWritten) {
  const auto model = testing::Kr16_2();
  const ControllerModel c = NominalController(model, ControllerKind::kKuka, "nominal kr16_2");
  const std::string src =
      "DEF p()\nPTP {A1 10, A2 -80, A3 100, A4 0, A5 30, A6 0}\n$TOOL = $NULLFRAME\n"
      "PTP {A1 20, A2 -80, A3 100, A4 0, A5 30, A6 0}\n$TOOL = TOOL_DATA[3]\nPTP {A1 30, A2 -80, A3 100, A4 0, A5 30, A6 0}\nEND\n";
  const Program program = ParseKrl({"p.src", src}, std::nullopt);
  const SignedRobot robot = Signed(model, testing::PlantedErrors(model, 8), false);
  const ProgramCompensation r = CompensateProgram(program, c, robot, nullptr);
  ASSERT_EQ(r.targets.size(), 3u);
  EXPECT_EQ(r.targets[0].status, TargetStatus::kFrameUnknown);
  EXPECT_NE(r.targets[0].why.find("does not set the tool"), std::string::npos) << r.targets[0].why;
  EXPECT_EQ(r.targets[1].status, TargetStatus::kOk);
  EXPECT_EQ(r.targets[2].status, TargetStatus::kFrameUnknown);
  EXPECT_NE(r.targets[2].why.find("TOOL_DATA[3]"), std::string::npos) << r.targets[2].why;
  EXPECT_EQ(r.refused, 0);
  EXPECT_TRUE(r.written());
  const std::string out = ApplyEdits(program.files, r.edits)[0];
  EXPECT_NE(out.find("PTP {A1 10, A2 -80, A3 100, A4 0, A5 30, A6 0}"), std::string::npos);  // as written
  EXPECT_EQ(out.find("PTP {A1 20, A2 -80, A3 100, A4 0, A5 30, A6 0}"), std::string::npos);  // compensated
}

}  // namespace
}  // namespace armsig::programs
