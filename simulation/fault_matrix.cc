#include "simulation/fault_matrix.h"

#include <chrono>
#include <thread>
#include <utility>

#include "instruments/emscon_device.h"
#include "instruments/geocom_device.h"
#include "instruments/gsi_device.h"
#include "robots/robot_controllers.h"
#include "simulation/counter_simulator.h"
#include "simulation/emscon_simulator.h"
#include "simulation/geocom_simulator.h"
#include "simulation/gsi_online_simulator.h"
#include "simulation/val_simulator.h"

namespace armsig::simulation {

namespace {

const std::vector<std::pair<Fault, const char*>>& Names() {
  static const std::vector<std::pair<Fault, const char*>> names = {
      {Fault::kNone, "none"},
      {Fault::kNoiseBytes, "noise"},
      {Fault::kDropReply, "silence"},
      {Fault::kTruncateReply, "partial"},
      {Fault::kWrongTrid, "wrong-trid"},
      {Fault::kBadCrc, "bad-crc"},
      {Fault::kBusy, "busy"},
      {Fault::kErrorCode, "error"},
      {Fault::kWarningCode, "warning"},
      {Fault::kNoCrc, "no-crc"},
      {Fault::kFloodBytes, "flood-bytes"},
      {Fault::kEndlessLine, "endless-line"},
      {Fault::kFloodLines, "flood-lines"},
      {Fault::kOtherReply, "other-reply"},
      {Fault::kOutOfRange, "out-of-range"},
      {Fault::kWrongUnit, "wrong-unit"},
      {Fault::kVanish, "vanish"},
      {Fault::kStopShort, "stop-short"},
      {Fault::kWrongCommandId, "wrong-command-id"},
      {Fault::kBeamBreak, "beam-break"},
      {Fault::kReflectorNotFound, "reflector-not-found"},
      {Fault::kStatusBetween, "status-between"},
      {Fault::kStatusInside, "status-inside"},
  };
  return names;
}

// The transport failures' codes (GeoCOM client codes, line_retry.h).
constexpr int kTimedOut = 3077, kOverrun = 3100, kFailed = 3085, kCantDecode = 3074;

}  // namespace

std::string FaultName(Fault fault) {
  for (const auto& [f, name] : Names()) {
    if (f == fault) return name;
  }
  return "fault " + std::to_string(static_cast<int>(fault));
}

std::optional<Fault> FaultFromName(std::string_view name) {
  for (const auto& [f, n] : Names()) {
    if (name == n) return f;
  }
  return std::nullopt;
}

std::string FaultNames() {
  std::string out;
  for (const auto& [f, name] : Names()) out += (out.empty() ? "" : ", ") + std::string(name);
  return out;
}

std::string ProtocolName(Protocol protocol) {
  switch (protocol) {
    case Protocol::kGeoCom:
      return "geocom";
    case Protocol::kGeoComCrc:
      return "geocom+crc";
    case Protocol::kGsiOnline:
      return "gsi";
    case Protocol::kValII:
      return "val";
    case Protocol::kKawasakiAs:
      return "as";
    case Protocol::kCounter:
      return "counter";
    case Protocol::kEmscon:
      return "emscon";
  }
  return "?";
}

std::vector<FaultCase> FaultMatrix() {
  std::vector<FaultCase> cases;
  // Random bytes: mostly short noise lines (CR or LF every 128 bytes on average), now and
  // then one over the maximum; the monitor may also read a noise line as an error
  // message (code 1) or take noise for a prompt and fail to decode the reply.
  const std::vector<int> flood_bytes = {kTimedOut, kOverrun};
  for (Protocol p : {Protocol::kGeoCom, Protocol::kGeoComCrc}) {
    cases.push_back({p, Fault::kFloodBytes, flood_bytes});
    cases.push_back({p, Fault::kEndlessLine, {kOverrun}});
    cases.push_back({p, Fault::kFloodLines, {3093}});  // COM_TR_ID_MISMATCH
    cases.push_back({p, Fault::kDropReply, {kTimedOut}});
    cases.push_back({p, Fault::kTruncateReply, {kTimedOut, kOverrun}});
    cases.push_back({p, Fault::kWrongTrid, {3093}});
    cases.push_back({p, Fault::kBadCrc, {3102}});  // COM_CLNT_RX_CHECKSUM_ERROR
    cases.push_back({p, Fault::kBusy, {13}});      // GRC_SYSBUSY, after every attempt
    cases.push_back({p, Fault::kVanish, {kFailed}});
    cases.push_back({p, Fault::kOtherReply, {kCantDecode}});
    cases.push_back({p, Fault::kOutOfRange, {kCantDecode}});
  }
  cases.push_back({Protocol::kGeoComCrc, Fault::kNoCrc, {3110}});  // COM_NO_CHECKSUM
  const Protocol gsi = Protocol::kGsiOnline;
  cases.push_back({gsi, Fault::kFloodBytes, flood_bytes});
  cases.push_back({gsi, Fault::kEndlessLine, {kOverrun}});
  cases.push_back({gsi, Fault::kFloodLines, {kTimedOut}});  // other words only
  cases.push_back({gsi, Fault::kDropReply, {kTimedOut}});
  cases.push_back({gsi, Fault::kTruncateReply, {kTimedOut, kOverrun}});
  cases.push_back({gsi, Fault::kBusy, {100}});  // @W100
  cases.push_back({gsi, Fault::kVanish, {kFailed}});
  cases.push_back({gsi, Fault::kOtherReply, {kTimedOut}});
  cases.push_back({gsi, Fault::kOutOfRange, {kCantDecode}});
  cases.push_back({gsi, Fault::kWrongUnit, {kCantDecode}});
  for (Protocol p : {Protocol::kValII, Protocol::kKawasakiAs}) {
    cases.push_back({p, Fault::kFloodBytes, {kTimedOut, kOverrun, kCantDecode, 1}});
    cases.push_back({p, Fault::kEndlessLine, {kOverrun}});
    cases.push_back({p, Fault::kFloodLines, {kOverrun}});  // rows and never a prompt
    cases.push_back({p, Fault::kDropReply, {kTimedOut}});
    cases.push_back({p, Fault::kTruncateReply, {kTimedOut, kCantDecode}});
    cases.push_back({p, Fault::kErrorCode, {1}});  // (P1000) motor power is OFF
    cases.push_back({p, Fault::kVanish, {kFailed}});
    cases.push_back({p, Fault::kOtherReply, {kCantDecode}});
    cases.push_back({p, Fault::kOutOfRange, {kCantDecode}});
  }
  const Protocol counter = Protocol::kCounter;
  cases.push_back({counter, Fault::kFloodBytes, {kTimedOut, kOverrun, 1}});
  cases.push_back({counter, Fault::kEndlessLine, {kOverrun}});
  cases.push_back({counter, Fault::kFloodLines, {kTimedOut}});  // other registers only
  cases.push_back({counter, Fault::kDropReply, {kTimedOut}});
  cases.push_back({counter, Fault::kTruncateReply, {kTimedOut, kOverrun}});
  cases.push_back({counter, Fault::kErrorCode, {1}});  // "e!"
  cases.push_back({counter, Fault::kVanish, {kFailed}});
  cases.push_back({counter, Fault::kOtherReply, {kTimedOut}});
  cases.push_back({counter, Fault::kOutOfRange, {kCantDecode}});
  // The laser tracker: binary packets over TCP. Most faults hit the set-up's first command
  // (SetUnits); the measurement faults hit StartMeasurement. A random size field is out of
  // frame (3100) but may also be plausible and wait for bytes that never come (3077).
  const Protocol emscon = Protocol::kEmscon;
  cases.push_back({emscon, Fault::kFloodBytes, {kOverrun, kTimedOut}});
  cases.push_back({emscon, Fault::kEndlessLine, {kOverrun, kTimedOut}});  // printable bytes
  // Status and position packets, never the answer; a drain may cut one (out of frame).
  cases.push_back({emscon, Fault::kFloodLines, {kTimedOut, kOverrun}});
  cases.push_back({emscon, Fault::kNoiseBytes, {kOverrun, kTimedOut}});
  cases.push_back({emscon, Fault::kDropReply, {kTimedOut}});
  cases.push_back({emscon, Fault::kTruncateReply, {kTimedOut}});
  cases.push_back({emscon, Fault::kWrongCommandId, {3093}});  // COM_TR_ID_MISMATCH
  cases.push_back({emscon, Fault::kStatusInside, {3093, kTimedOut, kOverrun}});
  cases.push_back({emscon, Fault::kBusy, {1}});        // ES_RS_ServerBusy
  cases.push_back({emscon, Fault::kErrorCode, {39}});  // the ErrorResponse's status
  cases.push_back({emscon, Fault::kVanish, {kFailed}});
  cases.push_back({emscon, Fault::kOutOfRange, {kCantDecode}});
  cases.push_back({emscon, Fault::kBeamBreak, {37}});             // ES_RS_NoDistanceSet
  cases.push_back({emscon, Fault::kReflectorNotFound, {10004}});  // MeasurementStatusNotReady
  return cases;
}

FaultOutcome RunFaultCase(VirtualLab& lab, const FaultCase& c, const std::string& link,
                          const instruments::RetryPolicy& policy) {
  SimulatorOptions options;
  options.angle_latency = std::chrono::milliseconds(10);
  options.distance_latency = std::chrono::milliseconds(20);
  options.motion_latency = std::chrono::milliseconds(20);
  instruments::SerialSettings port;
  port.path = link;
  port.baud = 115200;
  robots::EncoderCalibration encoders;  // 10000 counts per rad on every joint
  encoders.counts_per_rad = Eigen::VectorXd::Constant(lab.model().num_joints(), 10000.0);
  encoders.offset_rad = Eigen::VectorXd::Zero(lab.model().num_joints());
  encoders.coupling = Eigen::MatrixXd::Identity(lab.model().num_joints(), lab.model().num_joints());

  std::unique_ptr<Simulator> sim;
  switch (c.protocol) {
    case Protocol::kEmscon: {
      EmsconSimulatorOptions tracker;
      tracker.time_scale = 0.01;  // a 500 ms measurement in 5 ms
      tracker.initialized = true;
      sim = std::make_unique<EmsconSimulator>(lab, 0, "127.0.0.1", 0, tracker);
      break;
    }
    case Protocol::kGeoCom:
    case Protocol::kGeoComCrc:
      sim = std::make_unique<GeoComSimulator>(lab, 0, link, options);
      break;
    case Protocol::kGsiOnline:
      sim = std::make_unique<GsiOnlineSimulator>(lab, 0, link, options);
      break;
    case Protocol::kValII:
    case Protocol::kKawasakiAs:
      sim = std::make_unique<ValSimulator>(lab, link,
                                           c.protocol == Protocol::kValII
                                               ? ValSimulator::Layout::kValII
                                               : ValSimulator::Layout::kKawasakiAs,
                                           options);
      break;
    case Protocol::kCounter:
      sim = std::make_unique<CounterSimulator>(lab, 0, encoders, link, options);
      break;
  }
  sim->Start();
  const int error_code = c.protocol == Protocol::kEmscon ? 39 : 1;  // TrackerNotInitialized
  sim->InjectAlways({c.fault, c.fault == Fault::kErrorCode ? error_code : 0});

  std::unique_ptr<instruments::Theodolite> theodolite;
  std::unique_ptr<instruments::RobotController> controller;
  switch (c.protocol) {
    case Protocol::kEmscon: {
      auto* tracker = static_cast<EmsconSimulator*>(sim.get());
      theodolite = std::make_unique<instruments::EmsconDevice>(
          instruments::MakeEmsconTcpTransport("127.0.0.1", tracker->port()), policy);
      break;
    }
    case Protocol::kGeoCom:
    case Protocol::kGeoComCrc:
      theodolite = std::make_unique<instruments::GeoComDevice>(
          instruments::MakeSerialTransport(port), policy, c.protocol == Protocol::kGeoComCrc);
      break;
    case Protocol::kGsiOnline:
      theodolite = std::make_unique<instruments::GsiOnlineDevice>(
          instruments::MakeSerialTransport(port), policy);
      break;
    case Protocol::kValII:
    case Protocol::kKawasakiAs:
      controller = std::make_unique<robots::ValController>(
          instruments::MakeSerialTransport(port), false, policy);
      break;
    case Protocol::kCounter: {
      robots::EncoderCalibration one;
      one.counts_per_rad = encoders.counts_per_rad.head(1);
      one.offset_rad = encoders.offset_rad.head(1);
      one.coupling = Eigen::MatrixXd::Identity(1, 1);
      std::vector<std::unique_ptr<instruments::LineTransport>> channels;
      channels.push_back(instruments::MakeSerialTransport(port));
      controller = std::make_unique<robots::CounterBox>(std::move(channels), one, policy);
      break;
    }
  }

  FaultOutcome out;
  const int64_t flooded_before = sim->flood_bytes();
  const auto start = std::chrono::steady_clock::now();
  try {
    if (theodolite) {
      theodolite->MeasureAngles();
    } else {
      controller->ReadJointsRad();
    }
    out.reading = true;
  } catch (const instruments::InstrumentError& e) {
    out.code = e.code();
    out.error = e.what();
  } catch (const std::exception& e) {
    out.error = std::string("not an InstrumentError: ") + e.what();
  }
  out.ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  // The simulator counts a flood's bytes on its own thread as the line takes them: give
  // the count a moment to catch up with what the driver already read (out.ms is taken).
  const auto settle = std::chrono::steady_clock::now() + std::chrono::milliseconds(200);
  while (sim->flood_bytes() - flooded_before < 4096 && std::chrono::steady_clock::now() < settle) {
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  out.flood_bytes = sim->flood_bytes() - flooded_before;
  sim->Stop();
  return out;
}

}  // namespace armsig::simulation
