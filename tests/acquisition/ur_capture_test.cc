// Capture sessions with a Universal Robots controller: the virtual UR (RTDE, primary and
// secondary interfaces, dashboard on loopback TCP) moving a UR10 with hidden geometric and
// joint-angle errors, measured by the virtual laser tracker (emScon on loopback TCP). Every
// fault of issue 35 against the simulator, at the session's level: what is stored (never a
// wrong reading), what the session says, and that it goes on or resumes. The UR runs 100
// times faster than physical time.
#include <fmt/format.h>
#include <gtest/gtest.h>

#include <atomic>
#include <filesystem>
#include <cmath>
#include <functional>
#include <nlohmann/json.hpp>
#include <thread>
#include <tuple>

#include "acquisition/controller_record.h"
#include "acquisition/lab.h"
#include "acquisition/on_the_move.h"
#include "acquisition/session.h"
#include "core/units.h"
#include "db/database.h"
#include "db/store.h"
#include "db/streams.h"
#include "calibration/iso9283_path.h"
#include "io/lab_file.h"
#include "iso9283/iso9283_path_report.h"
#include "iso9283/iso9283_report.h"
#include "simulation/path_motion.h"
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
  // `measured_base`: the lab file's base instead (a base measured well).
  void StartController(simulation::UrSimulatorOptions o, int timeout_ms = 2000,
                       std::optional<Eigen::Isometry3d> measured_base = std::nullopt) {
    ur_.reset();
    ur_ = std::make_unique<simulation::UrSimulator>(*lab_, o);
    ur_->Start();
    Eigen::Isometry3d given = truth_.world_from_base;
    given.translate(Eigen::Vector3d(3.0, -2.0, 1.5));
    given.rotate(Eigen::AngleAxisd(1e-3, Eigen::Vector3d::UnitZ()));
    if (measured_base) given = *measured_base;
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
  // Ten times faster than physical time: at twenty, a loaded machine (four such tests on two
  // cores) thins the joint stream into gaps the pairing leaves out.
  StartController(Options(true, 0.1));
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
  // The session list says what it keeps: one segment swept, none of it paired yet.
  const auto listed = db::ListSessions(db, std::nullopt);
  ASSERT_EQ(listed.size(), 1u);
  EXPECT_EQ(listed[0].sweep_segments, 1);
  EXPECT_EQ(listed[0].measured, 0);

  // The beam breaks for a second, eight seconds into the resumed run (the segment sweeps for
  // about twenty; its set-up may take a moment of a loaded machine: 0.8 s of wall time here).
  const double now = ur_->arm().clock().Now();
  tracker_->BreakBeam(now + 8.0, now + 9.0);
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

// The true robot's path figures along the controller's linear moves through `rows` (one
// cycle: the robot repeats exactly), from the truth: what a perfect tracker would give.
calibration::iso9283::PathFigures TruePathFigures(const simulation::VirtualRobot& truth,
                                                  const calibration::RobotModel& model,
                                                  const acquisition::Plan& rows,
                                                  const calibration::iso9283::PathCommand& command) {
  const programs::ControllerModel controller = simulation::UrControllerModel(truth.kinematics);
  calibration::Kinematics kin(model);
  calibration::iso9283::AttainedCycle cycle;
  double t = 0.0;
  for (size_t k = 1; k < rows.size(); ++k) {
    simulation::LinearPathRequest r;
    r.start_rad = rows[k - 1].joints_rad;
    if (rows[k].via) {  // a circular move through this row to the next
      r.via_mm = programs::TcpPose(controller, rows[k].joints_rad, Eigen::Isometry3d::Identity())
                     .translation();
      ++k;
    }
    r.to_tcp = programs::TcpPose(controller, rows[k].joints_rad, Eigen::Isometry3d::Identity());
    r.speed_mm_s = *rows[k].linear_speed_mm_s;
    const auto leg = simulation::LinearPath(controller, r);
    EXPECT_TRUE(leg);
    if (!leg) return {};
    for (const auto& q : *leg) {
      const Eigen::VectorXd at = truth.joint_errors.TrueAngles(q);
      cycle.samples.push_back(
          {t, kin.Position(Eigen::Isometry3d::Identity(), truth.true_params, at.data())});
      t += r.dt_s;
    }
  }
  return calibration::iso9283::EvaluatePath(command, {cycle}, iso9283::DefaultIso9283PathOptions());
}

// Issue 40: an ISO 9283 path test measured on the move. `iso9283 plan --path`'s plan (line,
// rectangle and large circle in a 300 mm cube around the home, 3 cycles at 250 mm/s) is swept
// with movel and movec, the
// tracker recording continuously on its own clock; `iso9283 report` finds the session a path
// test and its figures are the true robot's along the controller's linear path (computed here
// from the truth, noise-free), in the lab's (here well measured) base. The same plan
// compensated with the true parameters is the same test with AT at a fraction: the report
// shows both.
TEST_F(UrCaptureFixture, AnIso9283PathIsSweptWithLinearMovesAndReportedAsTheTrueRobotsPath) {
  // Ten times faster than physical time, the tracker recording every 8 ms of its clock (2 mm
  // of path): some 1,250 records a second of wall time, which a loaded machine reads on time.
  StartController(Options(true, 0.1), 2000, truth_.world_from_base);
  tracker_->FollowArm(&ur_->arm());
  calibration::Kinematics kin(model_);
  const Eigen::VectorXd zero = Eigen::VectorXd::Zero(model_.num_parameters());
  iso9283::Iso9283PlanOptions o;
  o.cube = calibration::iso9283::TestCube{
      kin.Position(Eigen::Isometry3d::Identity(), zero, truth_.home_rad.data()), 300.0};
  o.seed_rad = truth_.home_rad;
  o.paths = {"line", "rectangle", "circle-large"};
  o.cycles = 3;
  workflows::ActiveSignature known;  // the true parameters, as a perfect calibration has them
  known.model = model_;
  known.signature.version = 1;
  known.signature.params = truth_.true_params;
  db::Database db(Db());
  int64_t sessions[2] = {0, 0};
  Plan plans[2];
  for (const bool compensated : {false, true}) {
    o.compensated = compensated;
    const auto plan = iso9283::MakeIso9283Plan(model_, "ur10", o, compensated ? &known : nullptr);
    const std::string file = dir_.File(compensated ? "compensated.csv" : "path.csv");
    testing::WriteText(file, plan.csv);
    plans[compensated] = ReadPlanCsv(file, model_);
    ASSERT_TRUE(HasLinearMoves(plans[compensated]));
    const int64_t session = CreateSession(db, Lab(), "ur10", plans[compensated]);
    MarkOnTheMove(db, session);
    CaptureOptions options;
    options.sweep.emplace().path_tracker_separation_ms = 8;
    const CaptureSummary s = workflows::CaptureInto(db, Lab(), session, options);
    ASSERT_TRUE(s.sweep);
    ASSERT_TRUE(s.completed) << s.pause_reason;
    EXPECT_EQ(s.sweep->segments, 9);  // each path's three cycles
    EXPECT_GT(s.sweep->tracker_records, 2000);
    sessions[compensated] = session;
  }
  ASSERT_TRUE(iso9283::IsIso9283PathSession(db, sessions[0]));
  iso9283::Iso9283ReportOptions r;
  r.robot = "ur10";
  r.session = sessions[0];
  r.compensated_session = sessions[1];
  r.out_dir = dir_.File("report");
  const auto report = iso9283::RunIso9283Report(db, r);
  ASSERT_EQ(report.json["paths"].size(), 3u) << report.text;
  ASSERT_TRUE(report.json.contains("compensated")) << report.text;
  EXPECT_EQ(report.json["alignment"]["method"], "lab base");
  // A figure of the report (a failure naming it, with the whole report, when it has none).
  const auto figure = [&](const nlohmann::json& j, const char* key) {
    if (j.contains(key) && j[key].is_number()) return j[key].get<double>();
    ADD_FAILURE() << key << " is not a number in\n" << j.dump(1) << "\n" << report.text;
    return std::nan("");
  };
  for (size_t i = 0; i < 3; ++i) {
    const auto& measured = report.json["paths"][i];
    const std::string name = measured["path"];
    EXPECT_EQ(measured["cycles"], 3) << name;
    // The first cycle's rows of this path, and the command they make (a circle: 360 chords).
    Plan rows;
    calibration::iso9283::PathCommand command;
    command.speed_mm_s = 250.0;
    for (const auto& c : plans[0]) {
      if (c.label.rfind(name + "-01-v", 0) == 0) rows.push_back(c);
    }
    const auto paths = calibration::iso9283::BuildTestPaths(*o.cube);
    command.vertices_mm = name == "line"        ? paths.line_mm
                          : name == "rectangle" ? paths.rectangle_mm
                                                : paths.large_circle_mm;
    ASSERT_GE(rows.size(), 2u) << name;
    const auto truth = TruePathFigures(truth_, model_, rows, command);
    // The tracker's noise (σ ≈ 0.015 mm per coordinate) on three cycles' crossings.
    EXPECT_NEAR(figure(measured, "AT_mm"), truth.at_mm, 0.03) << name << "\n" << report.text;
    EXPECT_NEAR(figure(measured, "mean_AT_mm"), truth.mean_at_mm, 0.01) << name;
    EXPECT_GT(truth.at_mm, 0.2) << name;  // the robot's errors show, far above the noise
    // A circle runs as two circular moves, stopping at its half (no blend radius), and the
    // virtual controller stands there while it plans the second: its mean speed is not the
    // controller's; the line's and the rectangle's stops are outside their steady parts.
    if (name != "circle-large")
      EXPECT_NEAR(figure(measured, "AV_percent"), truth.av_percent, 0.5) << name;
    // The arm repeats exactly: RT is the tracker's noise, l̄ + 3 S of three crossings (σ ≈
    // 0.015 mm a coordinate), the largest over up to a thousand planes.
    EXPECT_LT(figure(measured, "RT_mm"), 0.15) << name;
    if (name == "rectangle") {
      ASSERT_EQ(measured["corners"].size(), 4u);
      // CR is the smallest distance of the records from the corner: the arm stands at each
      // corner for a moment, and the least of hundreds of noisy records lies some 3 σ (0.05
      // mm) nearer than the true path, never farther.
      for (size_t k = 0; k < 4; ++k) {
        const double cr = figure(measured["corners"][k], "CR_mm");
        EXPECT_LT(cr, truth.corners[k].cr_max_mm + 0.01) << k;
        EXPECT_GT(cr, truth.corners[k].cr_max_mm - 0.08) << k;
      }
    }
    const auto& after = report.json["compensated"]["paths"][i];
    EXPECT_LT(figure(after, "AT_mm"), 0.5 * truth.at_mm) << name << "\n" << report.text;
  }
  EXPECT_TRUE(std::filesystem::exists(dir_.File("report/deviation-line.png")));
  EXPECT_TRUE(std::filesystem::exists(dir_.File("report/deviation-rectangle.png")));
  EXPECT_NE(report.text.find("corner 2"), std::string::npos) << report.text;
  // A path test is judged by no pose limit and has the robot's frame, not a fit.
  r.align = true;
  EXPECT_THROW(iso9283::RunIso9283Report(db, r), InputError);
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
  // A path plan (linear moves) captured stop-and-go would measure its vertices standing: it
  // is refused, naming the plan and what to add, before anything is stored.
  Eigen::VectorXd next = truth_.home_rad;
  next(0) += 0.2;
  std::string csv = "pose,q1_rad,q2_rad,q3_rad,q4_rad,q5_rad,q6_rad,speed_mm_s\n";
  for (const auto& [label, q, speed] : {std::tuple{"line-01-v1", truth_.home_rad, ""},
                                        std::tuple{"line-01-v2", next, "250"}}) {
    csv += label;
    for (int j = 0; j < 6; ++j) csv += fmt::format(",{:.12f}", q(j));
    csv += std::string(",") + speed + "\n";
  }
  testing::WriteText(dir_.File("path.csv"), csv);
  workflows::CaptureRequest request = Request();
  request.plan = dir_.File("path.csv");
  try {
    workflows::RunCaptureSession(request);
    ADD_FAILURE() << "a path plan captured stop-and-go";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("path.csv"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("add --on-the-move"), std::string::npos) << e.what();
  }
  db::Database db(Db());
  EXPECT_TRUE(db::SessionIds(db).empty());
}

}  // namespace
}  // namespace armsig::acquisition
