// Capture sessions with a Universal Robots controller: the virtual UR (RTDE, primary and
// secondary interfaces, dashboard on loopback TCP) moving a UR10 with hidden geometric and
// joint-angle errors, measured by the virtual laser tracker (emScon on loopback TCP). Every
// fault of issue 35 against the simulator, at the session's level: what is stored (never a
// wrong reading), what the session says, and that it goes on or resumes. The UR runs 100
// times faster than physical time.
#include <fmt/format.h>
#include <gtest/gtest.h>

#include <atomic>
#include <functional>
#include <thread>

#include "acquisition/controller_record.h"
#include "acquisition/lab.h"
#include "acquisition/on_the_move.h"
#include "acquisition/session.h"
#include "core/units.h"
#include "db/database.h"
#include "db/store.h"
#include "db/streams.h"
#include "io/lab_file.h"
#include "simulation/ur_simulator.h"
#include "support/tracker_cell.h"
#include "test_support.h"
#include "workflows/capture.h"

namespace armsig::acquisition {
namespace {

using namespace std::chrono_literals;
using Kind = instruments::ControllerError::Kind;

constexpr int kConfigurations = 5;

class UrCaptureFixture : public ::testing::Test {
 protected:
  simulation::UrSimulatorOptions Options(bool e_series = true, double time_scale = 0.01) const {
    simulation::UrSimulatorOptions o = e_series ? simulation::UrSimulatorOptions{}
                                                : simulation::Cb3Options();
    o.model = truth_.identity.model;
    o.serial = truth_.identity.serial;
    o.kinematics = truth_.kinematics;
    o.home_rad = truth_.home_rad;
    o.time_scale = time_scale;
    return o;
  }

  // The controller, and the lab file that names it (a hand-measured base, 3 mm and 1 mrad off,
  // so the tracker's beam is pointed from the first configuration).
  void StartController(simulation::UrSimulatorOptions o, int timeout_ms = 2000) {
    ur_.reset();
    ur_ = std::make_unique<simulation::UrSimulator>(*lab_, o);
    ur_->Start();
    Eigen::Isometry3d given = truth_.world_from_base;
    given.translate(Eigen::Vector3d(3.0, -2.0, 1.5));
    given.rotate(Eigen::AngleAxisd(1e-3, Eigen::Vector3d::UnitZ()));
    std::string base = "[";
    for (int r = 0; r < 4; ++r) {
      base += r ? ", [" : "[";
      for (int c = 0; c < 4; ++c) base += (c ? ", " : "") + fmt::format("{:.12g}", given.matrix()(r, c));
      base += "]";
    }
    base += "]";
    const auto& p = ur_->ports();
    testing::WriteText(
        dir_.File("lab.yaml"),
        fmt::format("robot:\n  model: '{}'\n  controller: {{protocol: ur, host: 127.0.0.1, "
                    "can_move: true, rtde_port: {}, primary_port: {}, secondary_port: {}, "
                    "dashboard_port: {}}}\n  base: {}\ninstruments:\n  - {{station: LT1, "
                    "protocol: emscon, tcp: '{}', measurement_time_ms: 20}}\nstations: "
                    "stations.yaml\ntolerances: {{settle_ms: 0, timeout_ms: {}, fault_retries: "
                    "1, fault_retry_delay_ms: 20}}\n",
                    testing::SourcePath("models/ur10.yaml"), p.rtde, p.primary, p.secondary,
                    p.dashboard, base, tracker_->path(), timeout_ms));
  }

  io::LabConfig Lab() const { return io::LoadLab(dir_.File("lab.yaml")); }
  // `armsig capture` of a new session of robot ur10, five well-spread configurations.
  workflows::CaptureRequest Request() const {
    workflows::CaptureRequest request;
    request.db_path = Db();
    request.lab = dir_.File("lab.yaml");
    request.plan = "auto:5";
    request.robot = "ur10";
    return request;
  }
  std::string Db() const { return dir_.File("lab.db"); }

  int64_t NewSession(db::Database& db, const std::string& robot = "ur10") {
    return CreateSession(db, Lab(), robot, plan_);
  }

  // The session run with `event` happening once `done` configurations are stored.
  CaptureSummary CaptureWithEvent(db::Database& db, int64_t session, int done,
                                  const std::function<void()>& event) {
    return testing::CaptureWithEvent(db, Lab(), session, done, event);
  }
  std::vector<testing::StoredPose> Stored(db::Database& db, int64_t session) {
    return testing::StoredPoses(db, session);
  }
  // Every stored configuration at its planned joints, exactly (RTDE's doubles), its point where
  // the true robot is at those joints, within the tracker's noise.
  void ExpectStoredAsPlanned(db::Database& db, int64_t session, size_t count) {
    testing::ExpectStoredAsPlanned(db, session, count, cell_, 1e-12);
  }

  testing::TempDir dir_;
  testing::TrackerCell cell_{"ur10", "models/ur10.yaml", dir_, kConfigurations, 25.0};
  calibration::RobotModel& model_ = cell_.model;
  simulation::VirtualRobot& truth_ = cell_.truth;
  std::unique_ptr<simulation::VirtualLab>& lab_ = cell_.lab;
  std::unique_ptr<simulation::EmsconSimulator>& tracker_ = cell_.tracker;
  Plan& plan_ = cell_.plan;
  std::unique_ptr<simulation::UrSimulator> ur_;
};

class UrCaptureRate : public UrCaptureFixture, public ::testing::WithParamInterface<bool> {};

TEST_P(UrCaptureRate, CapturesOverRtdeWithTheControllersTimeStamps) {
  const bool e_series = GetParam();
  // Ten times faster than physical time: 500 Hz is a package every 0.2 ms of wall time, the
  // most the simulator sends (none left out).
  StartController(Options(e_series, 0.1));
  db::Database db(Db());
  const int64_t session = NewSession(db);
  const CaptureSummary s = workflows::CaptureInto(db, Lab(), session, {});
  ASSERT_TRUE(s.completed) << s.pause_reason;
  EXPECT_EQ(s.measured, kConfigurations);
  EXPECT_EQ(ur_->frequency_hz(), e_series ? 500.0 : 125.0);
  ExpectStoredAsPlanned(db, session, kConfigurations);
  // The controller's clock: stamped, in whole RTDE periods, later for every configuration.
  const auto stored = Stored(db, session);
  for (size_t k = 0; k < stored.size(); ++k) {
    ASSERT_TRUE(stored[k].controller_time_s);
    const double periods = *stored[k].controller_time_s * ur_->frequency_hz();
    EXPECT_NEAR(periods, std::round(periods), 1e-6);
    if (k > 0) {
      EXPECT_GT(*stored[k].controller_time_s, *stored[k - 1].controller_time_s);
    }
  }
  // Who the controller is, with the session and the robot.
  const auto record = db::SessionController(db, session);
  ASSERT_TRUE(record);
  EXPECT_EQ(record->model, "UR10");
  EXPECT_EQ(record->serial, truth_.identity.serial);
  EXPECT_EQ(record->kinematics_checksum, ur_->kinematics_info().ToKinematics().checksum);
  const auto k = KinematicsFromJson(record->kinematics_json, {db.path(), "sessions", session, "kinematics_json"});
  EXPECT_EQ(k.dh_d_mm, truth_.kinematics.dh_d_mm);
  const auto robot = db::RobotControllerRecord(db, *db::FindRobot(db, "ur10"));
  ASSERT_TRUE(robot);
  EXPECT_EQ(robot->serial, truth_.identity.serial);
  EXPECT_NE(s.controller.find("UR10 serial " + truth_.identity.serial), std::string::npos)
      << s.controller;
}

INSTANTIATE_TEST_SUITE_P(Rtde, UrCaptureRate, ::testing::Values(false, true),
                         [](const auto& info) { return info.param ? "ESeries500Hz" : "Cb3At125Hz"; });

TEST_F(UrCaptureFixture, AProtectiveStopDuringAMovePausesSaysSoAndGoesOnOnceCleared) {
  StartController(Options());
  db::Database db(Db());
  const int64_t session = NewSession(db);
  ur_->ProtectiveStopDuringNextMove(0.5);
  std::vector<std::string> told, waiting;
  CaptureOptions options;
  options.controller_fault = [&](const instruments::ControllerError& e) {
    told.push_back(e.what());
    return true;  // the operator looked: armsig unlocks it (5 s after the stop at the earliest)
  };
  options.progress = [&](const Progress& p) {
    if (!p.waiting.empty()) waiting.push_back(p.waiting);
  };
  const CaptureSummary s = workflows::CaptureInto(db, Lab(), session, options);
  ASSERT_TRUE(s.completed) << s.pause_reason;
  ASSERT_EQ(told.size(), 1u);
  EXPECT_NE(told[0].find("protective stop: the arm stopped itself"), std::string::npos) << told[0];
  ASSERT_EQ(waiting.size(), 1u);
  EXPECT_NE(waiting[0].find("protective stop: look at why"), std::string::npos) << waiting[0];
  EXPECT_EQ(s.controller_waits, 1);
  EXPECT_EQ(s.skipped, 0);
  ExpectStoredAsPlanned(db, session, kConfigurations);
  EXPECT_EQ(ur_->arm().stops(), 1);
}

TEST_F(UrCaptureFixture, AProtectiveStopClearedOnThePendantLetsTheSessionGoOn) {
  StartController(Options());
  db::Database db(Db());
  const int64_t session = NewSession(db);
  ur_->ProtectiveStopDuringNextMove(0.3);
  std::thread pendant;
  CaptureOptions options;
  options.controller_fault = [&](const instruments::ControllerError&) {
    pendant = std::thread([this] {
      std::this_thread::sleep_for(30ms);
      ur_->UnlockProtectiveStopOnPendant();
    });
    return false;  // cleared on the pendant: armsig waits
  };
  const CaptureSummary s = workflows::CaptureInto(db, Lab(), session, options);
  pendant.join();
  ASSERT_TRUE(s.completed) << s.pause_reason;
  EXPECT_EQ(s.controller_waits, 1);
  ExpectStoredAsPlanned(db, session, kConfigurations);
}

TEST_F(UrCaptureFixture, AnEmergencyStopPausesTheSessionNamingWhatToDoAndItResumes) {
  StartController(Options());
  db::Database db(Db());
  const int64_t session = NewSession(db);
  const CaptureSummary first =
      CaptureWithEvent(db, session, 2, [&] { ur_->PressEmergencyStop(); });
  EXPECT_TRUE(first.paused);
  EXPECT_NE(first.pause_reason.find("emergency stop"), std::string::npos) << first.pause_reason;
  EXPECT_NE(first.pause_reason.find("release the emergency stop button"), std::string::npos);
  EXPECT_EQ(db::LoadSession(db, session)->state, db::SessionState::kPaused);
  EXPECT_EQ(Stored(db, session).size(), 2u);  // nothing of the third configuration
  EXPECT_EQ(db::StoredSeqs(db, session).size(), 2u);
  ur_->ReleaseEmergencyStop();
  ur_->PowerOnFromPendant();
  const CaptureSummary resumed = workflows::CaptureInto(db, Lab(), session, {});
  ASSERT_TRUE(resumed.completed) << resumed.pause_reason;
  EXPECT_EQ(resumed.already, 2);
  ExpectStoredAsPlanned(db, session, kConfigurations);
}

TEST_F(UrCaptureFixture, LocalControlIsNamedBeforeASessionIsMadeAndPausesOneUnderWay) {
  StartController(Options());
  ur_->SetRemoteControl(false);
  const workflows::CaptureRequest request = Request();
  try {
    workflows::RunCaptureSession(request);
    FAIL() << "captured in local control";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("not in remote control"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("nothing was stored"), std::string::npos);
  }
  db::Database db(Db());
  EXPECT_TRUE(db::SessionIds(db).empty());
  // Switched to local control while a session runs: paused, resumable.
  ur_->SetRemoteControl(true);
  const int64_t session = NewSession(db);
  const CaptureSummary s =
      CaptureWithEvent(db, session, 1, [&] { ur_->SetRemoteControl(false); });
  EXPECT_TRUE(s.paused);
  EXPECT_NE(s.pause_reason.find("switch the pendant to Remote Control"), std::string::npos)
      << s.pause_reason;
  EXPECT_EQ(Stored(db, session).size(), 1u);
  ur_->SetRemoteControl(true);
  ASSERT_TRUE(workflows::CaptureInto(db, Lab(), session, {}).completed);
  ExpectStoredAsPlanned(db, session, kConfigurations);
}

TEST_F(UrCaptureFixture, ARefusedRtdeVersionPausesTheSessionBeforeAnythingIsStored) {
  StartController(Options());
  ur_->RefuseRtdeVersion2(true);
  db::Database db(Db());
  const int64_t session = NewSession(db);
  const CaptureSummary s = workflows::CaptureInto(db, Lab(), session, {});
  EXPECT_TRUE(s.paused);
  EXPECT_NE(s.pause_reason.find("refused RTDE protocol version 2"), std::string::npos)
      << s.pause_reason;
  EXPECT_TRUE(Stored(db, session).empty());
  EXPECT_TRUE(db::StoredSeqs(db, session).empty());  // not even a skipped row
}

TEST_F(UrCaptureFixture, AConnectionDroppedAndRestoredMidSessionLosesNothing) {
  StartController(Options());
  db::Database db(Db());
  const int64_t session = NewSession(db);
  const int connections_before = ur_->connections();
  CaptureOptions options;
  options.progress = [&](const Progress& p) {
    if (p.done == 2) ur_->DropConnections(150ms);  // restored within the call's 2 s
  };
  const CaptureSummary s = workflows::CaptureInto(db, Lab(), session, options);
  ASSERT_TRUE(s.completed) << s.pause_reason;
  EXPECT_GT(ur_->connections(), connections_before + 2);  // the interfaces connected again
  ExpectStoredAsPlanned(db, session, kConfigurations);
}

TEST_F(UrCaptureFixture, AConnectionThatDoesNotComeBackPausesTheSessionResumably) {
  StartController(Options(), 500);  // each call given up after 0.5 s
  db::Database db(Db());
  const int64_t session = NewSession(db);
  const CaptureSummary s =
      CaptureWithEvent(db, session, 1, [&] { ur_->DropConnections(10s); });
  EXPECT_TRUE(s.paused);
  EXPECT_NE(s.pause_reason.find("connection lost"), std::string::npos) << s.pause_reason;
  EXPECT_EQ(Stored(db, session).size(), 1u);
  // The controller back (a new one on the same arm): the session resumes where it stopped.
  StartController(Options());
  ASSERT_TRUE(workflows::CaptureInto(db, Lab(), session, {}).completed);
  ExpectStoredAsPlanned(db, session, kConfigurations);
}

TEST_F(UrCaptureFixture, AReadingTakenWhileTheArmMovesIsNeverStored) {
  // Time 10 times faster than the wall's (not 100): the 0.3 s the arm stands before the other
  // program turns it are 30 ms of wall time, which a loaded machine's packages do not miss.
  StartController(Options(true, 0.1));
  db::Database db(Db());
  const int64_t session = NewSession(db);
  // Once the first move has ended, another program turns joint 6 for 10 s (1 s of wall
  // time), while the tracker measures: that reading is refused, the configuration measured
  // again (the controller's move takes the arm back), every stored joint the planned one.
  ur_->MoveAfterNextMove(5, 0.05, 0.3, 10.0);
  const CaptureSummary s = workflows::CaptureInto(db, Lab(), session, {});
  ASSERT_TRUE(s.completed) << s.pause_reason;
  ExpectStoredAsPlanned(db, session, kConfigurations);
  // The first configuration was measured again: its first reading, taken as the arm moved, is
  // not there — refused by the joints read again after the tracker (a second measurement) or,
  // when the motion began before the move was seen to end, by the move itself.
  EXPECT_TRUE(Stored(db, session)[0].attempts >= 2 || s.moving_refused >= 1)
      << "attempts " << Stored(db, session)[0].attempts;
}

TEST_F(UrCaptureFixture, AnotherArmIsRefusedBeforeASessionIsMade) {
  StartController(Options());
  workflows::CaptureRequest request = Request();
  ASSERT_TRUE(workflows::RunCaptureSession(request).ok);
  // Another UR10 (another serial number) behind the same lab file: refused.
  auto other = Options();
  other.serial = "20193019999";
  StartController(other);
  try {
    workflows::RunCaptureSession(request);
    FAIL() << "another arm was captured as robot ur10";
  } catch (const InputError& e) {
    EXPECT_NE(e.message().find("another arm"), std::string::npos) << e.what();
    EXPECT_NE(e.message().find("20193019999"), std::string::npos) << e.what();
  }
  // Another model than the lab's robot model: refused too.
  auto ur5 = Options();
  ur5.model = "UR5";
  StartController(ur5);
  request.robot = "new-robot";
  try {
    workflows::RunCaptureSession(request);
    FAIL() << "a UR5 was captured with a UR10 model";
  } catch (const InputError& e) {
    EXPECT_NE(e.message().find("answers model UR5, the lab's robot model is ur10"), std::string::npos)
        << e.what();
  }
  db::Database db(Db());
  EXPECT_EQ(db::SessionIds(db).size(), 1u);
}

TEST_F(UrCaptureFixture, AChangedKinematicsInfoRefusesTheResumeAndIsNamedAsACause) {
  StartController(Options());
  db::Database db(Db());
  const int64_t first = NewSession(db);
  std::atomic<bool> stop{false};
  CaptureOptions options;
  options.stop = &stop;
  options.progress = [&](const Progress& p) {
    if (p.done == 2) stop = true;
  };
  EXPECT_TRUE(workflows::CaptureInto(db, Lab(), first, options).stopped);
  auto recalibrated = truth_.kinematics;
  recalibrated.dh_theta_rad[1] += 3e-4;  // UR's own calibration run again
  ur_->SetKinematics(recalibrated);
  try {
    workflows::CaptureInto(db, Lab(), first, {});
    FAIL() << "resumed across a changed controller calibration";
  } catch (const InputError& e) {
    EXPECT_NE(e.message().find("the controller's own calibration changed since session"),
              std::string::npos)
        << e.what();
  }
  EXPECT_EQ(Stored(db, first).size(), 2u);
  const int64_t second = NewSession(db);
  ASSERT_TRUE(workflows::CaptureInto(db, Lab(), second, {}).completed);
  const std::string cause = ControllerCalibrationChange(db, *db::FindRobot(db, "ur10"));
  EXPECT_NE(cause.find("the controller's own calibration changed"), std::string::npos) << cause;
  EXPECT_NE(cause.find(fmt::format("in session {},", first)), std::string::npos) << cause;
  EXPECT_NE(cause.find(fmt::format("in session {})", second)), std::string::npos) << cause;
  // The robot keeps the newest kinematics.
  EXPECT_EQ(db::RobotControllerRecord(db, *db::FindRobot(db, "ur10"))->kinematics_checksum,
            db::SessionController(db, second)->kinematics_checksum);
}

// Measuring on the move through the real drivers: the UR sweeps thirteen waypoints in two
// segments while the tracker measures continuously on its own clock (42.1 ms, −8 ppm off).
// Ctrl-C after the first segment: it is kept, the session paused; the resume sweeps the
// second segment only, through a beam break (named, its records missing, the stream going on),
// then pairs every point at the tracker's time with the clock estimated from the data.
TEST_F(UrCaptureFixture, OnTheMoveKeepsItsSegmentsThroughCtrlCAndNamesABeamBreak) {
  StartController(Options(true, 0.05));
  tracker_->FollowArm(&ur_->arm());
  Plan sweep;
  std::mt19937 rng(21);
  std::uniform_real_distribution<double> around(-0.7, 0.7);
  for (int k = 0; k < 13; ++k) {
    Eigen::VectorXd q = truth_.home_rad;
    for (int j = 0; j < q.size(); ++j) q(j) += around(rng);
    sweep.push_back({"W" + std::to_string(k + 1), q});
  }
  db::Database db(Db());
  const int64_t session = CreateSession(db, Lab(), "ur10", sweep);
  MarkOnTheMove(db, session);
  std::atomic<bool> stop{false};
  CaptureOptions options;
  options.stop = &stop;
  options.progress = [&](const Progress& p) {
    if (p.done == 1) stop = true;  // Ctrl-C once the first segment is stored
  };
  const CaptureSummary first = workflows::CaptureInto(db, Lab(), session, options);
  EXPECT_TRUE(first.stopped);
  ASSERT_TRUE(first.sweep);
  EXPECT_EQ(first.sweep->segments, 2);
  EXPECT_EQ(db::StoredStreamSegments(db, session), std::set<int>{0});
  EXPECT_EQ(db::LoadSession(db, session)->state, db::SessionState::kPaused);
  EXPECT_EQ(db.sql().execAndGet("SELECT count(*) FROM poses").getInt(), 0);  // not paired yet

  // The beam breaks for a second, three seconds into the resumed run (the segment sweeps for
  // about twenty; its set-up may take a moment of a loaded machine).
  const double now = ur_->arm().clock().Now();
  tracker_->BreakBeam(now + 3.0, now + 4.0);
  stop = false;
  options.progress = nullptr;
  const CaptureSummary second = workflows::CaptureInto(db, Lab(), session, options);
  ASSERT_TRUE(second.completed) << second.pause_reason;
  ASSERT_TRUE(second.sweep);
  const SweepSummary& w = *second.sweep;
  EXPECT_EQ(w.segments_before, 1);
  EXPECT_EQ(db::StoredStreamSegments(db, session), (std::set<int>{0, 1}));
  ASSERT_FALSE(w.beam_breaks.empty());
  EXPECT_NE(w.beam_breaks.front().find("NoDistanceSet"), std::string::npos) << w.beam_breaks.front();
  EXPECT_GT(tracker_->records_lost_to_breaks(), 0);
  EXPECT_EQ(db.sql().execAndGet("SELECT count(*) FROM stream_events").getInt(), 1);
  // No package stored twice.
  EXPECT_EQ(db.sql().execAndGet("SELECT count(*) FROM stream_joints").getInt(),
            db.sql().execAndGet("SELECT count(DISTINCT t_s) FROM stream_joints").getInt());
  ASSERT_TRUE(w.clock);
  EXPECT_NEAR(w.clock->offset_ms, 42.1, 0.5);
  EXPECT_GT(w.paired, 150);
  EXPECT_EQ(second.usable, w.paired);
  EXPECT_EQ(db.sql().execAndGet("SELECT count(*) FROM poses WHERE controller_time_s IS NOT NULL")
                .getInt(),
            w.paired);
  // Each paired configuration is the true robot at its joints, within the tracker's noise and
  // its clock share.
  calibration::Kinematics kin(model_);
  const auto poses = db::LoadSessionPoses(db, session);
  ASSERT_EQ(static_cast<int>(poses.size()), w.paired);
  double worst = 0.0;
  for (const auto& p : poses) {
    const Eigen::VectorXd q = truth_.joint_errors.TrueAngles(p.joints_rad);
    worst = std::max(worst, (kin.Position(truth_.world_from_base, truth_.true_params, q.data()) -
                             p.target_in_world).norm());
  }
  EXPECT_LT(worst, 0.15);
}

// A lab that cannot be measured on the move is refused before a session is made.
TEST_F(UrCaptureFixture, OnTheMoveNeedsAStreamingControllerArmsigMoves) {
  StartController(Options());
  io::LabConfig lab = Lab();
  EXPECT_NO_THROW(CheckOnTheMoveLab(lab));
  lab.controller.can_move = false;
  EXPECT_THROW(CheckOnTheMoveLab(lab), InputError);
  lab.controller.can_move = true;
  lab.instruments.clear();
  EXPECT_THROW(CheckOnTheMoveLab(lab), InputError);
}

}  // namespace
}  // namespace armsig::acquisition
