// Drivers against simulators over real pseudo-terminals (Boost.Asio on both ends).
#include <gtest/gtest.h>

#include <future>
#include <numbers>
#include <thread>

#include "calibration/synthetic.h"
#include "instruments/geocom_device.h"
#include "instruments/gsi_device.h"
#include "robots/robot_controllers.h"
#include "reduction/intersection.h"
#include "reduction/observation.h"
#include "simulation/counter_simulator.h"
#include "simulation/geocom_simulator.h"
#include "simulation/gsi_online_simulator.h"
#include "simulation/simulator.h"
#include "simulation/val_simulator.h"
#include "test_support.h"

namespace armsig::simulation {

using instruments::InstrumentError;
using instruments::RetryPolicy;
using namespace std::chrono_literals;

namespace {

class PtyLab : public ::testing::Test {
 protected:
  PtyLab() : lab_(testing::Puma(), Eigen::VectorXd::Zero(43), Eigen::Isometry3d::Identity()) {
    VirtualStation s;
    s.pose.id = "T1";
    s.pose.position_mm = {3000.0, -500.0, 1200.0};
    s.pose.azimuth_rad = 4.0;
    s.pose.world_from_station = reduction::LevelledRotation(4.0);
    lab_.AddStation(s);  // noise-free: readings are checked exactly
    Eigen::VectorXd q(6);
    q << 0.3, -0.4, 0.9, 0.2, -0.5, 0.1;
    lab_.SetJoints(q);
    options_.angle_latency = 10ms;
    options_.distance_latency = 20ms;
    options_.motion_latency = 20ms;
    policy_.timeout = 400ms;
    policy_.attempts = 3;
    policy_.busy_delay = 10ms;
    policy_.reconnect_delay = 20ms;
  }

  AngleReading Truth() {
    return reduction::PredictReading(lab_.station(0).pose.position_mm,
                                     lab_.station(0).pose.world_from_station,
                                     lab_.TruePosition("robot"));
  }

  std::unique_ptr<instruments::LineTransport> Port(const std::string& path) {
    instruments::SerialSettings settings;
    settings.path = path;
    settings.baud = 115200;
    return instruments::MakeSerialTransport(settings);
  }

  testing::TempDir dir_;
  VirtualLab lab_;
  SimulatorOptions options_;
  RetryPolicy policy_;
};

}  // namespace

TEST_F(PtyLab, GeoComEveryCall) {
  GeoComSimulator sim(lab_, 0, dir_.File("tps"), options_);
  sim.Start();
  instruments::GeoComDevice device(Port(sim.path()), policy_);
  const auto info = device.Identify();
  EXPECT_EQ(info.name, "TDRA6000");
  EXPECT_EQ(info.serial, "358123");
  EXPECT_EQ(info.firmware, "3.20.7");
  EXPECT_TRUE(device.CompensatorOn());
  EXPECT_EQ(device.Face(), 1);
  const auto truth = Truth();
  const auto a = device.MeasureAngles();
  EXPECT_NEAR(a.angles.hz_rad, truth.hz_rad, 1e-12);
  EXPECT_NEAR(a.angles.v_rad, truth.v_rad, 1e-12);
  EXPECT_EQ(a.angles.face, 1);
  EXPECT_EQ(a.return_code, 0);
  const auto simple = device.MeasureAnglesSimple();
  EXPECT_NEAR(simple.angles.hz_rad, truth.hz_rad, 1e-12);
  const auto d = device.MeasureDistanceAndAngles();
  ASSERT_TRUE(d.distance_mm);
  EXPECT_NEAR(*d.distance_mm,
              (lab_.TruePosition("robot") - lab_.station(0).pose.position_mm).norm(), 1e-3);
  device.ChangeFace();
  EXPECT_EQ(device.Face(), 2);
  const auto face2 = device.MeasureAngles();
  EXPECT_EQ(face2.angles.face, 2);
  EXPECT_NEAR(reduction::DirectionInStation(face2.angles).dot(reduction::DirectionInStation(truth)),
              1.0, 1e-12);
  device.FineAdjust(0.01, 0.01);
  device.PositionTo(1.0, 1.5, true);
  EXPECT_EQ(device.statistics().retries, 0);
}

TEST_F(PtyLab, GeoComWithCrc) {
  GeoComSimulator sim(lab_, 0, dir_.File("tps"), options_);
  sim.Start();
  instruments::GeoComDevice device(Port(sim.path()), policy_, /*use_crc=*/true);
  EXPECT_EQ(device.Identify().name, "TDRA6000");
  EXPECT_NEAR(device.MeasureAngles().angles.hz_rad, Truth().hz_rad, 1e-12);
}

// Every injected fault gives a retried success or a typed error, never a made-up reading.
TEST_F(PtyLab, GeoComFaultsAreRetriedOrTyped) {
  GeoComSimulator sim(lab_, 0, dir_.File("tps"), options_);
  sim.Start();
  instruments::GeoComDevice device(Port(sim.path()), policy_, true);
  const auto truth = Truth();
  for (Fault f : {Fault::kNoiseBytes, Fault::kDropReply, Fault::kTruncateReply, Fault::kWrongTrid,
                  Fault::kBadCrc, Fault::kBusy}) {
    sim.InjectOnce({f, 0});
    const auto r = device.MeasureAngles();
    EXPECT_NEAR(r.angles.hz_rad, truth.hz_rad, 1e-12) << static_cast<int>(f);
    EXPECT_EQ(r.return_code, 0);
  }
  const auto& stats = device.statistics();
  EXPECT_GE(stats.retries, 4);  // drop, truncate, wrong trid, bad crc, busy
  EXPECT_GE(stats.noise_lines, 1);
  EXPECT_GE(stats.crc_errors, 1);
  EXPECT_GE(stats.busy, 1);
  // An error code: a typed error carrying the code.
  sim.InjectOnce({Fault::kErrorCode, 8710});
  try {
    device.MeasureAngles();
    FAIL() << "expected InstrumentError";
  } catch (const InstrumentError& e) {
    EXPECT_EQ(e.code(), 8710);
    EXPECT_NE(std::string(e.what()).find("AUT_NO_TARGET"), std::string::npos);
  }
  // A warning with valid data is a reading with the warning, not an error.
  sim.InjectOnce({Fault::kWarningCode, 1284});
  const auto w = device.MeasureAngles();
  EXPECT_EQ(w.return_code, 1284);
  EXPECT_NEAR(w.angles.hz_rad, truth.hz_rad, 1e-12);
  EXPECT_NE(w.note.find("TMC_ACCURACY_GUARANTEE"), std::string::npos);
}

TEST_F(PtyLab, GeoComAnglesOnlyReplyGivesNoDistance) {
  GeoComSimulator sim(lab_, 0, dir_.File("tps"), options_);
  sim.Start();
  instruments::GeoComDevice device(Port(sim.path()), policy_);
  sim.InjectOnce({Fault::kNone, 0});            // TMC_DoMeasure
  sim.InjectOnce({Fault::kWarningCode, 1285});  // TMC_GetSimpleMea: angles only
  const auto r = device.MeasureDistanceAndAngles();
  EXPECT_EQ(r.return_code, 1285);
  EXPECT_FALSE(r.distance_mm.has_value());  // never invented
}

TEST_F(PtyLab, GeoComSilentInstrumentTimesOutWithATypedError) {
  GeoComSimulator sim(lab_, 0, dir_.File("tps"), options_);
  sim.Start();
  policy_.timeout = 100ms;
  instruments::GeoComDevice device(Port(sim.path()), policy_);
  for (int k = 0; k < 3; ++k) sim.InjectOnce({Fault::kDropReply, 0});
  try {
    device.MeasureAngles();
    FAIL();
  } catch (const InstrumentError& e) {
    EXPECT_EQ(e.code(), 3077);
  }
  // The line recovers: the next request is answered, late replies are not mistaken.
  EXPECT_NEAR(device.MeasureAngles().angles.hz_rad, Truth().hz_rad, 1e-12);
}

// A reading taken while the port disappears fails cleanly; after it returns, the next
// one succeeds.
TEST_F(PtyLab, PortThatDisappearsAndReturns) {
  options_.angle_latency = 200ms;
  GeoComSimulator sim(lab_, 0, dir_.File("tps"), options_);
  sim.Start();
  policy_.attempts = 2;
  instruments::GeoComDevice device(Port(sim.path()), policy_);
  EXPECT_EQ(device.Face(), 1);
  auto pending = std::async(std::launch::async, [&] { return device.MeasureAngles(); });
  std::this_thread::sleep_for(50ms);
  sim.Disappear();
  EXPECT_THROW(pending.get(), InstrumentError);
  sim.Reappear();
  const auto r = device.MeasureAngles();
  EXPECT_NEAR(r.angles.hz_rad, Truth().hz_rad, 1e-12);
  EXPECT_GE(device.statistics().reconnects, 1);
}

TEST_F(PtyLab, GsiOnlineCalls) {
  GsiOnlineSimulator sim(lab_, 0, dir_.File("gsi"), options_);
  sim.Start();
  instruments::GsiOnlineDevice device(Port(sim.path()), policy_);
  const auto info = device.Identify();
  EXPECT_EQ(info.name, "T2002");
  EXPECT_EQ(info.serial, "4711");
  const auto truth = Truth();
  const auto a = device.MeasureAngles();
  EXPECT_NEAR(a.angles.hz_rad, truth.hz_rad, 2e-7);  // GSI-8: 0.00001 gon
  EXPECT_NEAR(a.angles.v_rad, truth.v_rad, 2e-7);
  const auto d = device.MeasureDistanceAndAngles();
  EXPECT_NEAR(*d.distance_mm,
              (lab_.TruePosition("robot") - lab_.station(0).pose.position_mm).norm(), 0.01);
  sim.InjectOnce({Fault::kErrorCode, 139});
  EXPECT_THROW(device.MeasureAngles(), InstrumentError);
  sim.InjectOnce({Fault::kNoiseBytes, 0});
  EXPECT_NEAR(device.MeasureAngles().angles.hz_rad, truth.hz_rad, 2e-7);
  EXPECT_THROW(device.ChangeFace(), InstrumentError);
}

TEST_F(PtyLab, ValAndKawasakiControllersReadAndMove) {
  for (auto layout : {ValSimulator::Layout::kKawasakiAs, ValSimulator::Layout::kValII}) {
    ValSimulator sim(lab_, dir_.File(layout == ValSimulator::Layout::kValII ? "val" : "as"), layout,
                     options_);
    sim.Start();
    robots::ValController robot(Port(sim.path()), true, policy_);
    const Eigen::VectorXd q = robot.ReadJointsRad();
    EXPECT_LT((q - lab_.Joints()).cwiseAbs().maxCoeff(), 1e-5);  // 0.001° printed
    Eigen::VectorXd target(6);
    target << 0.1, -0.2, 1.1, -0.3, 0.4, 0.5;
    robot.MoveTo(target);
    EXPECT_LT((robot.ReadJointsRad() - target).cwiseAbs().maxCoeff(), 1e-5);
    sim.InjectOnce({Fault::kErrorCode, 0});
    EXPECT_THROW(robot.ReadJointsRad(), InstrumentError);
  }
}

TEST_F(PtyLab, CounterBoxReadsCoupledJoints) {
  robots::EncoderCalibration c;
  c.counts_per_rad = Eigen::VectorXd::Constant(6, 10000.0);
  c.counts_per_rad(0) = -9965.0;
  c.offset_rad = Eigen::VectorXd::Constant(6, 0.05);
  c.coupling = Eigen::MatrixXd::Identity(6, 6);
  c.coupling(5, 4) = -0.180556;
  std::vector<std::unique_ptr<CounterSimulator>> sims;
  std::vector<std::unique_ptr<instruments::LineTransport>> ports;
  for (int j = 0; j < 6; ++j) {
    sims.push_back(std::make_unique<CounterSimulator>(
        lab_, j, c, dir_.File("qsb" + std::to_string(j)), options_));
    sims.back()->Start();
    ports.push_back(Port(sims.back()->path()));
  }
  robots::CounterBox box(std::move(ports), c, policy_);
  EXPECT_LT((box.ReadJointsRad() - lab_.Joints()).cwiseAbs().maxCoeff(), 2e-4);  // one count
  EXPECT_THROW(box.MoveTo(Eigen::VectorXd::Zero(6)), InstrumentError);
  sims[2]->InjectOnce({Fault::kErrorCode, 0});
  EXPECT_THROW(box.ReadJointsRad(), InstrumentError);
}

TEST(FakeTransport, DriverLogicWithoutAPort) {
  int calls = 0;
  auto fake =
      std::make_unique<instruments::FakeTransport>([&](std::string_view request) -> std::string {
        ++calls;
        const auto q = instruments::geocom::ParseRequest(request.substr(1));
        if (calls == 1) return "%R1P,0,999:0,\"stale\"\r\n";  // a late reply to something else
        return instruments::geocom::EncodeReply({0, *q.request->trid, 0, {"\"TS30\""}}, false) +
               instruments::geocom::EncodeReply({0, *q.request->trid, 0, {"358"}}, false);
      });
  instruments::RetryPolicy policy;
  // The first attempt waits out its share of the deadline for its own reply after the stale
  // one; 10 ms left the retry none on a loaded machine ("no usable reply after 1 attempt in
  // 15 ms").
  policy.timeout = 300ms;
  instruments::GeoComDevice device(std::move(fake), policy);
  const auto reply = device.Call(5004, {});
  EXPECT_EQ(reply.values[0], "\"TS30\"");
  EXPECT_EQ(device.statistics().stale_replies, 1);
  EXPECT_EQ(device.statistics().retries, 1);
}

}  // namespace armsig::simulation
