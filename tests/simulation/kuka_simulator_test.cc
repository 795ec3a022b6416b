// armsig's KUKA driver against the virtual KR C4 over real TCP sockets: the variable server
// protocol, ARMSIG's contract, physical move times, and every fault of the cell and the
// network, each with the message an operator acts on.
#include "simulation/kuka_simulator.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <future>
#include <numbers>
#include <thread>

#include "robots/kuka_controller.h"
#include "io/model_yaml.h"
#include "test_support.h"

namespace armsig::simulation {
namespace {

using instruments::ControllerError;
using robots::KukaController;
using Kind = instruments::ControllerError::Kind;
using namespace std::chrono_literals;

constexpr double kDeg = std::numbers::pi / 180.0;

Eigen::VectorXd Deg(std::initializer_list<double> q) {
  Eigen::VectorXd v(static_cast<Eigen::Index>(q.size()));
  Eigen::Index i = 0;
  for (double x : q) v(i++) = x * kDeg;
  return v;
}

const calibration::RobotModel& Kr16() {
  static const calibration::RobotModel model =
      io::LoadRobotModel(std::string(ARMSIG_SOURCE_DIR) + "/models/kr16_2.yaml");
  return model;
}

class KukaCell : public ::testing::Test {
 protected:
  void SetUp() override { Open(0.02); }

  void Open(double time_scale, KukaSimulatorOptions options = {}) {
    controller_.reset();
    sim_.reset();  // before the lab it reads
    lab_ = std::make_unique<VirtualLab>(Kr16(), Eigen::VectorXd::Zero(Kr16().num_parameters()),
                                        Eigen::Isometry3d::Identity());
    lab_->SetJoints(Deg({0, -90, 90, 0, 0, 0}));
    options.time_scale = time_scale;
    sim_ = std::make_unique<KukaSimulator>(*lab_, "127.0.0.1", 0, options);
    sim_->Start();
    controller_ = Connect();
  }

  std::unique_ptr<KukaController> Connect(robots::KukaOptions options = {}) {
    instruments::RetryPolicy policy;
    policy.attempts = 3;
    policy.timeout = 1000ms;
    policy.reconnect_delay = 30ms;
    options.poll = 5ms;
    options.accept_timeout = 300ms;
    options.move_timeout = 20s;
    return std::make_unique<KukaController>(
        instruments::MakeFramedTcpTransport("127.0.0.1", sim_->port(), robots::kuka::kResponseFrames), true, policy, options);
  }

  // MoveTo on another thread, returned once the controller has taken the command.
  std::future<void> MoveInBackground(const Eigen::VectorXd& q) {
    const int64_t before = sim_->snapshot().cmd;
    auto f = std::async(std::launch::async, [this, q] { controller_->MoveTo(q); });
    EXPECT_TRUE(testing::WaitUntil([&] {
      const auto s = sim_->snapshot();
      return s.busy > before && s.moving;
    }));
    return f;
  }

  template <typename F>
  ControllerError StateErrorOf(F&& f) {
    try {
      f();
    } catch (const ControllerError& e) {
      return e;
    }
    ADD_FAILURE() << "no ControllerError";
    return ControllerError(Kind::kVersionRefused, "none", "none", "none");
  }

  std::unique_ptr<VirtualLab> lab_;
  std::unique_ptr<KukaSimulator> sim_;
  std::unique_ptr<KukaController> controller_;
};

TEST_F(KukaCell, IdentifiesTheControllerByItsSystemVariables) {
  const auto id = controller_->Identify();
  ASSERT_TRUE(id);
  EXPECT_EQ(id->protocol, "kuka");
  EXPECT_EQ(id->vendor, "KUKA");
  EXPECT_EQ(id->model, "KR16_2");  // the arm of $TRAFONAME[] "#KR16_2 C4 FLR"
  EXPECT_EQ(id->serial, "501234");
  EXPECT_EQ(id->software, "KS V8.3.38");
  EXPECT_EQ(controller_->Read("PING"), "PONG");
  const auto s = controller_->State();
  EXPECT_EQ(s.mode, "AUT");
  EXPECT_EQ(s.program_state, "P_ACTIVE");
  EXPECT_TRUE(s.ProgramIsArmsig()) << s.program_name;
  EXPECT_EQ(s.contract_version, 1);
}

TEST_F(KukaCell, MovesThroughArmsigAndReadsTheJointsWhereTheyStand) {
  const Eigen::VectorXd target = Deg({12.5, -80.25, 100.125, -30, 45.5, 170});
  controller_->MoveTo(target);
  const auto s = sim_->snapshot();
  EXPECT_EQ(s.moves, 1);
  EXPECT_EQ(s.done, s.cmd);
  EXPECT_EQ(s.result, 0);
  const Eigen::VectorXd q = controller_->ReadJointsRad();
  // The controller shows 32-bit floats: 9 significant digits.
  EXPECT_LT((q - target).cwiseAbs().maxCoeff(), 1e-6 * kDeg) << q.transpose() / kDeg;
  EXPECT_LT((lab_->Joints() - target).norm(), 1e-6);  // the lab's robot stands there
  // The same target again: a command of its own, and no time.
  controller_->MoveTo(target);
  EXPECT_EQ(sim_->snapshot().moves, 2);
  EXPECT_EQ(sim_->snapshot().last_move_seconds, 0.0);
  // $POS_ACT by the controller's nominal kinematics: the reflector of the model at home.
  controller_->MoveTo(Deg({0, -90, 90, 0, 0, 0}));
  const auto pose = controller_->ReadPoseAct();
  // Joint 1's frame is $ROBROOT turned about x: (1188, 0, 1320) there is (1188, 0, -1320).
  EXPECT_NEAR(pose(0), 1188.0, 1e-3);
  EXPECT_NEAR(pose(2), -1320.0, 1e-3);
}

// A synchronous PTP takes the leading axis's time: A1 90° at 20 % of 156 °/s (31.2 °/s) and
// 20 % of 390 °/s² (78 °/s²) ramps 0.4 s each way: 90 / 31.2 + 0.4 = 3.2846 s; the other axes
// follow in the same time.
TEST_F(KukaCell, MovesTakeThePhysicalTimeOfTheLeadingAxis) {
  controller_->MoveTo(Deg({90, -90, 90, 10, 0, 0}));
  EXPECT_NEAR(sim_->snapshot().last_move_seconds, 90.0 / 31.2 + 31.2 / 78.0, 1e-9);
  // A short move never reaches the velocity: a triangle, 2·sqrt(d / a).
  EXPECT_NEAR(sim_->MoveSeconds(Eigen::VectorXd::Zero(6), (Eigen::VectorXd(6) << 1, 0, 0, 0, 0, 0).finished(),
                                20, 20),
              2.0 * std::sqrt(1.0 / 78.0), 1e-12);
}

TEST_F(KukaCell, AReadingWhileTheArmMovesIsRefused) {
  Open(1.0);  // a real-time move of 3 s
  sim_->CommandMove(Eigen::Vector3d(90, -90, 90), 20);  // another client moves the robot
  ASSERT_TRUE(testing::WaitUntil([&] { return sim_->snapshot().moving; }));
  const auto e = StateErrorOf([&] { controller_->ReadJointsRad(); });
  EXPECT_EQ(e.kind(), Kind::kArmMoving);
  EXPECT_FALSE(e.WaitedOut());
  EXPECT_NE(std::string(e.what()).find("$ROB_STOPPED FALSE"), std::string::npos) << e.what();
  EXPECT_NE(std::string(e.what()).find(sim_->path()), std::string::npos) << e.what();
  sim_->StopProgram();  // the STOP key: it brakes along its path and stands
  ASSERT_TRUE(testing::WaitUntil([&] { return !sim_->snapshot().moving; }));
  EXPECT_NO_THROW(controller_->ReadJointsRad());
}

TEST_F(KukaCell, AnEmergencyStopDuringAMoveIsReportedAndTheMoveResumes) {
  Open(0.2);
  const Eigen::VectorXd target = Deg({90, -60, 80, 0, 30, 0});
  auto move = MoveInBackground(target);
  sim_->PressEmergencyStop();
  const auto e = StateErrorOf([&] { move.get(); });
  EXPECT_EQ(e.kind(), Kind::kEmergencyStop);
  EXPECT_FALSE(e.WaitedOut());  // the session pauses until the operator resumes it
  EXPECT_NE(std::string(e.what()).find("EMERGENCY STOP"), std::string::npos) << e.what();
  EXPECT_NE(std::string(e.what()).find("release it"), std::string::npos) << e.what();
  const auto halted = sim_->snapshot();
  EXPECT_TRUE(halted.halted);
  EXPECT_GT((halted.joints_deg - target / kDeg).cwiseAbs().maxCoeff(), 1.0);  // stopped short
  // Still stopped: a move is refused before anything is written.
  EXPECT_EQ(StateErrorOf([&] { controller_->MoveTo(target); }).kind(), Kind::kEmergencyStop);
  EXPECT_EQ(sim_->snapshot().cmd, halted.cmd);
  // The operator releases, acknowledges and restarts: the same call goes on with the same
  // command, and the robot arrives.
  sim_->ReleaseEmergencyStop();
  sim_->Acknowledge();
  sim_->StartProgram();
  controller_->MoveTo(target);
  const auto s = sim_->snapshot();
  EXPECT_EQ(s.moves, 1);
  EXPECT_EQ(s.cmd, halted.cmd);
  EXPECT_EQ(controller_->statistics().resumed_moves, 1);
  EXPECT_LT((controller_->ReadJointsRad() - target).cwiseAbs().maxCoeff(), 1e-6);
}

// The KUKA equivalent of a protective stop: operator safety (the cell's gate) opened in AUT.
TEST_F(KukaCell, ASafetyStopFromTheGatePausesTheMoveUntilCleared) {
  Open(0.2);
  const Eigen::VectorXd target = Deg({-90, -70, 110, 20, -40, 90});
  auto move = MoveInBackground(target);
  sim_->OpenSafetyGate();
  const auto e = StateErrorOf([&] { move.get(); });
  EXPECT_EQ(e.kind(), Kind::kProtectiveStop);
  EXPECT_TRUE(e.WaitedOut());  // the session waits until it is cleared
  EXPECT_NE(std::string(e.what()).find("the move stopped"), std::string::npos) << e.what();
  EXPECT_NE(std::string(e.what()).find("gate"), std::string::npos) << e.what();
  // Acknowledging with the gate open does not clear it.
  sim_->Acknowledge();
  EXPECT_EQ(StateErrorOf([&] { controller_->CheckReady(); }).kind(), Kind::kProtectiveStop);
  sim_->CloseSafetyGate();
  sim_->Acknowledge();
  // Acknowledged, not yet started: still a stop the session waits out.
  const auto stopped = StateErrorOf([&] { controller_->CheckReady(); });
  EXPECT_EQ(stopped.kind(), Kind::kProtectiveStop);
  EXPECT_NE(std::string(stopped.what()).find("#P_STOP"), std::string::npos) << stopped.what();
  sim_->StartProgram();
  EXPECT_NO_THROW(controller_->CheckReady());
  controller_->MoveTo(target);
  EXPECT_EQ(sim_->snapshot().moves, 1);
  EXPECT_LT((controller_->ReadJointsRad() - target).cwiseAbs().maxCoeff(), 1e-6);
}

// The drives switched off mid-move (the smartPAD's drives key, $DRIVES_OFF): the arm brakes
// short of the target; the session pauses naming the drives, and the same command goes on once
// the operator has switched them on and started ARMSIG.
TEST_F(KukaCell, DrivesSwitchedOffStopTheMoveAndAreNamed) {
  Open(0.2);
  const Eigen::VectorXd target = Deg({90, -60, 80, 0, 30, 0});
  auto move = MoveInBackground(target);
  sim_->SwitchDrivesOff();
  const auto e = StateErrorOf([&] { move.get(); });
  EXPECT_EQ(e.kind(), Kind::kNotRunning);
  EXPECT_FALSE(e.WaitedOut());
  EXPECT_NE(std::string(e.what()).find(sim_->path()), std::string::npos) << e.what();
  EXPECT_NE(std::string(e.what()).find("the move stopped: the drives are off ($PERI_RDY FALSE)"),
            std::string::npos)
      << e.what();
  EXPECT_NE(std::string(e.what()).find("switch the drives on"), std::string::npos) << e.what();
  const auto halted = sim_->snapshot();
  EXPECT_GT((halted.joints_deg - target / kDeg).cwiseAbs().maxCoeff(), 1.0);  // stopped short
  EXPECT_EQ(StateErrorOf([&] { controller_->CheckReady(); }).kind(), Kind::kNotRunning);
  sim_->StartProgram();
  controller_->MoveTo(target);
  EXPECT_EQ(sim_->snapshot().cmd, halted.cmd);  // the same command, not a new one
  EXPECT_EQ(controller_->statistics().resumed_moves, 1);
  EXPECT_LT((controller_->ReadJointsRad() - target).cwiseAbs().maxCoeff(), 1e-6);
}

TEST_F(KukaCell, NoMoveOutsideAutomaticModeButJointsStillRead) {
  sim_->SetMode("T1");
  const int64_t cmd = sim_->snapshot().cmd;
  const auto e = StateErrorOf([&] { controller_->MoveTo(Deg({10, -90, 90, 0, 0, 0})); });
  EXPECT_EQ(e.kind(), Kind::kNotRemote);
  EXPECT_NE(std::string(e.what()).find("in T1"), std::string::npos) << e.what();
  EXPECT_NE(std::string(e.what()).find("AUT"), std::string::npos) << e.what();
  EXPECT_EQ(sim_->snapshot().cmd, cmd);  // nothing written
  EXPECT_NO_THROW(controller_->ReadJointsRad());
}

TEST_F(KukaCell, AProgramNotRunningOrAnotherProgramIsNamed) {
  // ARMSIG stopped with the STOP key: waited out until it is started again.
  sim_->StopProgram();
  auto e = StateErrorOf([&] { controller_->MoveTo(Deg({10, -90, 90, 0, 0, 0})); });
  EXPECT_EQ(e.kind(), Kind::kProtectiveStop);
  EXPECT_NE(std::string(e.what()).find("#P_STOP"), std::string::npos) << e.what();
  // Not selected: the session pauses, naming what to do.
  sim_->SelectProgram("");
  e = StateErrorOf([&] { controller_->MoveTo(Deg({10, -90, 90, 0, 0, 0})); });
  EXPECT_EQ(e.kind(), Kind::kNotRunning);
  EXPECT_NE(std::string(e.what()).find("#P_FREE, selected: no program"), std::string::npos)
      << e.what();
  // Another program runs: the command is never taken.
  sim_->SelectProgram("CELL");
  sim_->StartProgram();
  e = StateErrorOf([&] { controller_->MoveTo(Deg({10, -90, 90, 0, 0, 0})); });
  EXPECT_EQ(e.kind(), Kind::kNotRunning);
  EXPECT_NE(std::string(e.what()).find("/R1/CELL.SRC, not ARMSIG"), std::string::npos) << e.what();
  EXPECT_EQ(sim_->snapshot().moves, 0);
  // ARMSIG selected and started again answers the command left open with "not executed";
  // the next move goes as usual.
  sim_->SelectProgram("ARMSIG");
  sim_->StartProgram();
  ASSERT_TRUE(testing::WaitUntil([&] { return sim_->snapshot().done == sim_->snapshot().cmd; }));
  EXPECT_EQ(sim_->snapshot().result, 3);
  controller_->MoveTo(Deg({10, -90, 90, 0, 0, 0}));
  EXPECT_EQ(sim_->snapshot().moves, 1);
}

// A program copied into the controller's program folder and run by the submit interpreter's
// runner (controllers/kuka/ARMSIG_SPS.sub): it replaces ARMSIG in the robot interpreter, its
// PTP goes where it says, its WAIT SEC holds the arm, its END is reported. Refused and named:
// a run outside AUT and EXT, a program not in the folder, one the controller cannot compile.
TEST_F(KukaCell, RunsAProgramFromItsFolderAndNamesWhatItRefuses) {
  testing::TempDir dir;
  KukaSimulatorOptions options;
  options.program_folder = dir.File("Program");
  std::filesystem::create_directories(options.program_folder);
  Open(0.002, options);
  testing::WriteText(dir.File("Probe.src"),
                     "DEF probe( )\n  $TOOL = {X 0, Y 0, Z 0, A 0, B 0, C 0}\n  PTP {A1 10, A2 -80, A3 80, A4 0, A5 20, A6 0}\n  WAIT SEC 1\nEND\n");
  testing::WriteText(dir.File("Broken.src"), "DEF broken( )\n  PTP {A1 10\n");
  robots::CopyToProgramFolder({dir.File("Probe.src"), dir.File("Broken.src")}, options.program_folder);

  const int64_t run = controller_->RunProgram("probe");
  EXPECT_NO_THROW(testing::WaitUntil([&] { return !controller_->ProgramRunning(run, "probe"); }))
      << sim_->snapshot().last_run_refusal;
  EXPECT_LT((controller_->ReadJointsRad() - Deg({10, -80, 80, 0, 20, 0})).cwiseAbs().maxCoeff(), 1e-6);
  const auto s = sim_->snapshot();
  EXPECT_EQ(s.runs, 1);
  EXPECT_EQ(s.program, "probe");
  EXPECT_EQ(s.program_state, "P_END");

  const int64_t missing = controller_->RunProgram("nothere");
  ControllerError e = StateErrorOf([&] { testing::WaitUntil([&] { return !controller_->ProgramRunning(missing, "nothere"); }); });
  EXPECT_EQ(e.kind(), Kind::kNotRunning);
  EXPECT_NE(std::string(e.what()).find("did not select nothere: no nothere.src in KRC:\\R1\\Program"), std::string::npos)
      << e.what();
  EXPECT_NE(sim_->snapshot().last_run_refusal.find("nothere.src is not in the program folder"), std::string::npos);
  const int64_t broken = controller_->RunProgram("broken");
  e = StateErrorOf([&] { testing::WaitUntil([&] { return !controller_->ProgramRunning(broken, "broken"); }); });
  EXPECT_EQ(e.kind(), Kind::kNotRunning);
  EXPECT_NE(sim_->snapshot().last_run_refusal.find("Broken.src"), std::string::npos) << sim_->snapshot().last_run_refusal;

  sim_->SetMode("T1");
  const int64_t manual = controller_->RunProgram("probe");
  e = StateErrorOf([&] { testing::WaitUntil([&] { return !controller_->ProgramRunning(manual, "probe"); }); });
  EXPECT_EQ(e.kind(), Kind::kNotRemote);
  EXPECT_NE(std::string(e.what()).find("not in AUT or EXT"), std::string::npos) << e.what();
  EXPECT_EQ(sim_->snapshot().runs, 1);
}

TEST_F(KukaCell, ATargetBeyondASoftwareLimitIsRefusedByArmsig) {
  const auto e = StateErrorOf([&] { controller_->MoveTo(Deg({0, 40, 90, 0, 0, 0})); });
  EXPECT_EQ(e.kind(), Kind::kMoveRefused);
  EXPECT_NE(std::string(e.what()).find("software limit"), std::string::npos) << e.what();
  EXPECT_EQ(sim_->snapshot().refused, 1);
  EXPECT_EQ(sim_->snapshot().moves, 0);
}

TEST_F(KukaCell, AnotherContractVersionIsRefusedBeforeAnyMove) {
  controller_->Write("ARMSIG_VERSION", "0");
  const auto e = StateErrorOf([&] { controller_->MoveTo(Deg({10, -90, 90, 0, 0, 0})); });
  EXPECT_EQ(e.kind(), Kind::kVersionRefused);
  EXPECT_NE(std::string(e.what()).find("controllers/kuka"), std::string::npos) << e.what();
}

TEST_F(KukaCell, AConnectionDroppedMidMoveIsBridgedAndALongerOutageResumes) {
  Open(0.2);
  const Eigen::VectorXd target = Deg({60, -70, 100, 0, 0, 0});
  auto move = MoveInBackground(target);
  sim_->DropConnections();  // dropped once, the server still there: the driver reconnects
  EXPECT_NO_THROW(move.get());
  EXPECT_GE(controller_->statistics().reconnects, 1);
  EXPECT_EQ(sim_->snapshot().moves, 1);
  EXPECT_LT((controller_->ReadJointsRad() - target).cwiseAbs().maxCoeff(), 1e-6);

  // Down longer than a call's retries: a typed failure naming the server; back up, the same
  // move resumes on the command the controller kept executing.
  const Eigen::VectorXd next = Deg({-60, -70, 100, 0, 0, 0});
  move = MoveInBackground(next);
  sim_->SetReachable(false);
  try {
    move.get();
    ADD_FAILURE() << "the move went on without the controller";
  } catch (const ControllerError& e) {
    EXPECT_EQ(e.kind(), Kind::kConnectionLost) << e.what();
    EXPECT_NE(std::string(e.what()).find("variable server"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("resumes"), std::string::npos) << e.what();
  }
  sim_->SetReachable(true);
  controller_->MoveTo(next);
  // The open command was waited for (its move still under way), or, done meanwhile, the same
  // target sent again (a move of no time): never a second move elsewhere.
  const auto s = sim_->snapshot();
  EXPECT_TRUE(controller_->statistics().resumed_moves == 1 || s.moves == 3)
      << controller_->statistics().resumed_moves << " " << s.moves;
  EXPECT_LT((controller_->ReadJointsRad() - next).cwiseAbs().maxCoeff(), 1e-6);
}

TEST_F(KukaCell, GarbageAndMalformedFramesAreSkippedOrRetried) {
  const Eigen::VectorXd q = controller_->ReadJointsRad();
  for (Fault f : {Fault::kNoiseBytes, Fault::kMalformed, Fault::kTruncateReply, Fault::kWrongTrid,
                  Fault::kDropReply, Fault::kVanish}) {
    SCOPED_TRACE(static_cast<int>(f));
    sim_->InjectOnce({f, 0});
    EXPECT_LT((controller_->ReadJointsRad() - q).norm(), 1e-9);
  }
  const auto& stats = controller_->statistics();
  EXPECT_GE(stats.bad_frames, 2);
  EXPECT_GE(stats.stale_answers, 1);
  EXPECT_GE(stats.retries, 4);
  // A flood of binary garbage on every request: a typed failure by the call's deadline.
  sim_->InjectAlways({Fault::kFloodBytes, 0});
  try {
    controller_->ReadJointsRad();
    ADD_FAILURE() << "a reading through a flood";
  } catch (const ControllerError& e) {
    EXPECT_EQ(e.kind(), Kind::kConnectionLost) << e.what();
  }
  sim_->ClearFaults();
  EXPECT_LT((controller_->ReadJointsRad() - q).norm(), 1e-9);
}

TEST_F(KukaCell, ValuesNoRobotCanHaveAreNoReading) {
  sim_->InjectAlways({Fault::kOutOfRange, 0});  // $AXIS_ACT with A1 at 1000°
  EXPECT_THROW(controller_->ReadJointsRad(), instruments::ReadingRangeError);
  sim_->ClearFaults();
  sim_->InjectOnce({Fault::kOtherReply, 0});  // $ROB_STOPPED answered with $MODE_OP's value
  try {
    controller_->ReadJointsRad();
    ADD_FAILURE() << "another variable's value taken";
  } catch (const instruments::InstrumentError& e) {
    EXPECT_EQ(e.code(), 3074);
    EXPECT_NE(std::string(e.what()).find("not TRUE or FALSE"), std::string::npos) << e.what();
  }
  // A variable the controller does not declare reads empty (KukaVarProxy): never a value.
  try {
    controller_->Read("ARMSIG_NOT_DECLARED");
    ADD_FAILURE();
  } catch (const ControllerError& e) {
    EXPECT_EQ(e.kind(), Kind::kVersionRefused);
    EXPECT_NE(std::string(e.what()).find("config_globals.dat"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace armsig::simulation
