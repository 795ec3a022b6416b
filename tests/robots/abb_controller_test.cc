// The ABB driver against the virtual controller (simulation/rws_simulator.h) over real TCP
// and TLS, both generations of Robot Web Services: identity, moves and readings, and every
// fault of issue 35 — each message names the controller and what to do, nothing wrong is
// read back, and the session can go on once the fault is cleared. Simulated time runs 20 to
// 100 times faster than the arm's physical time.
#include "robots/abb_controller.h"

#include <gtest/gtest.h>
#include <spdlog/sinks/ostream_sink.h>
#include <spdlog/spdlog.h>

#include <future>
#include <sstream>

#include "core/units.h"
#include "simulation/rws_simulator.h"
#include "test_support.h"

namespace armsig::robots {
using instruments::ControllerError;
using instruments::RetryPolicy;
namespace {

using namespace std::chrono_literals;
using simulation::RwsSimulator;
using simulation::RwsSimulatorOptions;
using simulation::VirtualLab;
using Kind = ControllerError::Kind;

RetryPolicy AbbFast() {
  RetryPolicy p;
  p.attempts = 3;
  p.timeout = 3000ms;
  p.reconnect_delay = 5ms;
  return p;
}

calibration::RobotModel Irb4600() {
  return io::LoadRobotModel(testing::SourcePath("models/irb4600.yaml"));
}

// A virtual ABB cell: the lab's robot (nominal, no errors) behind a virtual controller.
struct Cell {
  Cell(rws::Version version, RwsSimulatorOptions options)
      : version_(version),
        model(Irb4600()),
        lab(model, Eigen::VectorXd::Zero(model.num_parameters()), Eigen::Isometry3d::Identity()),
        sim(lab, With(version, std::move(options))) {
    sim.Start();
  }
  static RwsSimulatorOptions With(rws::Version version, RwsSimulatorOptions o) {
    o.version = version;
    return o;
  }

  std::unique_ptr<AbbController> Connect(AbbSettings s = {}, std::optional<TlsSettings> tls = {},
                                         RetryPolicy policy = AbbFast()) {
    s.version = version();
    if (s.user.empty() && s.password.empty()) {
      s.user = "Default User";
      s.password = "robotics";
    }
    s.can_move = true;
    s.poll_interval = 2ms;
    TlsSettings t;
    if (tls) {
      t = *tls;
    } else if (version() == rws::Version::kRws2) {
      t.pinned_sha256 = sim.certificate_sha256();
    }
    t.enabled = version() == rws::Version::kRws2;
    return std::make_unique<AbbController>(s, MakeHttpTransport("127.0.0.1", sim.port(), t),
                                           policy);
  }
  rws::Version version() const { return version_; }

  rws::Version version_;
  calibration::RobotModel model;
  VirtualLab lab;
  RwsSimulator sim;
};

// A cell whose simulated time runs `time_scale` times the arm's physical time.
std::unique_ptr<Cell> MakeCell(rws::Version v, RwsSimulatorOptions o = {},
                               double time_scale = 0.02) {
  o.time_scale = time_scale;
  return std::make_unique<Cell>(v, std::move(o));
}

Eigen::VectorXd Deg(std::initializer_list<double> d) {
  Eigen::VectorXd q(static_cast<Eigen::Index>(d.size()));
  int i = 0;
  for (double v : d) q(i++) = v * kRadPerDeg;
  return q;
}

// The error a call throws (fails the test when it throws none or another type).
template <typename E, typename F>
E Thrown(F&& call) {
  try {
    call();
  } catch (const E& e) {
    return e;
  } catch (const std::exception& e) {
    ADD_FAILURE() << "another error: " << e.what();
    throw;
  }
  ADD_FAILURE() << "no error";
  throw std::logic_error("no error");
}
template <typename F>
ControllerError StateError(F&& call) {
  return Thrown<ControllerError>(std::forward<F>(call));
}
template <typename F>
AbbFault LabFault(F&& call) {
  return Thrown<AbbFault>(std::forward<F>(call));
}
bool Says(const std::exception& e, const std::string& text) {
  return std::string(e.what()).find(text) != std::string::npos;
}

TEST(AbbController, IdentifiesItselfOverBothGenerationsAndAllRepresentations) {
  struct Case {
    rws::Version version;
    rws::Representation representation;
  };
  for (const Case c : {Case{rws::Version::kRws1, rws::Representation::kXhtml},
                       Case{rws::Version::kRws1, rws::Representation::kJson1},
                       Case{rws::Version::kRws2, rws::Representation::kHalJson}}) {
    auto cell = MakeCell(c.version);
    AbbSettings s;
    s.representation = c.representation;
    auto abb = cell->Connect(s);
    const AbbIdentity id = abb->Details();
    EXPECT_EQ(id.model, "IRB 4600-40/2.55");
    EXPECT_EQ(id.serial, "4600-501234");
    EXPECT_EQ(id.controller_name, "armsig-virtual");
    EXPECT_EQ(id.controller_id, "14-21985");
    EXPECT_EQ(id.robotware, c.version == rws::Version::kRws1 ? "6.15.03.00" : "7.16.0.0");
    EXPECT_EQ(id.contract_version, abb_contract::kVersion);
    EXPECT_NE(abb->name().find("IRB 4600-40/2.55 'armsig-virtual'"), std::string::npos);
    abb->CheckReady();
    // One login for the whole conversation: the session cookie carries it.
    EXPECT_EQ(cell->sim.snapshot().logins, 1);
    EXPECT_GE(abb->exchanges(), 6);
    abb.reset();  // logs out
    EXPECT_EQ(cell->sim.request_log().back(), "GET /logout" +
                                                  std::string(c.representation ==
                                                                      rws::Representation::kJson1
                                                                  ? "?json=1"
                                                                  : ""));
  }
}

TEST(AbbController, MovesInThePhysicalTimeAndReadsWhereTheArmStands) {
  for (rws::Version v : {rws::Version::kRws1, rws::Version::kRws2}) {
    auto cell = MakeCell(v, {}, 0.05);
    AbbSettings s;
    s.speed_percent = 50;
    auto abb = cell->Connect(s);
    const Eigen::VectorXd target = Deg({40, 20.5, -30.25, 120, -45.125, 200});
    const auto start = std::chrono::steady_clock::now();
    abb->MoveTo(target);
    const double elapsed = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    // Axis 6 travels 200° at 50 % of 360 °/s (its acceleration reaching 180 °/s in 0.25 s):
    // 200/180 + 0.25 = 1.361 s of the arm's time, 68 ms at the simulator's scale. Axis 4
    // (120° at 125 °/s): 1.21 s. Anything shorter would be no physical move.
    EXPECT_GE(elapsed, 0.05 * (200.0 / 180.0 + 0.25) - 0.002);
    const Eigen::VectorXd q = abb->ReadJointsRad();
    // RAPID nums are single-precision: 2e-5° is a float's step near 200°.
    EXPECT_LT((q - target).cwiseAbs().maxCoeff(), 2e-5 * kRadPerDeg) << q.transpose() / kRadPerDeg;
    EXPECT_LT((cell->lab.Joints() - target).cwiseAbs().maxCoeff(), 2e-5 * kRadPerDeg);
    const auto snap = cell->sim.snapshot();
    EXPECT_EQ(snap.moves, 1);
    EXPECT_EQ(snap.cmd, snap.done);
    EXPECT_EQ(cell->sim.Symbol("armsig_speed"), "50");
  }
}

TEST(AbbController, GuardStopDuringAMoveIsOneStopUntilTheProgramRunsAgain) {
  auto cell = MakeCell(rws::Version::kRws2);
  auto abb = cell->Connect();
  const Eigen::VectorXd target = Deg({60, 10, -20, 0, 30, 0});
  cell->sim.StopDuringNextMove(RwsSimulator::CellStop::kGuardStop, 0.5);
  const ControllerError stop = StateError([&] { abb->MoveTo(target); });
  EXPECT_EQ(stop.kind(), Kind::kProtectiveStop);
  EXPECT_TRUE(stop.WaitedOut());  // the session waits, then measures the configuration again
  EXPECT_TRUE(Says(stop, "ABB IRB 4600-40/2.55 'armsig-virtual' at 127.0.0.1:")) << stop.what();
  EXPECT_TRUE(Says(stop, "guard stop during move 1")) << stop.what();
  EXPECT_TRUE(Says(stop, "switch the motors on")) << stop.what();
  // The arm braked on its path, half way; no reading is given while the move is unfinished.
  const double j1 = cell->sim.snapshot().joints_deg(0);
  EXPECT_GT(j1, 5.0);
  EXPECT_LT(j1, 58.0);
  EXPECT_EQ(StateError([&] { abb->ReadJointsRad(); }).kind(), Kind::kProtectiveStop);
  EXPECT_EQ(StateError([&] { abb->MoveTo(target); }).kind(), Kind::kProtectiveStop);
  // ABB's recovery passes through motors off and a stopped program: still the same stop,
  // each step saying what is left to do.
  cell->sim.ResetStop();
  ControllerError step = StateError([&] { abb->CheckReady(); });
  EXPECT_EQ(step.kind(), Kind::kProtectiveStop);
  EXPECT_TRUE(Says(step, "the motors are still off")) << step.what();
  cell->sim.SetMotors(true);
  step = StateError([&] { abb->CheckReady(); });
  EXPECT_EQ(step.kind(), Kind::kProtectiveStop);
  EXPECT_TRUE(Says(step, "the program is not running yet")) << step.what();
  // Continued (no PP to main): the move finishes, and the same request lands there.
  cell->sim.StartProgram();
  abb->CheckReady();
  abb->MoveTo(target);
  EXPECT_LT((abb->ReadJointsRad() - target).cwiseAbs().maxCoeff(), 2e-5 * kRadPerDeg);
}

TEST(AbbController, EmergencyStopNamesTheButtonAndResumes) {
  auto cell = MakeCell(rws::Version::kRws1);
  auto abb = cell->Connect();
  const Eigen::VectorXd target = Deg({-30, 0, 0, 0, 60, 90});
  cell->sim.StopDuringNextMove(RwsSimulator::CellStop::kEmergencyStop, 0.3);
  const ControllerError stop = StateError([&] { abb->MoveTo(target); });
  EXPECT_EQ(stop.kind(), Kind::kEmergencyStop);
  EXPECT_FALSE(stop.WaitedOut());  // the session pauses for the operator
  EXPECT_TRUE(Says(stop, "release the emergency stop button")) << stop.what();
  // Released and reset but the motors still off: said as such.
  cell->sim.ResetStop();
  const ControllerError off = StateError([&] { abb->MoveTo(target); });
  EXPECT_EQ(off.kind(), Kind::kNotRunning);
  EXPECT_TRUE(Says(off, "motors off")) << off.what();
  cell->sim.SetMotors(true);
  cell->sim.StartProgram();
  abb->MoveTo(target);
  EXPECT_LT((abb->ReadJointsRad() - target).cwiseAbs().maxCoeff(), 2e-5 * kRadPerDeg);
}

TEST(AbbController, NotInAutoMotorsOffOrProgramStoppedIsSaidBeforeMoving) {
  auto cell = MakeCell(rws::Version::kRws2);
  auto abb = cell->Connect();
  const Eigen::VectorXd target = Deg({10, 0, 0, 0, 30, 0});
  cell->sim.SetMode(rws::OperationMode::kManualReduced);
  ControllerError f = StateError([&] { abb->MoveTo(target); });
  // Turning the key switched the motors off first; that is what is said first.
  EXPECT_EQ(f.kind(), Kind::kNotRunning);
  EXPECT_TRUE(Says(f, "motors off")) << f.what();
  cell->sim.SetMotors(true);
  f = StateError([&] { abb->MoveTo(target); });
  EXPECT_EQ(f.kind(), Kind::kNotRemote);
  EXPECT_TRUE(Says(f, "operating mode MANR (manual, reduced speed)")) << f.what();
  EXPECT_TRUE(Says(f, "turn the mode key to AUTO")) << f.what();
  cell->sim.SetMode(rws::OperationMode::kAuto);
  cell->sim.SetMotors(true);
  f = StateError([&] { abb->MoveTo(target); });
  EXPECT_EQ(f.kind(), Kind::kNotRunning);
  EXPECT_TRUE(Says(f, "the RAPID program is not running")) << f.what();
  EXPECT_TRUE(Says(f, "task T_ROB1, module ArmsigServer")) << f.what();
  EXPECT_EQ(cell->sim.snapshot().moves, 0);  // nothing moved
  // A reading needs no AUTO: the arm stands where the module recorded it.
  EXPECT_LT((abb->ReadJointsRad() - Deg({0, 0, 0, 0, 30, 0})).cwiseAbs().maxCoeff(), 1e-9);
  cell->sim.StartProgram(true);
  abb->MoveTo(target);
  EXPECT_EQ(cell->sim.snapshot().moves, 1);
}

// A program module as a lab runs one: uploaded, loaded, run from its routine, unloaded; the
// arm goes where its MoveAbsJ says and armsig's own module's main runs again afterwards.
// What the controller refuses is said with the file and the controller's words: a module that
// does not compile (nothing loaded), a routine whose name the task already has, another
// client's mastership, a start in manual mode.
TEST(AbbController, RunsAProgramModuleAndSaysWhatTheControllerRefuses) {
  for (const auto version : {rws::Version::kRws1, rws::Version::kRws2}) {
    SCOPED_TRACE(rws::VersionName(version));
    auto cell = MakeCell(version, {}, 0.002);
    auto abb = cell->Connect();
    const std::string module =
        "MODULE Probe\n  CONST jointtarget j1:=[[10,0,0,0,30,0],[9E9,9E9,9E9,9E9,9E9,9E9]];\n"
        "  PROC go()\n    MoveAbsJ j1, v1000, fine, tool0;\n    WaitTime 1;\n  ENDPROC\nENDMODULE\n";
    abb->LoadProgram("Probe.mod", module, "Probe", "go");
    abb->StartProgram("Probe");
    EXPECT_TRUE(testing::WaitUntil([&] { return !abb->ProgramRunning(); }));
    EXPECT_LT((abb->ReadJointTargetDeg() - Eigen::Vector<double, 6>(10, 0, 0, 0, 30, 0)).cwiseAbs().maxCoeff(), 0.006);
    abb->UnloadProgram("Probe");
    EXPECT_EQ(cell->sim.snapshot().routines_run, 1);
    EXPECT_EQ(cell->sim.snapshot().program_pointer, "main");
    EXPECT_TRUE(cell->sim.snapshot().running);  // armsig's module runs again

    const RwsRefused syntax = Thrown<RwsRefused>(
        [&] { abb->LoadProgram("Broken.mod", "MODULE Broken\n  PROC go()\n    MoveJ p1, v100, fine, tool0;\n", "Broken", "go"); });
    EXPECT_TRUE(Says(syntax, "did not load Broken.mod into task T_ROB1")) << syntax.what();
    EXPECT_TRUE(Says(syntax, "Broken.mod")) << syntax.what();
    ASSERT_TRUE(syntax.status());
    EXPECT_EQ(syntax.status()->code, rws::code::kModuleNotLoaded);
    const RwsRefused ambiguous = Thrown<RwsRefused>([&] {
      abb->LoadProgram("Main.mod", "MODULE MainMod\n  PROC main()\n  ENDPROC\nENDMODULE\n", "MainMod", "main");
    });
    EXPECT_TRUE(Says(ambiguous, "ambiguous name main (also in module ArmsigServer)")) << ambiguous.what();

    cell->sim.HoldMastershipElsewhere(true);
    const ControllerError held = StateError([&] { abb->LoadProgram("Probe.mod", module, "Probe", "go"); });
    EXPECT_EQ(held.kind(), Kind::kNotRemote);
    EXPECT_TRUE(Says(held, "mastership) to RAPID (loading Probe.mod)")) << held.what();
    cell->sim.HoldMastershipElsewhere(false);

    abb->LoadProgram("Probe.mod", module, "Probe", "go");
    cell->sim.SetMode(rws::OperationMode::kManualReduced);
    cell->sim.SetMotors(true);
    const ControllerError manual = StateError([&] { abb->StartProgram("Probe"); });
    EXPECT_EQ(manual.kind(), Kind::kNotRemote);
    EXPECT_TRUE(Says(manual, "operating mode MANR (manual, reduced speed) (starting Probe)")) << manual.what();
    EXPECT_EQ(cell->sim.snapshot().routines_run, 1);
  }
}

TEST(AbbController, ConnectionCutMidMoveAndRestoredGoesOn) {
  auto cell = MakeCell(rws::Version::kRws1, {}, 0.2);
  auto abb = cell->Connect();
  abb->Details();
  const Eigen::VectorXd target = Deg({90, 0, 0, 0, 30, 0});
  auto moving = std::async(std::launch::async, [&] { abb->MoveTo(target); });
  ASSERT_TRUE(testing::WaitUntil([&] { return cell->sim.snapshot().moving; }));
  cell->sim.CutNetwork();
  const ControllerError lost = StateError([&] { moving.get(); });
  EXPECT_EQ(lost.kind(), Kind::kConnectionLost);
  EXPECT_TRUE(Says(lost, "ABB IRB 4600-40/2.55 'armsig-virtual'")) << lost.what();
  EXPECT_TRUE(Says(lost, "network cable")) << lost.what();
  cell->sim.RestoreNetwork();
  // The same configuration again: the request left running is waited for, then the arm is
  // asked once more (it is there already).
  abb->MoveTo(target);
  EXPECT_LT((abb->ReadJointsRad() - target).cwiseAbs().maxCoeff(), 2e-5 * kRadPerDeg);
  EXPECT_EQ(cell->sim.snapshot().logins, 1);  // the session survived the cut
}

TEST(AbbController, NoReadingWhileTheArmMovesOrAfterItWasMoved) {
  // Physical time: the other client's move lasts seconds.
  auto cell = MakeCell(rws::Version::kRws2, {}, 1.0);
  auto abb = cell->Connect();
  cell->sim.RequestMoveElsewhere((Eigen::VectorXd(6) << 150, 0, 0, 0, 30, 0).finished());
  ControllerError f = StateError([&] { abb->ReadJointsRad(); });
  EXPECT_EQ(f.kind(), Kind::kArmMoving);
  EXPECT_TRUE(Says(f, "the arm is moving (move 1 not finished)")) << f.what();
  auto still = MakeCell(rws::Version::kRws1);
  auto abb1 = still->Connect();
  abb1->ReadJointsRad();  // it stands where the module recorded it
  still->sim.TurnBehindModule(4, 20.0);  // a jog of joint 5
  ASSERT_TRUE(testing::WaitUntil(
      [&] { return std::abs(still->sim.snapshot().joints_deg(4) - 30.0) > 0.1; }));
  f = StateError([&] { abb1->ReadJointsRad(); });
  EXPECT_EQ(f.kind(), Kind::kArmMoving);
  EXPECT_TRUE(Says(f, "(joint 5 is ")) << f.what();
}

TEST(AbbController, IdentifiesItselfToTheFramework) {
  auto cell = MakeCell(rws::Version::kRws2);
  const auto id = cell->Connect()->Identify();
  ASSERT_TRUE(id);
  EXPECT_EQ(id->protocol, "abb");
  EXPECT_EQ(id->vendor, "ABB");
  EXPECT_EQ(id->model, "IRB 4600-40/2.55");
  EXPECT_EQ(id->serial, "4600-501234");
  EXPECT_EQ(id->software, "RobotWare 7.16.0.0");
  EXPECT_TRUE(id->kinematics_checksum.empty());
}

TEST(AbbController, WrongCredentialsNameTheirFileAndNeverThePassword) {
  const std::string secret = "Sesame-7fq2-never-printed";
  std::ostringstream logged;
  auto sink = std::make_shared<spdlog::sinks::ostream_sink_mt>(logged);
  auto logger = spdlog::default_logger();
  logger->sinks().push_back(sink);
  const auto level = logger->level();
  logger->set_level(spdlog::level::trace);
  for (rws::Version v : {rws::Version::kRws1, rws::Version::kRws2}) {
    RwsSimulatorOptions o;
    o.password = secret;  // the controller's; the lab's file says otherwise
    auto cell = MakeCell(v, o);
    AbbSettings s;
    s.user = "Default User";
    s.password = secret + "-typo";
    s.credentials_source = "the credentials file /labs/cell2/abb.yaml";
    auto abb = cell->Connect(s);
    const AbbFault f = LabFault([&] { abb->Details(); });
    EXPECT_EQ(f.kind(), AbbFault::Kind::kCredentials);
    const std::string what = f.what();
    EXPECT_NE(what.find("ABB controller at 127.0.0.1:"), std::string::npos) << what;
    EXPECT_NE(what.find("refused the user 'Default User'"), std::string::npos) << what;
    EXPECT_NE(what.find("check the user name and password in the credentials file "
                        "/labs/cell2/abb.yaml"),
              std::string::npos)
        << what;
    EXPECT_EQ(what.find(secret), std::string::npos);
    EXPECT_EQ(cell->sim.snapshot().refused_logins, 1);
    // With the right password it works, and the whole conversation leaks it nowhere.
    s.password = secret;
    auto right = cell->Connect(s);
    right->MoveTo(Deg({5, 5, 5, 5, 35, 5}));
    right->ReadJointsRad();
    right.reset();
    for (const std::string& line : cell->sim.request_log()) {
      EXPECT_EQ(line.find(secret), std::string::npos) << line;
    }
  }
  logger->flush();
  logger->sinks().pop_back();
  logger->set_level(level);
  EXPECT_FALSE(logged.str().empty());  // the trace did log the requests
  EXPECT_EQ(logged.str().find(secret), std::string::npos);
}

TEST(AbbController, TlsCertificateMustBePinnedOrVerified) {
  auto cell = MakeCell(rws::Version::kRws2);
  const std::string fingerprint = cell->sim.certificate_sha256();
  // Neither pin nor CA: refused, naming the fingerprint to compare and pin.
  AbbFault f = LabFault([&] { cell->Connect({}, TlsSettings{})->Details(); });
  EXPECT_EQ(f.kind(), AbbFault::Kind::kCertificate);
  EXPECT_NE(std::string(f.what()).find("certificate_sha256: " + fingerprint), std::string::npos)
      << f.what();
  // Another pin: refused (a different controller, or someone in between).
  TlsSettings wrong;
  wrong.pinned_sha256 = *http::CanonicalFingerprint(std::string(64, 'a'));
  f = LabFault([&] { cell->Connect({}, wrong)->Details(); });
  EXPECT_EQ(f.kind(), AbbFault::Kind::kCertificate);
  EXPECT_NE(std::string(f.what()).find("is not the pinned one"), std::string::npos);
  EXPECT_EQ(cell->sim.snapshot().logins, 0);  // no password was sent to either
  // Pinned, or verified against a CA file (the controller's certificate as its own CA).
  TlsSettings pinned;
  pinned.pinned_sha256 = fingerprint;
  EXPECT_EQ(cell->Connect({}, pinned)->Details().serial, "4600-501234");
  testing::TempDir dir;
  testing::WriteText(dir.File("ca.pem"), cell->sim.certificate_pem());
  TlsSettings ca;
  ca.ca_file = dir.File("ca.pem");
  EXPECT_EQ(cell->Connect({}, ca)->Details().serial, "4600-501234");
}

TEST(AbbController, AMissingModuleOrMastershipHeldElsewhereIsSaid) {
  RwsSimulatorOptions o;
  o.module_text.clear();
  auto bare = MakeCell(rws::Version::kRws1, o);
  const AbbFault f = LabFault([&] { bare->Connect()->Details(); });
  EXPECT_EQ(f.kind(), AbbFault::Kind::kContract);
  EXPECT_NE(std::string(f.what()).find("load armsig's module controllers/abb/ArmsigServer.mod "
                                       "into T_ROB1"),
            std::string::npos)
      << f.what();
  auto cell = MakeCell(rws::Version::kRws2);
  auto abb = cell->Connect();
  cell->sim.HoldMastershipElsewhere(true);
  const ControllerError held = StateError([&] { abb->MoveTo(Deg({1, 0, 0, 0, 30, 0})); });
  EXPECT_EQ(held.kind(), Kind::kNotRemote);
  EXPECT_TRUE(Says(held, "another client holds the write access")) << held.what();
  EXPECT_EQ(cell->sim.snapshot().cmd, 0);  // nothing was written
  cell->sim.HoldMastershipElsewhere(false);
  abb->MoveTo(Deg({1, 0, 0, 0, 30, 0}));
}

TEST(AbbController, ATargetOutsideTheWorkingRangeStopsTheProgramNotTheArm) {
  auto cell = MakeCell(rws::Version::kRws2);
  auto abb = cell->Connect();
  const ControllerError f = StateError([&] { abb->MoveTo(Deg({0, 160, 0, 0, 30, 0})); });  // ≤ 150°
  EXPECT_EQ(f.kind(), Kind::kNotRunning);
  EXPECT_NE(std::string(f.what()).find("not running during move 1"), std::string::npos)
      << f.what();
  EXPECT_EQ(cell->sim.snapshot().moves, 0);
  EXPECT_LT((cell->sim.snapshot().joints_deg - Deg({0, 0, 0, 0, 30, 0}) / kRadPerDeg).norm(), 1e-9);
}

TEST(AbbController, LostRepliesAreRetriedAndSilenceEndsByTheDeadline) {
  auto cell = MakeCell(rws::Version::kRws1);
  auto abb = cell->Connect();
  for (simulation::Fault fault : {simulation::Fault::kVanish, simulation::Fault::kNoiseBytes,
                                  simulation::Fault::kTruncateReply}) {
    cell->sim.InjectOnce({fault, 0});
    EXPECT_NO_THROW(abb->CheckReady()) << static_cast<int>(fault);
  }
  cell->sim.InjectOnce({simulation::Fault::kErrorCode, -1073445881});
  try {
    abb->CheckReady();
    ADD_FAILURE() << "a refusal was not reported";
  } catch (const RwsRefused& e) {
    EXPECT_EQ(e.http_status(), 500u);
    EXPECT_EQ(e.code(), -1073445881);
  }
  cell->sim.InjectAlways({simulation::Fault::kDropReply, 0});
  RetryPolicy short_deadline = AbbFast();
  short_deadline.timeout = 300ms;
  auto patient = cell->Connect({}, {}, short_deadline);
  const ControllerError silent = StateError([&] { patient->CheckReady(); });
  EXPECT_EQ(silent.kind(), Kind::kConnectionLost);
  EXPECT_TRUE(Says(silent, "no usable reply after")) << silent.what();
}

}  // namespace
}  // namespace armsig::robots
