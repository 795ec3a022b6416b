// Capture sessions with a KUKA controller: the virtual KR C4 (its variable server on loopback
// TCP, ARMSIG's contract) moving a KR 16-2 with hidden geometric and joint-angle errors,
// measured by the virtual laser tracker (emScon on loopback TCP). The faults of issue 35 at
// the session's level: what is stored (never a wrong reading), what the session says, and
// that it goes on or resumes. The KR C4 runs 100 times faster than physical time.
#include <fmt/format.h>
#include <gtest/gtest.h>

#include <functional>
#include <thread>

#include "acquisition/controller_record.h"
#include "acquisition/session.h"
#include "db/database.h"
#include "db/store.h"
#include "io/lab_file.h"
#include "simulation/kuka_simulator.h"
#include "support/tracker_cell.h"
#include "test_support.h"
#include "workflows/capture.h"

namespace armsig::acquisition {
namespace {

using namespace std::chrono_literals;

constexpr int kKukaConfigurations = 5;

class KukaCapture : public ::testing::Test {
 protected:
  void SetUp() override { StartController(); }

  void StartController(std::string trafo_name = "", int serial = 0, int timeout_ms = 2000) {
    kuka_.reset();
    simulation::KukaSimulatorOptions o;
    o.time_scale = 0.01;
    o.latency = 100us;
    o.trafo_name = trafo_name.empty() ? "#" + truth_.identity.model + " C4 FLR" : trafo_name;
    o.serial = serial ? serial : std::stoi(truth_.identity.serial);
    o.home_rad = truth_.home_rad;
    kuka_ = std::make_unique<simulation::KukaSimulator>(*cell_.lab, "127.0.0.1", 0, o);
    kuka_->Start();
    testing::WriteText(
        dir_.File("lab.yaml"),
        fmt::format("robot:\n  model: '{}'\n  controller: {{protocol: kuka, host: 127.0.0.1, "
                    "can_move: true, variable_server_port: {}, velocity_percent: 30}}\n"
                    "instruments:\n  - {{station: LT1, protocol: emscon, tcp: '{}', "
                    "measurement_time_ms: 20}}\nstations: stations.yaml\ntolerances: "
                    "{{settle_ms: 0, timeout_ms: {}, fault_retries: 1, fault_retry_delay_ms: "
                    "20}}\n",
                    testing::SourcePath("models/kr16_2.yaml"), kuka_->port(),
                    cell_.tracker->path(), timeout_ms));
  }

  io::LabConfig Lab() const { return io::LoadLab(dir_.File("lab.yaml")); }
  int64_t NewSession(db::Database& db) { return CreateSession(db, Lab(), "kr16", cell_.plan); }
  // The capture command's request for robot `robot` with an automatic plan.
  workflows::CaptureRequest Request(const std::string& robot) const {
    workflows::CaptureRequest request;
    request.db_path = dir_.File("lab.db");
    request.lab = dir_.File("lab.yaml");
    request.plan = "auto:5";
    request.robot = robot;
    return request;
  }
  // The session run with `event` happening once `done` configurations are stored.
  CaptureSummary CaptureWithEvent(db::Database& db, int64_t session, int done,
                                  const std::function<void()>& event) {
    return testing::CaptureWithEvent(db, Lab(), session, done, event);
  }
  // $AXIS_ACT shows 32-bit floats: a joint as stored is the planned one within 1e-5°.
  void ExpectStoredAsPlanned(db::Database& db, int64_t session) {
    testing::ExpectStoredAsPlanned(db, session, kKukaConfigurations, cell_, 2e-7);
  }

  testing::TempDir dir_;
  testing::TrackerCell cell_{"kuka", "models/kr16_2.yaml", dir_, kKukaConfigurations};
  simulation::VirtualRobot& truth_ = cell_.truth;
  std::unique_ptr<simulation::KukaSimulator> kuka_;
};

TEST_F(KukaCapture, CapturesThroughArmsigAndKeepsWhoTheControllerIs) {
  db::Database db(dir_.File("lab.db"));
  const int64_t session = NewSession(db);
  const CaptureSummary s = workflows::CaptureInto(db, Lab(), session, {});
  ASSERT_TRUE(s.completed) << s.pause_reason;
  EXPECT_EQ(s.measured, kKukaConfigurations);
  ExpectStoredAsPlanned(db, session);
  EXPECT_EQ(kuka_->snapshot().moves, kKukaConfigurations);
  const auto record = db::SessionController(db, session);
  ASSERT_TRUE(record);
  EXPECT_EQ(record->model, "KR16_2");
  EXPECT_EQ(record->serial, truth_.identity.serial);
  EXPECT_NE(s.controller.find("KR16_2 serial " + truth_.identity.serial), std::string::npos)
      << s.controller;
}

// KUKA's protective stop: the cell's gate opened in AUT during a move. The session waits, says
// so, and goes on by itself once the operator has closed the gate, acknowledged and started
// ARMSIG again: the halted move ends where it was going.
TEST_F(KukaCapture, ASafetyStopDuringAMoveIsWaitedOutAndTheSessionGoesOn) {
  db::Database db(dir_.File("lab.db"));
  const int64_t session = NewSession(db);
  std::vector<std::string> told, waiting;
  std::thread opener, operator_;
  CaptureOptions options;
  options.progress = [&](const Progress& p) {
    if (!p.waiting.empty()) waiting.push_back(p.waiting);
    if (p.done != 1 || opener.joinable()) return;
    opener = std::thread([this] {
      if (testing::WaitUntil([&] { return kuka_->snapshot().moving; })) kuka_->OpenSafetyGate();
    });
  };
  // The operator closes the gate, acknowledges and starts ARMSIG once the session has named
  // the stop (acting on the gate alone raced the driver's next look at the controller, which
  // under load came after ARMSIG ran again and found nothing to name).
  options.controller_fault = [&](const instruments::ControllerError& e) {
    told.push_back(e.what());
    if (!operator_.joinable()) {
      operator_ = std::thread([this] {
        std::this_thread::sleep_for(30ms);
        kuka_->CloseSafetyGate();
        kuka_->Acknowledge();
        kuka_->StartProgram();
      });
    }
    return false;  // armsig cannot clear it: it waits
  };
  const CaptureSummary s = workflows::CaptureInto(db, Lab(), session, options);
  if (opener.joinable()) opener.join();
  if (operator_.joinable()) operator_.join();
  ASSERT_TRUE(s.completed) << s.pause_reason;
  ASSERT_EQ(told.size(), 1u);
  EXPECT_NE(told[0].find("protective stop: the move stopped: a safety stop"), std::string::npos)
      << told[0];
  ASSERT_FALSE(waiting.empty());
  EXPECT_NE(waiting[0].find("close the gate"), std::string::npos) << waiting[0];
  EXPECT_EQ(s.controller_waits, 1);
  EXPECT_EQ(s.skipped, 0);
  // The halted move went on to its target once ARMSIG was started again; the session's move
  // after the wait found it there (a command of no motion), or still under way (waited for).
  EXPECT_EQ(kuka_->snapshot().halts, 1);
  EXPECT_LE(kuka_->snapshot().moves, kKukaConfigurations + 1);
  ExpectStoredAsPlanned(db, session);
}

TEST_F(KukaCapture, AnEmergencyStopPausesTheSessionNamingWhatToDoAndItResumes) {
  db::Database db(dir_.File("lab.db"));
  const int64_t session = NewSession(db);
  const CaptureSummary first =
      CaptureWithEvent(db, session, 2, [&] { kuka_->PressEmergencyStop(); });
  EXPECT_TRUE(first.paused);
  EXPECT_NE(first.pause_reason.find("emergency stop: EMERGENCY STOP is pressed"), std::string::npos)
      << first.pause_reason;
  EXPECT_NE(first.pause_reason.find("release it, acknowledge"), std::string::npos);
  EXPECT_EQ(db::LoadSessionPoses(db, session).size(), 2u);
  EXPECT_EQ(db::StoredSeqs(db, session).size(), 2u);  // nothing of the third configuration
  kuka_->ReleaseEmergencyStop();
  kuka_->Acknowledge();
  kuka_->StartProgram();
  const CaptureSummary resumed = workflows::CaptureInto(db, Lab(), session, {});
  ASSERT_TRUE(resumed.completed) << resumed.pause_reason;
  EXPECT_EQ(resumed.already, 2);
  ExpectStoredAsPlanned(db, session);
}

TEST_F(KukaCapture, T1IsNamedBeforeASessionIsMadeAndAStoppedProgramPausesOneUnderWay) {
  kuka_->SetMode("T1");
  try {
    workflows::RunCaptureSession(Request("kr16"));
    FAIL() << "captured in T1";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("not in remote control: the controller is in T1"),
              std::string::npos)
        << e.what();
    EXPECT_NE(std::string(e.what()).find("nothing was stored"), std::string::npos);
  }
  db::Database db(dir_.File("lab.db"));
  EXPECT_TRUE(db::SessionIds(db).empty());
  // ARMSIG deselected while a session runs (another program chosen on the smartPAD): paused.
  kuka_->SetMode("AUT");
  kuka_->StartProgram();
  const int64_t session = NewSession(db);
  const CaptureSummary s = CaptureWithEvent(db, session, 1, [&] { kuka_->SelectProgram("CELL"); });
  EXPECT_TRUE(s.paused);
  EXPECT_NE(s.pause_reason.find("not running"), std::string::npos) << s.pause_reason;
  EXPECT_NE(s.pause_reason.find("select ARMSIG"), std::string::npos) << s.pause_reason;
  EXPECT_EQ(db::LoadSessionPoses(db, session).size(), 1u);
  kuka_->SelectProgram("ARMSIG");
  kuka_->StartProgram();
  ASSERT_TRUE(workflows::CaptureInto(db, Lab(), session, {}).completed);
  ExpectStoredAsPlanned(db, session);
}

// The drives switched off during a session (the smartPAD's drives key, or the PLC): the move
// halts, the session pauses naming the drives, keeps what it stored, and resumes.
TEST_F(KukaCapture, DrivesSwitchedOffPauseTheSessionNamingThemAndItResumes) {
  db::Database db(dir_.File("lab.db"));
  const int64_t session = NewSession(db);
  const CaptureSummary s = CaptureWithEvent(db, session, 2, [&] { kuka_->SwitchDrivesOff(); });
  EXPECT_TRUE(s.paused);
  EXPECT_NE(s.pause_reason.find("KUKA controller " + kuka_->path()), std::string::npos)
      << s.pause_reason;
  EXPECT_NE(s.pause_reason.find("the drives are off ($PERI_RDY FALSE)"), std::string::npos)
      << s.pause_reason;
  EXPECT_NE(s.pause_reason.find("switch the drives on"), std::string::npos) << s.pause_reason;
  EXPECT_EQ(db::StoredSeqs(db, session).size(), 2u);
  kuka_->StartProgram();
  const CaptureSummary resumed = workflows::CaptureInto(db, Lab(), session, {});
  ASSERT_TRUE(resumed.completed) << resumed.pause_reason;
  EXPECT_EQ(resumed.already, 2);
  ExpectStoredAsPlanned(db, session);
}

// A variable server that takes the connection and answers nothing more (KukaVarProxy hung):
// the session pauses naming the controller, keeps what it stored, and resumes once it answers.
TEST_F(KukaCapture, AStalledVariableServerPausesTheSessionAndLosesNothing) {
  StartController("", 0, 500);  // each call given up after 0.5 s
  db::Database db(dir_.File("lab.db"));
  const int64_t session = NewSession(db);
  const CaptureSummary s = CaptureWithEvent(
      db, session, 2, [&] { kuka_->InjectAlways({simulation::Fault::kDropReply, 0}); });
  EXPECT_TRUE(s.paused);
  EXPECT_NE(s.pause_reason.find("KUKA controller " + kuka_->path()), std::string::npos)
      << s.pause_reason;
  EXPECT_NE(s.pause_reason.find("connection lost"), std::string::npos) << s.pause_reason;
  EXPECT_EQ(db::StoredSeqs(db, session).size(), 2u);
  kuka_->ClearFaults();
  ASSERT_TRUE(workflows::CaptureInto(db, Lab(), session, {}).completed);
  ExpectStoredAsPlanned(db, session);
}

// Garbage on the line mid-session (noise bytes, a malformed frame, half an answer, an answer
// with another tag): skipped or asked again; every configuration stored is right.
TEST_F(KukaCapture, GarbageOnTheLineIsSkippedAndNothingWrongIsStored) {
  db::Database db(dir_.File("lab.db"));
  const int64_t session = NewSession(db);
  const CaptureSummary s = CaptureWithEvent(db, session, 1, [&] {
    for (auto f : {simulation::Fault::kNoiseBytes, simulation::Fault::kMalformed,
                   simulation::Fault::kTruncateReply, simulation::Fault::kWrongTrid}) {
      kuka_->InjectOnce({f, 0});
    }
  });
  ASSERT_TRUE(s.completed) << s.pause_reason;
  EXPECT_EQ(s.measured, kKukaConfigurations);
  ExpectStoredAsPlanned(db, session);
}

TEST_F(KukaCapture, AConnectionDroppedMidSessionIsReconnectedAndLosesNothing) {
  db::Database db(dir_.File("lab.db"));
  const int64_t session = NewSession(db);
  const int connections_before = kuka_->connections();
  const CaptureSummary s = CaptureWithEvent(db, session, 2, [&] { kuka_->DropConnections(); });
  ASSERT_TRUE(s.completed) << s.pause_reason;
  EXPECT_GT(kuka_->connections(), connections_before + 1);
  ExpectStoredAsPlanned(db, session);
}

TEST_F(KukaCapture, AConnectionThatDoesNotComeBackPausesTheSessionResumably) {
  db::Database db(dir_.File("lab.db"));
  const int64_t session = NewSession(db);
  const CaptureSummary s = CaptureWithEvent(db, session, 1, [&] { kuka_->SetReachable(false); });
  EXPECT_TRUE(s.paused);
  EXPECT_NE(s.pause_reason.find("connection lost: the variable server did not answer"),
            std::string::npos)
      << s.pause_reason;
  EXPECT_EQ(db::LoadSessionPoses(db, session).size(), 1u);
  kuka_->SetReachable(true);
  ASSERT_TRUE(workflows::CaptureInto(db, Lab(), session, {}).completed);
  ExpectStoredAsPlanned(db, session);
}

TEST_F(KukaCapture, AReadingTakenWhileTheArmMovesIsNeverStored) {
  db::Database db(dir_.File("lab.db"));
  const int64_t session = NewSession(db);
  // Once the first move has ended, something turns A6 for 10 s (0.1 s of wall time) while the
  // tracker measures: that reading is refused ($ROB_STOPPED, or the joints read again after the
  // tracker), the configuration measured again once ARMSIG has taken the arm back. (A6 turns
  // the reflector about itself: the tracker's own self-check, two readings of one point, is
  // not what refuses it.)
  kuka_->arm().DriftAfterNextMove(5, 0.05, 0.2, 10.0);
  const CaptureSummary s = workflows::CaptureInto(db, Lab(), session, {});
  ASSERT_TRUE(s.completed) << s.pause_reason;
  EXPECT_GE(s.moving_refused, 1);
  ExpectStoredAsPlanned(db, session);
}

TEST_F(KukaCapture, AnotherArmIsRefusedBeforeASessionIsMade) {
  auto request = Request("kr16");
  ASSERT_TRUE(workflows::RunCaptureSession(request).ok);
  StartController("", 509999);  // another KR 16-2 behind the same lab file
  try {
    workflows::RunCaptureSession(request);
    FAIL() << "another arm was captured as robot kr16";
  } catch (const InputError& e) {
    EXPECT_NE(e.message().find("another arm"), std::string::npos) << e.what();
    EXPECT_NE(e.message().find("509999"), std::string::npos) << e.what();
  }
  StartController("#KR6_R900_2 C4SR FLR");  // another model than the lab's kr16_2
  request.robot = "new-robot";
  try {
    workflows::RunCaptureSession(request);
    FAIL() << "a KR 6 was captured with a KR 16 model";
  } catch (const InputError& e) {
    EXPECT_NE(e.message().find("answers model KR6_R900_2, the lab's robot model is kr16_2"),
              std::string::npos)
        << e.what();
  }
  db::Database db(dir_.File("lab.db"));
  EXPECT_EQ(db::SessionIds(db).size(), 1u);
}

}  // namespace
}  // namespace armsig::acquisition
