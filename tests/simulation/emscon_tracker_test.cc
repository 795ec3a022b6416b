// The laser tracker driver against the virtual tracker over real TCP on 127.0.0.1 (Asio on
// both ends): every call, the set-up overriding a tracker state that is deliberately not
// armsig's, every fault once (recovered, or a typed error and no reading), the noise model
// checked by χ², the weather drifting, an interrupt on a flood, and the command line.
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <functional>
#include <nlohmann/json.hpp>
#include <numbers>
#include <thread>

#include "instruments/emscon_device.h"
#include "reduction/intersection.h"
#include "reduction/observation.h"
#include "simulation/emscon_simulator.h"
#include "simulation/fault_matrix.h"
#include "test_support.h"

namespace armsig::simulation {
namespace {

namespace es = instruments::emscon;
using namespace std::chrono_literals;

// A PUMA 760 seen from a tracker 3.2 m away, levelled, circle zero at azimuth 0.7 rad.
std::unique_ptr<VirtualLab> TrackerLab() {
  auto lab = std::make_unique<VirtualLab>(testing::Puma(), Eigen::VectorXd::Zero(43),
                                          Eigen::Isometry3d::Identity());
  VirtualStation s;
  s.pose.id = "LT1";
  s.pose.position_mm = {2800.0, -1500.0, 400.0};
  s.pose.azimuth_rad = 0.7;
  s.pose.world_from_station = reduction::LevelledRotation(0.7);
  lab->AddStation(s);
  Eigen::VectorXd q(6);
  q << 0.3, -0.4, 0.9, 0.2, -0.5, 0.1;
  lab->SetJoints(q);
  return lab;
}

EmsconSimulatorOptions Quick() {
  EmsconSimulatorOptions o;
  o.time_scale = 0.1;  // a 100 ms measurement in 10 ms
  return o;
}

instruments::RetryPolicy TrackerPolicy(std::chrono::milliseconds timeout = 1000ms) {
  instruments::RetryPolicy p;
  p.timeout = timeout;
  p.busy_delay = 10ms;
  p.reconnect_delay = 20ms;
  return p;
}

struct TrackerRig {
  std::unique_ptr<VirtualLab> lab = TrackerLab();
  std::unique_ptr<EmsconSimulator> sim;
  std::unique_ptr<instruments::EmsconDevice> device;
  explicit TrackerRig(EmsconSimulatorOptions options = Quick(),
                      instruments::RetryPolicy policy = TrackerPolicy()) {
    sim = std::make_unique<EmsconSimulator>(*lab, 0, "127.0.0.1", 0, options);
    sim->Start();
    instruments::EmsconOptions tracker;
    tracker.measurement_time_ms = 100;  // an attempt then waits 300 ms at least
    device = std::make_unique<instruments::EmsconDevice>(
        instruments::MakeEmsconTcpTransport("127.0.0.1", sim->port()), policy, tracker);
  }
  // The reading is the truth within `k` of the noise model's σ on each axis.
  void ExpectTruth(const instruments::Reading& r, double k = 6.0) const {
    ASSERT_TRUE(r.point_in_instrument_mm);
    const Eigen::Vector3d truth = sim->TruePointInTracker();
    const double sigma = sim->SigmaMm(truth.norm());
    EXPECT_LT((*r.point_in_instrument_mm - truth).cwiseAbs().maxCoeff(), k * sigma)
        << "reading " << r.point_in_instrument_mm->transpose() << " truth " << truth.transpose();
  }
};

int CodeOf(const std::function<void()>& call) {
  try {
    call();
  } catch (const instruments::InstrumentError& e) {
    return e.code();
  }
  ADD_FAILURE() << "expected an InstrumentError";
  return -1;
}

}  // namespace

// The virtual tracker starts in metres, gon, °F, mmHg, Cartesian, continuous mode, with a
// user transformation on and not initialised: after the driver's set-up every one of them is
// armsig's, and the reading is the truth.
TEST(VirtualTracker, DriverSetsEveryStateAndMeasuresTheTruth) {
  TrackerRig rig;
  const auto before = rig.sim->state();
  EXPECT_EQ(before.units.length, es::length_unit::kMeter);
  EXPECT_TRUE(before.settings.apply_transformation);
  EXPECT_FALSE(before.initialized);
  const instruments::Reading r = rig.device->Measure();
  rig.ExpectTruth(r);
  const auto after = rig.sim->state();
  EXPECT_EQ(after.units, es::Units{});  // mm, rad, °C, mbar, %RH
  EXPECT_EQ(after.coordinate_system, es::coordinate_system::kSCC);  // RHR only for the check
  EXPECT_TRUE(rig.device->convention_checked());
  EXPECT_EQ(after.meas_mode, es::meas_mode::kStationary);
  EXPECT_EQ(after.meas_time_ms, 100);
  EXPECT_TRUE(after.initialized);
  EXPECT_FALSE(after.settings.apply_transformation);
  EXPECT_FALSE(after.settings.apply_station_orientation);
  EXPECT_TRUE(after.settings.send_unsolicited_messages);
  EXPECT_EQ(rig.device->reflector_id(), 1);
  // Hz, V and the distance are the theodolite reading (docs/reference/conventions.md) of the
  // target from the station.
  const auto& pose = rig.lab->station(0).pose;
  const Eigen::Vector3d target = rig.lab->TruePosition("robot");
  const AngleReading truth =
      reduction::PredictReading(pose.position_mm, pose.world_from_station, target);
  const double d = (target - pose.position_mm).norm();
  const double sigma = rig.sim->SigmaMm(d);
  EXPECT_NEAR(r.angles.hz_rad, truth.hz_rad, 6 * sigma / d / std::sin(truth.v_rad));
  EXPECT_NEAR(r.angles.v_rad, truth.v_rad, 6 * sigma / d);
  EXPECT_NEAR(*r.distance_mm, d, 6 * sigma);
  // The result's sigmas are the noise model's in spherical form.
  EXPECT_NEAR(r.sigma->distance_mm, sigma, 1e-6 * sigma);
  EXPECT_NEAR(r.sigma->v_rad, sigma / *r.distance_mm, 1e-9);
  EXPECT_NEAR(r.sigma->hz_rad, sigma / (*r.distance_mm * std::sin(r.angles.v_rad)), 1e-9);
  // °C, hPa, %RH (the tracker was in °F and mmHg).
  EXPECT_NEAR(r.environment->temperature_c, 20.0, 1.0);
  EXPECT_NEAR(r.environment->pressure_hpa, 1013.25, 2.0);
  EXPECT_NEAR(r.environment->humidity_percent, 45.0, 3.0);
}

// A cold tracker: Initialize takes 1.5 s, longer than the call's 1 s deadline; it has its
// own deadline and the measurement after it still gets its time.
// Continuous time mode (an AT9xx): records every separation of the tracker's own clock, its
// offset and drift as planted, each the truth within the noise; an AT4xx refuses the mode;
// after StopContinuous the tracker measures standing again.
TEST(VirtualTracker, ContinuousRecordsOnTheTrackersOwnClock) {
  EmsconSimulatorOptions o = Quick();
  o.time_scale = 1.0;
  o.continuous_modes = true;
  o.clock_offset_s = 12.5;
  o.clock_drift_ppm = 40.0;
  TrackerRig rig(o);
  rig.device->Measure();  // set up (stationary)
  rig.device->StartContinuous({20, std::nullopt});
  std::vector<instruments::ContinuousRecord> records;
  std::atomic<bool> done{false};
  std::thread stopper([&] {
    std::this_thread::sleep_for(400ms);
    done = true;
  });
  rig.device->ReadContinuous(instruments::Clock::now() + 5s, done,
                             [&](const instruments::ContinuousRecord& r) { records.push_back(r); },
                             {});
  stopper.join();
  // What the reader did not read before it stopped (the records still in flight) arrives
  // with the stop, in order; nothing is lost between two calls.
  std::this_thread::sleep_for(200ms);
  const size_t read = records.size();
  rig.device->StopContinuous(
      [&](const instruments::ContinuousRecord& r) { records.push_back(r); });
  EXPECT_GE(records.size(), read + 5) << "the 200 ms after the reader stopped";
  ASSERT_GE(records.size(), 20u);
  EXPECT_LE(records.size(), 40u);
  const Eigen::Vector3d truth = rig.sim->TruePointInTracker();
  const double sigma = rig.sim->SigmaMm(truth.norm());
  for (size_t k = 0; k < records.size(); ++k) {
    EXPECT_LT((records[k].point_in_instrument_mm - truth).cwiseAbs().maxCoeff(), 6 * sigma);
    if (k > 0) {
      EXPECT_NEAR(records[k].tracker_time_s - records[k - 1].tracker_time_s, 0.020, 2e-6);
    }
  }
  // The tracker's clock: offset 12.5 s on the simulator's physical time (a second at most).
  EXPECT_GT(records.front().tracker_time_s, 12.5);
  EXPECT_LT(records.front().tracker_time_s, 14.0);
  EXPECT_EQ(rig.sim->state().meas_mode, es::meas_mode::kStationary);
  rig.ExpectTruth(rig.device->Measure());

  TrackerRig at4xx;  // continuous modes not offered
  at4xx.device->Measure();
  EXPECT_THROW(at4xx.device->StartContinuous({20, std::nullopt}), instruments::InstrumentError);
}

TEST(VirtualTracker, ColdTrackerIsInitializedWithinItsOwnDeadline) {
  EmsconSimulatorOptions options;
  options.time_scale = 1.0;
  options.initialize_latency = 1500ms;
  options.command_latency = 1ms;
  TrackerRig rig(options, TrackerPolicy(1000ms));
  const auto start = std::chrono::steady_clock::now();
  rig.ExpectTruth(rig.device->Measure());
  EXPECT_GE(std::chrono::steady_clock::now() - start, 1500ms);
  EXPECT_TRUE(rig.sim->state().initialized);
  EXPECT_EQ(rig.device->statistics().retries, 0);
}

TEST(VirtualTracker, EveryCall) {
  TrackerRig rig;
  const auto info = rig.device->Identify();
  EXPECT_EQ(info.serial, "391234");
  EXPECT_EQ(info.firmware, "emScon 3.6.1234");
  EXPECT_EQ(rig.device->Face(), 1);
  rig.device->ChangeFace();
  EXPECT_EQ(rig.device->Face(), 2);
  EXPECT_EQ(rig.sim->state().face, 2);
  EXPECT_TRUE(rig.device->CompensatorOn());
  EXPECT_EQ(rig.device->Reflectors().size(), 4u);
  rig.device->FindReflector(3000.0);
  // GoPosition: the point the tracker turns to is the one asked for (SCC both ways).
  const Eigen::Vector3d predicted(-1200.0, 2500.0, 700.0);
  rig.device->GoPosition(predicted);
  ASSERT_TRUE(rig.sim->state().go_position_mm);
  EXPECT_LT((*rig.sim->state().go_position_mm - predicted).norm(), 1e-9);
  const auto env = rig.device->GetEnvironment();
  EXPECT_NEAR(env.temperature_c, 20.0, 1.0);
  EXPECT_NEAR(env.pressure_hpa, 1013.25, 2.0);
  EXPECT_EQ(rig.device->statistics().configurations, 1);
}

// χ² of the normalised errors over many readings: Σ (e/σ)² over 3N components follows
// χ²(3N), mean 3N, standard deviation √(6N). Both with the noise model's σ per Cartesian
// axis and with the sigmas each result reports (Hz, V, distance).
TEST(VirtualTracker, ReadingsAgreeWithTheTruthToTheStatedNoise) {
  EmsconSimulatorOptions options;
  options.time_scale = 0.0;  // no latency
  options.seed = 20240917;
  TrackerRig rig(options);
  const Eigen::Vector3d truth = rig.sim->TruePointInTracker();
  const es::Spherical t = es::SphericalFromPoint(truth);
  const double sigma = rig.sim->SigmaMm(truth.norm());
  constexpr int kN = 400;
  double chi2_xyz = 0.0, chi2_reported = 0.0;
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (int i = 0; i < kN; ++i) {
    const auto r = rig.device->Measure();
    const Eigen::Vector3d e = *r.point_in_instrument_mm - truth;
    mean += e / kN;
    chi2_xyz += e.squaredNorm() / (sigma * sigma);
    chi2_reported += std::pow((r.angles.hz_rad - t.hz_rad) / r.sigma->hz_rad, 2) +
                     std::pow((r.angles.v_rad - t.v_rad) / r.sigma->v_rad, 2) +
                     std::pow((*r.distance_mm - t.distance_mm) / r.sigma->distance_mm, 2);
  }
  const double dof = 3.0 * kN, sd = std::sqrt(2.0 * dof);
  std::cout << "chi2/dof: Cartesian " << chi2_xyz / dof << ", reported sigmas "
            << chi2_reported / dof << " (dof " << dof << ", 1 ± " << 4 * sd / dof
            << " at 4 sd); sigma " << sigma * 1000 << " um at " << truth.norm() / 1000 << " m\n";
  EXPECT_NEAR(chi2_xyz, dof, 4 * sd);
  EXPECT_NEAR(chi2_reported, dof, 4 * sd);
  // No bias: the mean error is within 4 σ/√N on each axis.
  EXPECT_LT(mean.cwiseAbs().maxCoeff(), 4 * sigma / std::sqrt(kN)) << mean.transpose();
}

TEST(VirtualTracker, EnvironmentDriftsSlowly) {
  EmsconSimulatorOptions options = Quick();
  options.environment_time_scale = 36000.0;  // ten hours of weather per second
  TrackerRig rig(options);
  std::vector<instruments::Environment> seen;
  for (int i = 0; i < 4; ++i) {
    seen.push_back(*rig.device->Measure().environment);
    std::this_thread::sleep_for(200ms);  // two hours of weather
  }
  for (size_t i = 1; i < seen.size(); ++i) {
    EXPECT_NE(seen[i].temperature_c, seen[i - 1].temperature_c);
    EXPECT_LT(std::abs(seen[i].temperature_c - seen[i - 1].temperature_c), 1.0);
    EXPECT_LT(std::abs(seen[i].pressure_hpa - seen[i - 1].pressure_hpa), 2.0);
    EXPECT_LT(std::abs(seen[i].humidity_percent - seen[i - 1].humidity_percent), 4.0);
  }
  // The model itself: 0.1 °C per hour of trend under a 0.3 °C daily-ish swing.
  EXPECT_NEAR(EmsconSimulator::WeatherAt(0).temperature, 20.0, 1e-12);
  EXPECT_NEAR(EmsconSimulator::WeatherAt(36000).temperature - 20.0, 1.0, 0.31);
}

// Every fault once: recovered (the reading is the truth) or a typed error with no reading,
// and the next reading the truth again.
TEST(VirtualTracker, EveryFaultOnceIsRecoveredOrTyped) {
  struct Case {
    Fault fault;
    int code;  // 0: the call recovers and returns the truth
  };
  for (const Case& c :
       {Case{Fault::kNoiseBytes, 0}, Case{Fault::kDropReply, 0}, Case{Fault::kTruncateReply, 0},
        Case{Fault::kWrongCommandId, 0}, Case{Fault::kBusy, 0}, Case{Fault::kVanish, 0},
        Case{Fault::kStatusBetween, 0}, Case{Fault::kStatusInside, 0}, Case{Fault::kBeamBreak, 37},
        Case{Fault::kReflectorNotFound, 10004}, Case{Fault::kErrorCode, 39},
        Case{Fault::kOutOfRange, 3074}}) {
    TrackerRig rig;
    rig.device->Connect();
    rig.sim->InjectOnce({c.fault, c.fault == Fault::kErrorCode ? 39 : 0});
    if (c.code == 0) {
      instruments::Reading r;
      ASSERT_NO_THROW(r = rig.device->Measure()) << FaultName(c.fault);
      rig.ExpectTruth(r);
    } else {
      EXPECT_EQ(CodeOf([&] { rig.device->Measure(); }), c.code) << FaultName(c.fault);
    }
    rig.ExpectTruth(rig.device->Measure());  // and the line is clean afterwards
    const auto& s = rig.device->statistics();
    if (c.fault == Fault::kVanish) {
      EXPECT_EQ(s.reconnects, 1);
      EXPECT_EQ(s.configurations, 2);  // set up again on the new connection
      EXPECT_EQ(rig.sim->connections(), 2);
    }
    if (c.fault == Fault::kStatusBetween) {
      EXPECT_GE(s.status_changes, 2);
      EXPECT_EQ(s.unsolicited_errors, 1);
      EXPECT_EQ(s.retries, 0);  // nothing to retry: the packets were read past
    }
    if (c.fault == Fault::kStatusInside) {
      EXPECT_EQ(s.retries, 1) << "one attempt lost";
    }
    if (c.fault == Fault::kBusy) {
      EXPECT_EQ(s.busy, 1);
    }
  }
}

// Faults on the other calls: a reflector that cannot be found, a busy GoPosition.
TEST(VirtualTracker, FindReflectorAndGoPositionFaults) {
  TrackerRig rig;
  rig.device->Connect();
  rig.sim->InjectOnce({Fault::kReflectorNotFound, 0});
  EXPECT_EQ(CodeOf([&] { rig.device->FindReflector(3000.0); }), 10004);
  rig.sim->InjectAlways({Fault::kBusy, 0});
  EXPECT_EQ(CodeOf([&] { rig.device->GoPosition({1000, 1000, 0}); }), 1);
  rig.sim->ClearFaults();
  rig.device->GoPosition({1000, 1000, 0});
  EXPECT_LT((*rig.sim->state().go_position_mm - Eigen::Vector3d(1000, 1000, 0)).norm(), 1e-9);
}

// Ctrl-C: a connection that floods ends its call within a few poll intervals.
TEST(VirtualTracker, InterruptEndsAFloodedCallAtOnce) {
  TrackerRig rig(Quick(), TrackerPolicy(20s));
  rig.device->Connect();
  rig.sim->InjectAlways({Fault::kFloodLines, 0});
  std::atomic<bool> stop{false};
  rig.device->SetInterrupt(&stop);
  // The clock starts before the thread that interrupts (started after it, it could begin a
  // few ms into the thread's 300 ms on a loaded machine).
  const auto start = std::chrono::steady_clock::now();
  std::thread ctrl_c([&] {
    std::this_thread::sleep_for(300ms);
    stop = true;
  });
  try {
    rig.device->Measure();
    ADD_FAILURE() << "expected an interrupt";
  } catch (const instruments::TransportError& e) {
    EXPECT_EQ(e.kind(), instruments::TransportError::Kind::kInterrupted) << e.what();
  }
  const auto took = std::chrono::steady_clock::now() - start;
  ctrl_c.join();
  EXPECT_GE(took, 300ms);
  EXPECT_LT(took, 300ms + 700ms);
  EXPECT_GT(rig.device->statistics().status_changes, 100);  // it was flooded
}

// The fault matrix has a laser-tracker row with the faults every protocol gets and the
// tracker's own (faults_pty_test.cc runs it).
TEST(FaultMatrix, HasTheTrackerRow) {
  const auto cases = FaultMatrix();
  for (Fault f :
       {Fault::kFloodBytes, Fault::kFloodLines, Fault::kNoiseBytes, Fault::kDropReply,
        Fault::kTruncateReply, Fault::kWrongCommandId, Fault::kVanish, Fault::kBusy,
        Fault::kOutOfRange, Fault::kBeamBreak, Fault::kReflectorNotFound, Fault::kStatusInside}) {
    EXPECT_TRUE(std::any_of(cases.begin(), cases.end(), [&](const FaultCase& c) {
      return c.protocol == Protocol::kEmscon && c.fault == f;
    })) << FaultName(f);
  }
}

// `armsig instrument probe|read --protocol emscon --tcp HOST:PORT --json`.
TEST(EmsconCommand, ProbeAndReadJsonAgainstTheVirtualTracker) {
  TrackerRig rig;
  const std::string tcp = rig.sim->path();
  const auto probe =
      testing::RunArmsig("instrument probe --protocol emscon --tcp " + tcp + " --json");
  ASSERT_EQ(probe.exit_code, 0) << probe.err;
  EXPECT_EQ(nlohmann::json::parse(probe.out)["serial"], "391234");
  EXPECT_EQ(rig.sim->state().units.length, es::length_unit::kMeter);  // a probe sets nothing
  const auto read =
      testing::RunArmsig("instrument read --protocol emscon --tcp " + tcp + " --json");
  ASSERT_EQ(read.exit_code, 0) << read.err;
  const auto j = nlohmann::json::parse(read.out);
  const Eigen::Vector3d truth = rig.sim->TruePointInTracker();
  const double sigma = rig.sim->SigmaMm(truth.norm());
  EXPECT_NEAR(j["x_mm"].get<double>(), truth.x(), 6 * sigma);
  EXPECT_NEAR(j["y_mm"].get<double>(), truth.y(), 6 * sigma);
  EXPECT_NEAR(j["z_mm"].get<double>(), truth.z(), 6 * sigma);
  EXPECT_NEAR(j["distance_mm"].get<double>(), truth.norm(), 6 * sigma);
  EXPECT_NEAR(j["sigma_distance_mm"].get<double>(), sigma, 1e-9);
  EXPECT_TRUE(j.contains("temperature_c"));
  EXPECT_TRUE(j.contains("pressure_hpa"));
  EXPECT_TRUE(j.contains("humidity_percent"));
  // A beam break: exit 1 naming the status, no reading.
  rig.sim->InjectAlways({Fault::kBeamBreak, 0});
  const auto broken =
      testing::RunArmsig("instrument read --protocol emscon --tcp " + tcp + " --json");
  EXPECT_EQ(broken.exit_code, 1);
  EXPECT_TRUE(broken.out.empty()) << broken.out;
  EXPECT_NE(broken.err.find("ES_RS_NoDistanceSet"), std::string::npos) << broken.err;
  EXPECT_NE(broken.err.find("the beam broke or the reflector left it"), std::string::npos)
      << broken.err;  // and what it means at the tracker
  // emscon needs --tcp.
  EXPECT_EQ(testing::RunArmsig("instrument read --protocol emscon --port /dev/null").exit_code, 2);
}

// `armsig instrument simulate --protocol emscon --tcp 127.0.0.1:PORT` serves a reader.
TEST(EmsconCommand, SimulateServesAReader) {
  // A free port: bind one, note it, let it go (the simulator binds it with SO_REUSEADDR).
  auto lab = TrackerLab();
  unsigned short port = 0;
  {
    EmsconSimulator probe(*lab, 0, "127.0.0.1", 0);
    probe.Start();
    port = probe.port();
    probe.Stop();
  }
  const std::string tcp = "127.0.0.1:" + std::to_string(port);
  testing::CommandResult served;
  std::thread server([&] {
    served =
        testing::RunArmsig("instrument simulate --protocol emscon --tcp " + tcp + " --seconds 8");
  });
  // `instrument read` with its default deadline (3 s) and the tracker's default stationary
  // time (500 ms): the first reading on a connection includes the convention self-check
  // (a second measurement), which has time of its own.
  testing::CommandResult read;
  const auto listening = std::chrono::steady_clock::now() + 6s;
  do {  // the program takes a moment to start listening: exit 1, "connection refused"
    read = testing::RunArmsig("instrument read --protocol emscon --tcp " + tcp + " --json");
  } while (read.exit_code != 0 && read.err.find("refused") != std::string::npos &&
           std::chrono::steady_clock::now() < listening);
  ASSERT_EQ(read.exit_code, 0) << read.err;
  EXPECT_GT(nlohmann::json::parse(read.out)["distance_mm"].get<double>(), 1000.0);
  instruments::RetryPolicy policy;
  policy.timeout = 3000ms;
  instruments::EmsconOptions options;
  options.measurement_time_ms = 50;  // the first reading is two (the convention self-check)
  instruments::EmsconDevice device(instruments::MakeEmsconTcpTransport("127.0.0.1", port), policy,
                                   options);
  instruments::Reading r;
  const auto until = std::chrono::steady_clock::now() + 3s;
  for (;;) {  // the program takes a moment to start listening
    try {
      r = device.Measure();
      break;
    } catch (const instruments::InstrumentError&) {
      if (std::chrono::steady_clock::now() > until) throw;
      std::this_thread::sleep_for(100ms);
    }
  }
  EXPECT_TRUE(r.distance_mm);
  EXPECT_GT(*r.distance_mm, 1000.0);
  server.join();
  EXPECT_EQ(served.exit_code, 0) << served.err;
  EXPECT_NE(served.out.find("virtual emscon instrument on " + tcp), std::string::npos)
      << served.out;
  EXPECT_EQ(testing::RunArmsig("instrument simulate --protocol emscon --tcp nowhere").exit_code, 2);
}

}  // namespace armsig::simulation
