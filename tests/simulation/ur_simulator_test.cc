// The UR driver (robots/ur_device.h) against the virtual UR controller over loopback
// TCP, Boost.Asio on both ends: who it is and its kinematics, RTDE at 125 Hz (CB3) and
// 500 Hz (e-Series), moves that take the arm's physical time, and every fault a lab meets —
// each named by its kind, with what the operator must do. The simulator runs 100 times
// faster than physical time (a 5 s wait is 50 ms).
#include "simulation/ur_simulator.h"

#include <gtest/gtest.h>

#include <fmt/format.h>

#include <cmath>
#include <functional>
#include <thread>

#include "core/units.h"
#include "instruments/frame_splitter.h"
#include "instruments/packet_transport.h"
#include "robots/ur_device.h"
#include "programs/controller.h"
#include "simulation/virtual_lab.h"
#include "test_support.h"

namespace armsig::simulation {
namespace {

using instruments::ControllerError;
using Kind = instruments::ControllerError::Kind;
using namespace std::chrono_literals;

constexpr double kScale = 0.01;

class UrFixture : public ::testing::Test {
 protected:
  void Start(UrSimulatorOptions o = {}) {
    lab_ = std::make_unique<VirtualLab>(testing::Puma(),
                                        Eigen::VectorXd::Zero(testing::Puma().num_parameters()),
                                        Eigen::Isometry3d::Identity());
    o.time_scale = kScale;
    if (o.kinematics.dh_a_mm.empty()) {
      o.kinematics.dh_theta_rad = {1e-4, 0, 0, 0, 0, 0};
      o.kinematics.dh_a_mm = {0, -612.1, -572.2, 0, 0, 0};
      o.kinematics.dh_d_mm = {127.3, 0, 0, 163.94, 115.7, 92.2};
      o.kinematics.dh_alpha_rad = {kPi / 2, 0, 0, kPi / 2, -kPi / 2, 0};
      o.kinematics.calibration_status = 2;
    }
    options_ = o;
    sim_ = std::make_unique<UrSimulator>(*lab_, o);
    sim_->Start();
  }
  std::unique_ptr<robots::UrController> Driver(int timeout_ms = 2000) {
    robots::UrOptions o;
    o.host = "127.0.0.1";
    o.rtde_port = sim_->ports().rtde;
    o.primary_port = sim_->ports().primary;
    o.secondary_port = sim_->ports().secondary;
    o.dashboard_port = sim_->ports().dashboard;
    o.can_move = true;
    instruments::RetryPolicy p;
    p.timeout = std::chrono::milliseconds(timeout_ms);
    p.reconnect_delay = 20ms;
    return std::make_unique<robots::UrController>(o, p);
  }
  // What the controller's error says, by kind (another exception fails the test).
  template <typename F>
  std::optional<ControllerError> ErrorOf(F&& call) {
    try {
      call();
    } catch (const ControllerError& e) {
      return e;
    }
    return std::nullopt;
  }

  UrSimulatorOptions options_;
  std::unique_ptr<VirtualLab> lab_;
  std::unique_ptr<UrSimulator> sim_;
};

TEST_F(UrFixture, AnESeriesSaysWhoItIsAndGivesItsOwnKinematics) {
  UrSimulatorOptions o;
  o.model = "UR10";
  o.serial = "20183012345";
  Start(o);
  auto ur = Driver();
  const auto who = ur->Identify();
  ASSERT_TRUE(who);
  EXPECT_EQ(who->model, "UR10");
  EXPECT_EQ(who->serial, "20183012345");
  EXPECT_EQ(who->software, "URSoftware 5.11.1.108318 (Nov 03 2021)");
  EXPECT_EQ(who->vendor, "Universal Robots");
  const auto k = ur->Kinematics();
  ASSERT_TRUE(k);
  EXPECT_EQ(k->checksum, sim_->kinematics_info().ToKinematics().checksum);
  EXPECT_EQ(who->kinematics_checksum, k->checksum);
  EXPECT_NEAR(k->dh_a_mm[1], -612.1, 1e-9);
  EXPECT_NEAR(k->dh_theta_rad[0], 1e-4, 1e-15);
  EXPECT_EQ(k->calibration_status, 2);
}

TEST_F(UrFixture, AnOldCb3CannotNameItsModelOrSerial) {
  UrSimulatorOptions o = Cb3Options();
  o.software = {3, 11, 0, 82155};  // get robot model / get serial number came with 3.12
  Start(o);
  const auto who = Driver()->Identify();
  ASSERT_TRUE(who);
  EXPECT_EQ(who->model, "");
  EXPECT_EQ(who->serial, "");
  EXPECT_NE(who->kinematics_checksum, "");
}

TEST_F(UrFixture, RtdeRunsAt125HzOnACb3And500HzOnAnESeries) {
  for (const bool e_series : {false, true}) {
    Start(e_series ? UrSimulatorOptions{} : Cb3Options());
    auto ur = Driver();
    const auto joints = ur->ReadStampedJoints();
    const double hz = e_series ? 500.0 : 125.0;
    EXPECT_EQ(ur->frequency_hz(), hz);
    EXPECT_EQ(sim_->frequency_hz(), hz);
    ASSERT_TRUE(joints.controller_time_s);
    // The controller's clock in whole periods of the recipe.
    const double periods = *joints.controller_time_s * hz;
    EXPECT_NEAR(periods, std::round(periods), 1e-6) << "at " << hz << " Hz";
    EXPECT_EQ(ur->version()->ESeries(), e_series);
    sim_.reset();
  }
}

// A client of our own, speaking the guide's packages through the codec only: successive data
// packages are exactly one period of the recipe apart on the controller's clock.
TEST_F(UrFixture, DataPackagesComeEveryPeriodOfTheRecipe) {
  for (const bool e_series : {false, true}) {
    UrSimulatorOptions o = e_series ? UrSimulatorOptions{} : Cb3Options();
    lab_ = std::make_unique<VirtualLab>(testing::Puma(),
                                        Eigen::VectorXd::Zero(testing::Puma().num_parameters()),
                                        Eigen::Isometry3d::Identity());
    o.time_scale = 0.25;  // 500 Hz: a package every 0.5 ms of wall time, none left out
    sim_ = std::make_unique<UrSimulator>(*lab_, o);
    sim_->Start();
    const double hz = e_series ? 500.0 : 125.0;
    auto t = instruments::MakeFramedTcpTransport("127.0.0.1", sim_->ports().rtde,
                                                 robots::ur::rtde::kFrames);
    t->Open();
    const auto deadline = instruments::Clock::now() + 2s;
    namespace rtde = robots::ur::rtde;
    std::string why;
    t->Write(rtde::RequestProtocolVersion(2), deadline);
    EXPECT_EQ(rtde::DecodeAccepted(rtde::Decode(t->ReadPacket(deadline), &why)->payload), true);
    t->Write(rtde::SetupOutputs(hz, {"timestamp", "actual_q"}), deadline);
    const auto setup = rtde::DecodeSetupOutputsAnswer(rtde::Decode(t->ReadPacket(deadline), &why)->payload);
    ASSERT_TRUE(setup);
    EXPECT_EQ(setup->types, (std::vector<std::string>{"DOUBLE", "VECTOR6D"}));
    // Faster than the controller can: refused.
    t->Write(rtde::SetupOutputs(2 * hz, {"timestamp"}), deadline);
    const auto text = rtde::DecodeText(rtde::Decode(t->ReadPacket(deadline), &why)->payload);
    ASSERT_TRUE(text);
    EXPECT_NE(text->message.find(fmt::format("at most {} Hz", hz)), std::string::npos);
    EXPECT_EQ(rtde::DecodeSetupOutputsAnswer(rtde::Decode(t->ReadPacket(deadline), &why)->payload)->recipe, 0);
    t->Write(rtde::SetupOutputs(hz, {"timestamp", "actual_q"}), deadline);
    t->ReadPacket(deadline);
    t->Write(rtde::Start(), deadline);
    EXPECT_EQ(rtde::DecodeAccepted(rtde::Decode(t->ReadPacket(deadline), &why)->payload), true);
    const std::vector<rtde::ValueType> types = {rtde::ValueType::kDouble, rtde::ValueType::kVector6d};
    std::vector<double> stamps;
    while (stamps.size() < 40) {
      const auto package = rtde::Decode(t->ReadPacket(deadline), &why);
      ASSERT_TRUE(package) << why;
      if (package->type != 'U') continue;
      stamps.push_back(rtde::DecodeData(package->payload, types, &why)->values[0][0]);
    }
    // One period apart; a period the simulator sampled too late for (a loaded machine) is
    // left out and counted, never sent under a stale stamp.
    int left_out = 0;
    for (size_t k = 1; k < stamps.size(); ++k) {
      const double periods = (stamps[k] - stamps[k - 1]) * hz;
      EXPECT_NEAR(periods, std::round(periods), 1e-6) << hz << " Hz, package " << k;
      EXPECT_GE(std::round(periods), 1.0) << hz << " Hz, package " << k;
      left_out += static_cast<int>(std::round(periods)) - 1;
    }
    EXPECT_LE(left_out, sim_->rtde_skipped());
    sim_.reset();
  }
}

TEST_F(UrFixture, AMoveTakesTheArmsTimeAndEndsAtItsTarget) {
  Start();
  auto ur = Driver();
  Eigen::VectorXd target(6);
  target << 0.6, -0.4, 0.3, 0.2, -0.1, 0.5;
  const double before = sim_->arm().Now().t;
  ur->MoveTo(target);
  const double after = sim_->arm().Now().t;
  const double duration = robots::ur::MoveJDuration(0.6, 1.4, 1.05);
  // No faster than physics allows (wall-time delays only add to it).
  EXPECT_GE(after - before, duration);
  EXPECT_GE(ur->statistics().last_move_s, duration);
  const auto read = ur->ReadStampedJoints();
  EXPECT_LT((read.joints_rad - target).cwiseAbs().maxCoeff(), 1e-12);
  EXPECT_EQ(sim_->moves(), 1);
}

TEST_F(UrFixture, ARefusedRtdeVersionIsNamed) {
  Start();
  sim_->RefuseRtdeVersion2(true);
  const auto e = ErrorOf([&] { Driver()->ReadStampedJoints(); });
  ASSERT_TRUE(e);
  EXPECT_EQ(e->kind(), Kind::kVersionRefused);
  EXPECT_NE(std::string(e->what()).find("refused RTDE protocol version 2"), std::string::npos)
      << e->what();
  EXPECT_NE(e->action().find("update the controller's software"), std::string::npos);
  EXPECT_EQ(e->device(), "UR 127.0.0.1");
}

TEST_F(UrFixture, AnOutputTheControllerHasNotIsNamed) {
  Start();
  sim_->HideRtdeOutput("safety_mode");
  const auto e = ErrorOf([&] { Driver()->ReadStampedJoints(); });
  ASSERT_TRUE(e);
  EXPECT_EQ(e->kind(), Kind::kVersionRefused);
  EXPECT_NE(std::string(e->what()).find("NOT_FOUND for RTDE output 'safety_mode'"),
            std::string::npos)
      << e->what();
}

TEST_F(UrFixture, AProtectiveStopStopsTheMoveAndUnlocksFiveSecondsLater) {
  Start();
  auto ur = Driver();
  Eigen::VectorXd target = Eigen::VectorXd::Zero(6);
  target(0) = 1.5;
  sim_->ProtectiveStopDuringNextMove(0.4);
  const auto stopped = ErrorOf([&] { ur->MoveTo(target); });
  ASSERT_TRUE(stopped);
  EXPECT_EQ(stopped->kind(), Kind::kProtectiveStop);
  EXPECT_TRUE(stopped->WaitedOut());
  EXPECT_LT(sim_->arm().Now().q(0), 1.5);  // short of the target
  EXPECT_EQ(ErrorOf([&] { ur->CheckReady(); })->kind(), Kind::kProtectiveStop);
  // Unlocked from armsig too early: refused as the controller refuses it.
  const double since = sim_->arm().SecondsSinceStop();
  if (since < 4.0) {
    const auto early = ErrorOf([&] { ur->ClearProtectiveStop(); });
    ASSERT_TRUE(early);
    EXPECT_NE(std::string(early->what()).find("until 5s after"), std::string::npos) << early->what();
  }
  std::this_thread::sleep_for(std::chrono::milliseconds(60));  // 6 s
  ur->ClearProtectiveStop();
  ur->CheckReady();
  ur->MoveTo(target);
  EXPECT_LT((ur->ReadJointsRad() - target).cwiseAbs().maxCoeff(), 1e-12);
}

TEST_F(UrFixture, AnEmergencyStopNeedsTheButtonReleasedAndTheArmPoweredOn) {
  Start();
  auto ur = Driver();
  sim_->PressEmergencyStop();
  auto e = ErrorOf([&] { ur->CheckReady(); });
  ASSERT_TRUE(e);
  EXPECT_EQ(e->kind(), Kind::kEmergencyStop);
  EXPECT_FALSE(e->WaitedOut());
  EXPECT_NE(e->action().find("release the emergency stop"), std::string::npos);
  EXPECT_EQ(ErrorOf([&] { ur->ReadStampedJoints(); })->kind(), Kind::kEmergencyStop);
  sim_->ReleaseEmergencyStop();
  e = ErrorOf([&] { ur->CheckReady(); });
  ASSERT_TRUE(e);
  EXPECT_EQ(e->kind(), Kind::kNotRunning);
  EXPECT_NE(std::string(e->what()).find("POWER_OFF"), std::string::npos) << e->what();
  sim_->PowerOnFromPendant();
  ur->CheckReady();
}

TEST_F(UrFixture, LocalControlIsRefusedBeforeAMoveIsSent) {
  Start();
  auto ur = Driver();
  sim_->SetRemoteControl(false);
  const auto e = ErrorOf([&] { ur->MoveTo(Eigen::VectorXd::Constant(6, 0.1)); });
  ASSERT_TRUE(e);
  EXPECT_EQ(e->kind(), Kind::kNotRemote);
  EXPECT_NE(e->action().find("Remote Control"), std::string::npos);
  EXPECT_EQ(sim_->scripts(), 0);  // nothing was sent
  EXPECT_EQ(sim_->moves(), 0);
  // A CB3 has no local mode: it takes the move.
  sim_.reset();
  UrSimulatorOptions cb3 = Cb3Options();
  cb3.remote_control = false;
  Start(cb3);
  auto cb3_driver = Driver();
  cb3_driver->MoveTo(Eigen::VectorXd::Constant(6, 0.1));
  EXPECT_EQ(sim_->moves(), 1);
}

TEST_F(UrFixture, JointsAreNeverReadWhileTheArmMoves) {
  Start();
  auto ur = Driver(300);
  sim_->KeepMoving(5, 0.05);
  const auto e = ErrorOf([&] { ur->ReadStampedJoints(); });
  ASSERT_TRUE(e);
  EXPECT_EQ(e->kind(), Kind::kArmMoving);
  EXPECT_NE(std::string(e->what()).find("joint 6"), std::string::npos) << e->what();
  sim_->StopMoving();
  const auto read = ur->ReadStampedJoints();
  EXPECT_GT(read.joints_rad(5), 0.0);  // where the other program left it
}

TEST_F(UrFixture, ADroppedConnectionIsOpenedAgainWithinTheCall) {
  Start();
  auto ur = Driver(2000);
  ur->ReadStampedJoints();
  const int before = sim_->connections();
  sim_->DropConnections(100ms);
  const auto read = ur->ReadStampedJoints();
  EXPECT_GT(sim_->connections(), before);
  EXPECT_GE(ur->statistics().reconnects, 1);
  EXPECT_TRUE(read.controller_time_s);
  // Down for longer than the call's deadline: the connection is lost, named.
  sim_->DropConnections(3000ms);
  auto short_driver = Driver(400);
  const auto e = ErrorOf([&] { short_driver->ReadStampedJoints(); });
  ASSERT_TRUE(e);
  EXPECT_EQ(e->kind(), Kind::kConnectionLost);
  EXPECT_NE(std::string(e->what()).find("RTDE at 127.0.0.1:"), std::string::npos) << e->what();
}

TEST_F(UrFixture, ARecalibratedControllerGivesAnotherChecksum) {
  Start();
  auto ur = Driver();
  const std::string before = ur->Kinematics()->checksum;
  auto changed = options_.kinematics;
  changed.dh_theta_rad[1] += 2e-4;  // UR's calibration run again: joint 2's zero moved
  sim_->SetKinematics(changed);
  const auto after = ur->Kinematics();
  EXPECT_NE(after->checksum, before);
  // Only joint 2's checksum word changed.
  EXPECT_EQ(after->checksum.substr(0, 8), before.substr(0, 8));
  EXPECT_NE(after->checksum.substr(9, 8), before.substr(9, 8));
  EXPECT_EQ(after->checksum.substr(18), before.substr(18));
}

// The lines of a program sent as text to the controller's primary or secondary interface,
// as a lab's PC sends them; then every message the controller sends back until `until`
// holds of one (or the connection closes).
std::vector<robots::ur::primary::Message> SendProgram(
    unsigned short port, const std::string& program,
    const std::function<bool(const robots::ur::primary::Message&)>& until) {
  namespace asio = boost::asio;
  asio::io_context io;
  asio::ip::tcp::socket socket(io);
  socket.connect({asio::ip::make_address("127.0.0.1"), port});
  asio::write(socket, asio::buffer(program));
  std::vector<robots::ur::primary::Message> got;
  instruments::FrameSplitter splitter(robots::ur::primary::kFrames);
  char chunk[4096];
  boost::system::error_code ec;
  while (!ec) {
    const std::size_t n = socket.read_some(asio::buffer(chunk), ec);
    splitter.Append(std::string_view(chunk, n));
    std::string frame;
    int32_t size = 0;
    while (splitter.Next(frame, &size) == instruments::FrameSplitter::Status::kFrame) {
      std::string why;
      if (auto m = robots::ur::primary::Decode(frame, &why)) {
        got.push_back(*m);
        if (until(*m)) return got;
      }
    }
  }
  return got;
}

// A whole program sent as text runs on the controller: its motions in the order written,
// a joint target as its joints, a pose target through the controller's inverse kinematics on
// its own KinematicsInfo (nearest the joints it stands at), standing still through each
// sleep — where the driver, reading only while the arm stands, finds it.
TEST_F(UrFixture, AWholeProgramSentAsTextRunsItsMotionsInOrder) {
  Start();
  auto ur = Driver();
  const Eigen::VectorXd home = ur->ReadJointsRad();
  Eigen::VectorXd a(6), mid(6), b(6);
  a << 0.3, -1.2, 1.1, -1.4, -1.5, 0.2;
  mid << 0.0, -1.57, 1.57, -1.57, -1.57, 0.0;
  b << -0.2, -1.4, 1.5, -1.7, -1.6, -0.3;
  // The pose target: where the controller's own model puts the flange at b.
  const programs::ControllerModel c = UrControllerModel(options_.kinematics);
  const Eigen::Isometry3d pose = programs::FlangePose(c, b);
  const Eigen::AngleAxisd turn(pose.linear());
  const Eigen::Vector3d r = turn.angle() * turn.axis(), x = pose.translation() / 1000.0;
  const std::string program = fmt::format(
      "def checked():\n  # two joint targets and a pose\n  movej([{:.9f}, {:.9f}, {:.9f}, {:.9f}, {:.9f}, {:.9f}], a=1.4, "
      "v=1.05)\n  sleep(10.0)\n  while (False):\n    textmsg(\"a loop\")\n  end\n  movej([0, -1.57, 1.57, -1.57, "
      "-1.57, 0])\n  sleep(10.0)\n  movel(p[{:.9f}, {:.9f}, {:.9f}, {:.9f}, {:.9f}, {:.9f}], a=1.2, v=0.25)\n  "
      "sleep(10.0)\nend\n",
      a(0), a(1), a(2), a(3), a(4), a(5), x.x(), x.y(), x.z(), r.x(), r.y(), r.z());
  SendProgram(sim_->ports().secondary, program, [](const auto&) { return true; });
  // The stands in order. A reading "while the arm stands" may come from a move's first or last
  // instants, below the driver's still speed (2e-4 rad/s: within (2e-4)²/2a ≈ 1.4e-8 rad of the
  // stand), so readings within 1e-6 rad are one stand, and the last stand is read until two
  // readings agree exactly (the program has ended; the arm stands).
  std::vector<Eigen::VectorXd> stood{home};
  for (int reads = 0; reads < 5000; ++reads) {
    const Eigen::VectorXd q = ur->ReadStampedJoints().joints_rad;
    const double step = (q - stood.back()).cwiseAbs().maxCoeff();
    if (step >= 1e-6) {
      stood.push_back(q);
      continue;
    }
    stood.back() = q;
    if (stood.size() == 4 && step == 0.0) break;
  }
  stood.erase(stood.begin());
  ASSERT_EQ(stood.size(), 3u);
  EXPECT_LT((stood[0] - a).cwiseAbs().maxCoeff(), 1e-7);
  EXPECT_LT((stood[1] - mid).cwiseAbs().maxCoeff(), 1e-7);
  // The pose target's joints: the controller's model puts the flange on the pose there, on
  // the branch of b (the solution nearest where the arm stood).
  const Eigen::Isometry3d at = programs::FlangePose(c, stood[2]);
  EXPECT_LT((at.translation() - pose.translation()).norm(), 1e-6);
  EXPECT_LT(Eigen::AngleAxisd(at.linear() * pose.linear().transpose()).angle(), 1e-9);
  EXPECT_LT((stood[2] - b).cwiseAbs().maxCoeff(), 1e-6);
  EXPECT_EQ(sim_->programs_started(), 1);
  EXPECT_EQ(sim_->scripts(), 1);  // one program, however many lines
}

// A program the controller cannot compile, or a secondary program that would move the arm,
// is answered on the interface it came by with a runtime exception message naming the place,
// and not run.
TEST_F(UrFixture, AProgramItCannotReadIsAnsweredAndNotRun) {
  Start();
  const auto got = SendProgram(sim_->ports().primary, "def bad():\n  textmsg(\"never ends)\n  movej([0,0,0,0,0,0])\nend\n",
                               [](const robots::ur::primary::Message& m) {
                                 return m.message_type == robots::ur::primary::kRuntimeExceptionMessage;
                               });
  ASSERT_FALSE(got.empty());
  ASSERT_TRUE(got.back().text);
  EXPECT_NE(got.back().text->find("compile error"), std::string::npos) << *got.back().text;
  EXPECT_NE(got.back().text->find(":2:"), std::string::npos) << *got.back().text;  // line 2
  // A secondary program that would move the arm: refused as the controller refuses it.
  const auto moving = SendProgram(sim_->ports().secondary,
                                  "sec s():\n  movej([0, -1.57, 1.57, -1.57, -1.57, 0])\nend\n",
                                  [](const robots::ur::primary::Message& m) {
                                    return m.message_type == robots::ur::primary::kRuntimeExceptionMessage;
                                  });
  ASSERT_FALSE(moving.empty());
  ASSERT_TRUE(moving.back().text);
  EXPECT_NE(moving.back().text->find("line 2: a secondary program cannot move"), std::string::npos)
      << *moving.back().text;
  // A program whose end never comes: dropped, and said so, past 1 MiB.
  std::string endless = "def endless():\n";
  while (endless.size() <= (1u << 20)) endless += "  textmsg(\"waiting\")\n";
  const auto dropped = SendProgram(sim_->ports().primary, endless, [](const robots::ur::primary::Message& m) {
    return m.message_type == robots::ur::primary::kRuntimeExceptionMessage;
  });
  ASSERT_FALSE(dropped.empty());
  ASSERT_TRUE(dropped.back().text);
  EXPECT_NE(dropped.back().text->find("does not end within 1 MiB"), std::string::npos) << *dropped.back().text;
  EXPECT_EQ(sim_->programs_started(), 0);
  EXPECT_EQ(sim_->moves(), 0);
}

}  // namespace
}  // namespace armsig::simulation
