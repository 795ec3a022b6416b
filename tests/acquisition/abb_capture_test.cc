// Capture sessions with an ABB controller: the virtual IRC5 (RWS 1.0) or OmniCore (RWS 2.0
// over TLS) running the shipped RAPID module, moving an IRB 4600 with hidden geometric and
// joint-angle errors, measured by the virtual laser tracker. Every fault of issue 35 at the
// session's level: what is stored (never a wrong reading), what the session says, and that it
// goes on or resumes. The controller runs 100 times faster than physical time.
#include <fmt/format.h>
#include <gtest/gtest.h>
#include <sys/stat.h>

#include <random>
#include <thread>

#include "acquisition/lab.h"
#include "acquisition/session.h"
#include "robots/abb_controller.h"
#include "core/units.h"
#include "db/database.h"
#include "db/store.h"
#include "io/lab_file.h"
#include "io/model_yaml.h"
#include "io/network_files.h"
#include "simulation/emscon_simulator.h"
#include "simulation/rws_simulator.h"
#include "simulation/virtual_robots.h"
#include "test_support.h"
#include "workflows/capture.h"

namespace armsig::acquisition {
namespace {

using namespace std::chrono_literals;
namespace rws = robots::rws;

constexpr int kAbbConfigurations = 5;
// RAPID nums are floats: a target and the joints the module records keep ~7 digits (2e-5°
// near 200°, 3.5e-7 rad).
constexpr double kFloatRad = 1e-6;

class AbbCaptureFixture : public ::testing::Test {
 protected:
  void SetUp() override {
    model_ = io::ParseRobotModel(testing::ReadText(testing::SourcePath("models/irb4600.yaml")),
                                 "irb4600.yaml");
    truth_ = simulation::MakeVirtualRobot("abb", model_, 7);
    lab_ = std::make_unique<simulation::VirtualLab>(model_, truth_.true_params,
                                                    truth_.world_from_base, 3);
    lab_->SetJointErrors(truth_.joint_errors);
    simulation::VirtualStation lt1;
    lt1.pose.id = "LT1";
    lab_->AddStation(lt1);
    simulation::EmsconSimulatorOptions t;
    t.command_latency = 1ms;
    t.motion_latency = 2ms;
    t.initialize_latency = 2ms;
    t.acquire_radius_mm = 25.0;
    t.seed = 11;
    tracker_ = std::make_unique<simulation::EmsconSimulator>(*lab_, 0, "127.0.0.1", 0, t);
    tracker_->Start();
    std::vector<reduction::Station> stations(1);
    stations[0].pose = lt1.pose;
    testing::WriteText(dir_.File("stations.yaml"), io::FormatStationsYaml(stations, "truth"));
    testing::WriteText(dir_.File("abb.yaml"), "user: armsig\npassword: \"c3ll-2 pa55\"\n");
    ::chmod(dir_.File("abb.yaml").c_str(), 0600);
    std::mt19937 rng(5);
    std::uniform_real_distribution<double> around(-0.3, 0.3);
    for (int k = 0; k < kAbbConfigurations; ++k) {
      Eigen::VectorXd q = truth_.home_rad;
      for (int j = 0; j < 6; ++j) q(j) += around(rng);
      plan_.push_back({"C" + std::to_string(k + 1), q});
    }
  }

  simulation::RwsSimulatorOptions Options(rws::Version version = rws::Version::kRws2) const {
    simulation::RwsSimulatorOptions o;
    o.version = version;
    o.model = truth_.identity.model;
    o.serial_high = "4600";
    o.serial_low = truth_.identity.serial.substr(5);
    o.user = "armsig";
    o.password = "c3ll-2 pa55";
    for (int i = 0; i < 6; ++i) o.start_deg[static_cast<size_t>(i)] = truth_.home_rad(i) * 180 / kPi;
    o.time_scale = 0.01;
    return o;
  }

  // The controller, and the lab file that names it (a hand-measured base, 3 mm and 1 mrad off,
  // so the tracker's beam is pointed from the first configuration).
  void StartController(simulation::RwsSimulatorOptions o) {
    abb_.reset();
    const bool v1 = o.version == rws::Version::kRws1;
    abb_ = std::make_unique<simulation::RwsSimulator>(*lab_, o);
    abb_->Start();
    Eigen::Isometry3d given = truth_.world_from_base;
    given.translate(Eigen::Vector3d(3.0, -2.0, 1.5));
    given.rotate(Eigen::AngleAxisd(1e-3, Eigen::Vector3d::UnitZ()));
    std::string base = "[";
    for (int r = 0; r < 4; ++r) {
      base += r ? ", [" : "[";
      for (int c = 0; c < 4; ++c)
        base += (c ? ", " : "") + fmt::format("{:.12g}", given.matrix()(r, c));
      base += "]";
    }
    base += "]";
    const std::string trust =
        v1 ? "" : fmt::format(", certificate_sha256: '{}'", abb_->certificate_sha256());
    testing::WriteText(
        dir_.File("lab.yaml"),
        fmt::format("robot:\n  model: '{}'\n  controller: {{protocol: abb, host: 127.0.0.1, "
                    "rws_port: {}, rws: {}, credentials: abb.yaml{}, can_move: true, "
                    "speed_percent: 50}}\n  base: {}\ninstruments:\n  - {{station: LT1, "
                    "protocol: emscon, tcp: '{}', measurement_time_ms: 20}}\nstations: "
                    "stations.yaml\ntolerances: {{settle_ms: 0, timeout_ms: 2000, fault_retries: "
                    "1, fault_retry_delay_ms: 20}}\n",
                    testing::SourcePath("models/irb4600.yaml"), abb_->port(), v1 ? 1 : 2, trust,
                    base, tracker_->path()));
  }

  io::LabConfig Lab() const { return io::LoadLab(dir_.File("lab.yaml")); }
  std::string Db() const { return dir_.File("lab.db"); }
  int64_t NewSession(db::Database& db, const std::string& robot = "irb4600") {
    return CreateSession(db, Lab(), robot, plan_);
  }

  // Every stored configuration at its planned joints (as RAPID nums), its point where the true
  // robot is at those joints (its joint errors included), within the tracker's noise.
  void ExpectStoredAsPlanned(db::Database& db, int64_t session, size_t count) {
    const auto poses = db::LoadSessionPoses(db, session);
    ASSERT_EQ(poses.size(), count);
    calibration::Kinematics kin(model_);
    for (size_t k = 0; k < count; ++k) {
      bool planned = false;
      for (const auto& c : plan_) {
        planned |= (poses[k].joints_rad - c.joints_rad).cwiseAbs().maxCoeff() < kFloatRad;
      }
      EXPECT_TRUE(planned) << "configuration " << k << ": " << poses[k].joints_rad.transpose();
      const Eigen::VectorXd q = truth_.joint_errors.TrueAngles(poses[k].joints_rad);
      const Eigen::Vector3d truth =
          kin.Position(truth_.world_from_base, truth_.true_params, q.data());
      EXPECT_LT((poses[k].target_in_world - truth).norm(), 0.15) << "configuration " << k;
    }
  }

  testing::TempDir dir_;
  calibration::RobotModel model_;
  simulation::VirtualRobot truth_;
  std::unique_ptr<simulation::VirtualLab> lab_;
  std::unique_ptr<simulation::EmsconSimulator> tracker_;
  std::unique_ptr<simulation::RwsSimulator> abb_;
  Plan plan_;
};

class AbbCaptureVersion : public AbbCaptureFixture,
                          public ::testing::WithParamInterface<rws::Version> {};

TEST_P(AbbCaptureVersion, CapturesOverRobotWebServices) {
  StartController(Options(GetParam()));
  db::Database db(Db());
  const int64_t session = NewSession(db);
  const CaptureSummary s = workflows::CaptureInto(db, Lab(), session, {});
  ASSERT_TRUE(s.completed) << s.pause_reason;
  EXPECT_EQ(s.measured, kAbbConfigurations);
  ExpectStoredAsPlanned(db, session, kAbbConfigurations);
  const auto record = db::SessionController(db, session);
  ASSERT_TRUE(record);
  EXPECT_EQ(record->model, "IRB 4600-40/2.55");
  EXPECT_EQ(record->serial, truth_.identity.serial);
  EXPECT_NE(s.controller.find("IRB 4600-40/2.55 serial " + truth_.identity.serial),
            std::string::npos)
      << s.controller;
  EXPECT_EQ(abb_->snapshot().moves, kAbbConfigurations);
  EXPECT_EQ(abb_->snapshot().logins, 1);  // one session, its cookie kept
  // The lab text stored with the session names the credentials file, never the password.
  EXPECT_EQ(db.sql().execAndGet("SELECT count(*) FROM sessions WHERE lab_yaml LIKE '%pa55%'")
                .getInt(),
            0);
}

INSTANTIATE_TEST_SUITE_P(Rws, AbbCaptureVersion,
                         ::testing::Values(rws::Version::kRws1, rws::Version::kRws2),
                         [](const auto& info) {
                           return info.param == rws::Version::kRws1 ? "Irc5Rws1" : "OmniCoreRws2";
                         });

TEST_F(AbbCaptureFixture, AGuardStopDuringAMoveIsWaitedOutThroughTheOperatorsRecovery) {
  StartController(Options());
  db::Database db(Db());
  const int64_t session = NewSession(db);
  abb_->StopDuringNextMove(simulation::RwsSimulator::CellStop::kGuardStop, 0.5);
  std::vector<std::string> told, waiting;
  std::thread operator_;
  CaptureOptions options;
  options.controller_fault = [&](const instruments::ControllerError& e) {
    told.push_back(e.what());
    // The operator closes the door and resets the stop, switches the motors on, and starts
    // the program (continue): each step a moment after the other.
    operator_ = std::thread([this] {
      std::this_thread::sleep_for(20ms);
      abb_->ResetStop();
      std::this_thread::sleep_for(20ms);
      abb_->SetMotors(true);
      std::this_thread::sleep_for(20ms);
      abb_->StartProgram();
    });
    return false;  // armsig cannot reset a guard stop
  };
  options.progress = [&](const Progress& p) {
    if (!p.waiting.empty()) waiting.push_back(p.waiting);
  };
  const CaptureSummary s = workflows::CaptureInto(db, Lab(), session, options);
  operator_.join();
  ASSERT_TRUE(s.completed) << s.pause_reason;
  ASSERT_EQ(told.size(), 1u);
  EXPECT_NE(told[0].find("guard stop during move"), std::string::npos) << told[0];
  ASSERT_EQ(waiting.size(), 1u);
  EXPECT_NE(waiting[0].find("close it and reset the stop"), std::string::npos) << waiting[0];
  EXPECT_EQ(s.controller_waits, 1);
  EXPECT_EQ(s.skipped, 0);
  ExpectStoredAsPlanned(db, session, kAbbConfigurations);
}

TEST_F(AbbCaptureFixture, AnEmergencyStopPausesTheSessionNamingWhatToDoAndItResumes) {
  StartController(Options(rws::Version::kRws1));
  db::Database db(Db());
  const int64_t session = NewSession(db);
  CaptureOptions options;
  options.progress = [&](const Progress& p) {
    if (p.done == 2) abb_->EmergencyStop();
  };
  const CaptureSummary first = workflows::CaptureInto(db, Lab(), session, options);
  EXPECT_TRUE(first.paused);
  EXPECT_NE(first.pause_reason.find("emergency stop"), std::string::npos) << first.pause_reason;
  EXPECT_NE(first.pause_reason.find("release the emergency stop button"), std::string::npos);
  EXPECT_EQ(db::LoadSession(db, session)->state, db::SessionState::kPaused);
  EXPECT_EQ(db::StoredSeqs(db, session).size(), 2u);  // nothing of the third configuration
  abb_->ResetStop();
  abb_->SetMotors(true);
  abb_->StartProgram();
  const CaptureSummary resumed = workflows::CaptureInto(db, Lab(), session, {});
  ASSERT_TRUE(resumed.completed) << resumed.pause_reason;
  EXPECT_EQ(resumed.already, 2);
  ExpectStoredAsPlanned(db, session, kAbbConfigurations);
}

TEST_F(AbbCaptureFixture, ManualModeIsNamedBeforeASessionIsMadeAndPausesOneUnderWay) {
  StartController(Options());
  abb_->SetMode(rws::OperationMode::kManualReduced);
  abb_->SetMotors(true);
  workflows::CaptureRequest request;
  request.db_path = Db();
  request.lab = dir_.File("lab.yaml");
  request.plan = "auto:5";
  request.robot = "irb4600";
  try {
    workflows::RunCaptureSession(request);
    FAIL() << "captured in manual mode";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("operating mode MANR"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("nothing was stored"), std::string::npos) << e.what();
  }
  db::Database db(Db());
  EXPECT_TRUE(db::SessionIds(db).empty());
  // The program stopped while a session runs: paused, resumable.
  abb_->SetMode(rws::OperationMode::kAuto);
  abb_->SetMotors(true);
  abb_->StartProgram(true);
  const int64_t session = NewSession(db);
  CaptureOptions options;
  options.progress = [&](const Progress& p) {
    if (p.done == 1) abb_->StopProgram();
  };
  const CaptureSummary s = workflows::CaptureInto(db, Lab(), session, options);
  EXPECT_TRUE(s.paused);
  EXPECT_NE(s.pause_reason.find("the RAPID program is not running"), std::string::npos)
      << s.pause_reason;
  EXPECT_EQ(db::StoredSeqs(db, session).size(), 1u);
  abb_->StartProgram();
  ASSERT_TRUE(workflows::CaptureInto(db, Lab(), session, {}).completed);
  ExpectStoredAsPlanned(db, session, kAbbConfigurations);
}

// The motors switched off mid-session pause it naming the controller; the credentials file
// then edited to a wrong password refuses the resume naming the controller, the user and the
// file (never the password), and nothing stored is lost; set right, the session goes on.
TEST_F(AbbCaptureFixture, MotorsOffThenAWrongPasswordLoseNothingAndNameTheController) {
  StartController(Options(rws::Version::kRws1));
  db::Database db(Db());
  const int64_t session = NewSession(db);
  CaptureOptions options;
  options.progress = [&](const Progress& p) {
    if (p.done == 2) abb_->SetMotors(false);
  };
  const CaptureSummary first = workflows::CaptureInto(db, Lab(), session, options);
  EXPECT_TRUE(first.paused);
  EXPECT_NE(first.pause_reason.find("ABB IRB 4600-40/2.55 'armsig-virtual' at 127.0.0.1:"),
            std::string::npos)
      << first.pause_reason;
  EXPECT_NE(first.pause_reason.find("motors off"), std::string::npos) << first.pause_reason;
  EXPECT_NE(first.pause_reason.find("switch the motors on"), std::string::npos);
  EXPECT_EQ(db::StoredSeqs(db, session).size(), 2u);
  abb_->SetMotors(true);
  abb_->StartProgram();
  testing::WriteText(dir_.File("abb.yaml"), "user: armsig\npassword: \"wr0ng s3cret\"\n");
  ::chmod(dir_.File("abb.yaml").c_str(), 0600);
  try {
    workflows::CaptureInto(db, Lab(), session, {});
    FAIL() << "resumed with a wrong password";
  } catch (const robots::AbbFault& e) {
    const std::string what = e.what();
    EXPECT_EQ(e.kind(), robots::AbbFault::Kind::kCredentials);
    EXPECT_NE(what.find("ABB controller at 127.0.0.1:"), std::string::npos) << what;
    EXPECT_NE(what.find("refused the user 'armsig'"), std::string::npos) << what;
    EXPECT_NE(what.find("the credentials file " + dir_.File("abb.yaml")), std::string::npos)
        << what;
    EXPECT_EQ(what.find("wr0ng"), std::string::npos) << what;
  }
  EXPECT_GE(abb_->snapshot().refused_logins, 1);
  EXPECT_EQ(db::StoredSeqs(db, session).size(), 2u);
  EXPECT_EQ(db::LoadSession(db, session)->state, db::SessionState::kPaused);
  testing::WriteText(dir_.File("abb.yaml"), "user: armsig\npassword: \"c3ll-2 pa55\"\n");
  const CaptureSummary resumed = workflows::CaptureInto(db, Lab(), session, {});
  ASSERT_TRUE(resumed.completed) << resumed.pause_reason;
  EXPECT_EQ(resumed.already, 2);
  ExpectStoredAsPlanned(db, session, kAbbConfigurations);
}

// A server that takes requests and never answers: each call ends by the lab's deadline, the
// configuration is retried once, then the session pauses naming the controller; once it
// answers again the session goes on from where it stopped.
TEST_F(AbbCaptureFixture, AStalledServerPausesTheSessionByItsDeadlineAndItResumes) {
  StartController(Options());
  std::string lab = testing::ReadText(dir_.File("lab.yaml"));
  lab.replace(lab.find("timeout_ms: 2000"), std::string("timeout_ms: 2000").size(),
              "timeout_ms: 400");
  testing::WriteText(dir_.File("lab.yaml"), lab);
  db::Database db(Db());
  const int64_t session = NewSession(db);
  CaptureOptions options;
  options.progress = [&](const Progress& p) {
    if (p.done == 3) abb_->InjectAlways({simulation::Fault::kDropReply});
  };
  const CaptureSummary first = workflows::CaptureInto(db, Lab(), session, options);
  EXPECT_TRUE(first.paused);
  EXPECT_NE(first.pause_reason.find("connection lost: Robot Web Services did not answer"),
            std::string::npos)
      << first.pause_reason;
  EXPECT_NE(first.pause_reason.find("ABB IRB 4600-40/2.55"), std::string::npos);
  EXPECT_EQ(db::StoredSeqs(db, session).size(), 3u);
  abb_->ClearFaults();
  const CaptureSummary resumed = workflows::CaptureInto(db, Lab(), session, {});
  ASSERT_TRUE(resumed.completed) << resumed.pause_reason;
  EXPECT_EQ(resumed.already, 3);
  ExpectStoredAsPlanned(db, session, kAbbConfigurations);
}

TEST_F(AbbCaptureFixture, TheNetworkCutAndRestoredMidSessionLosesNothing) {
  StartController(Options());
  db::Database db(Db());
  const int64_t session = NewSession(db);
  std::thread cable;
  CaptureOptions options;
  options.progress = [&](const Progress& p) {
    if (p.done != 2 || cable.joinable()) return;
    abb_->CutNetwork();
    cable = std::thread([this] {
      std::this_thread::sleep_for(150ms);  // back within the call's 2 s
      abb_->RestoreNetwork();
    });
  };
  const CaptureSummary s = workflows::CaptureInto(db, Lab(), session, options);
  cable.join();
  ASSERT_TRUE(s.completed) << s.pause_reason;
  ExpectStoredAsPlanned(db, session, kAbbConfigurations);
  EXPECT_EQ(abb_->snapshot().logins, 1);  // the session cookie outlived the cut
}

TEST_F(AbbCaptureFixture, AReadingTakenWhileTheArmMovesIsNeverStored) {
  StartController(Options());
  db::Database db(Db());
  const int64_t session = NewSession(db);
  // Once the second move has ended, something turns joint 6 for 10 s (0.1 s of wall time)
  // while the tracker measures: the reading is refused, the configuration measured again (the
  // module's move takes the arm back), every stored joint a planned one. (Not at the first
  // configuration: the tracker checks its reading convention there, on a standing arm.)
  CaptureOptions options;
  options.progress = [&](const Progress& p) {
    if (p.done == 1 && p.waiting.empty()) abb_->TurnAfterNextMove(5, 3.0, 0.3, 10.0);
  };
  const CaptureSummary s = workflows::CaptureInto(db, Lab(), session, options);
  ASSERT_TRUE(s.completed) << s.pause_reason;
  ExpectStoredAsPlanned(db, session, kAbbConfigurations);
  EXPECT_GE(s.moving_refused, 1);
}

TEST_F(AbbCaptureFixture, AnotherArmIsRefusedBeforeASessionIsMade) {
  StartController(Options());
  workflows::CaptureRequest request;
  request.db_path = Db();
  request.lab = dir_.File("lab.yaml");
  request.plan = "auto:5";
  request.robot = "irb4600";
  ASSERT_TRUE(workflows::RunCaptureSession(request).ok);
  auto other = Options();
  other.serial_low = "599999";
  StartController(other);
  try {
    workflows::RunCaptureSession(request);
    FAIL() << "another arm was captured as robot irb4600";
  } catch (const InputError& e) {
    EXPECT_NE(e.message().find("another arm"), std::string::npos) << e.what();
    EXPECT_NE(e.message().find("4600-599999"), std::string::npos) << e.what();
  }
  auto small = Options();
  small.model = "IRB 1600-10/1.45";
  StartController(small);
  request.robot = "new-robot";
  try {
    workflows::RunCaptureSession(request);
    FAIL() << "an IRB 1600 was captured with an IRB 4600 model";
  } catch (const InputError& e) {
    EXPECT_NE(e.message().find("answers model IRB 1600-10/1.45"), std::string::npos) << e.what();
  }
  db::Database db(Db());
  EXPECT_EQ(db::SessionIds(db).size(), 1u);
}

TEST_F(AbbCaptureFixture, CredentialsComeFromTheFileOrTheEnvironmentOnly) {
  StartController(Options());
  std::string lab = testing::ReadText(dir_.File("lab.yaml"));
  lab.replace(lab.find("credentials: abb.yaml, "), std::string("credentials: abb.yaml, ").size(),
              "");
  testing::WriteText(dir_.File("lab.yaml"), lab);
  try {
    OpenController(Lab());
    FAIL() << "opened without credentials";
  } catch (const InputError& e) {
    EXPECT_NE(e.message().find("credentials: FILE"), std::string::npos) << e.what();
    EXPECT_NE(e.message().find("ARMSIG_CONTROLLER_USER"), std::string::npos) << e.what();
  }
  ::setenv("ARMSIG_CONTROLLER_USER", "armsig", 1);
  ::setenv("ARMSIG_CONTROLLER_PASSWORD", "c3ll-2 pa55", 1);
  const auto controller = OpenController(Lab());
  ::unsetenv("ARMSIG_CONTROLLER_USER");
  ::unsetenv("ARMSIG_CONTROLLER_PASSWORD");
  ASSERT_TRUE(controller->Identify());
  // A setting out of its range is refused naming its key.
  lab = testing::ReadText(dir_.File("lab.yaml"));
  lab.replace(lab.find("speed_percent: 50"), std::string("speed_percent: 50").size(),
              "speed_percent: 150");
  testing::WriteText(dir_.File("lab.yaml"), lab);
  try {
    OpenController(Lab());
    FAIL() << "opened at 150 %";
  } catch (const InputError& e) {
    EXPECT_NE(e.message().find("speed_percent: expected a velocity override from 1 to 100"),
              std::string::npos)
        << e.what();
  }
}

}  // namespace
}  // namespace armsig::acquisition
