// The emScon tracker driver against an in-memory packet transport: the set-up sequence it
// sends (nothing about the tracker's state assumed), how asynchronous packets between a
// command and its answer are recorded and never taken for the answer, answers with another
// command id, results split over reads, results that are no reading, retries and the
// Hz/V/distance mapping.
#include "instruments/emscon_device.h"

#include <fmt/format.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <functional>
#include <map>
#include <numbers>

#include "core/error.h"

namespace armsig::instruments {
namespace {

namespace es = emscon;
using namespace std::chrono_literals;

RetryPolicy EmsconFast() {
  RetryPolicy p;
  p.attempts = 3;
  p.timeout = 200ms;
  p.busy_delay = 1ms;
  p.reconnect_delay = 1ms;
  return p;
}

// A scripted tracker: answers every command AllOK (with the payloads the driver asks for),
// a StartMeasurement with `result` (SCC values) in the coordinate system type set: in RHR
// the point those values are by the public convention (emscon::PointFromScc), or, with
// `wrong_convention`, by a theodolite's (Hz clockwise from +y). Per-command overrides
// replace the whole answer.
struct FakeTracker {
  es::MeasResult result;
  int32_t processor_status = es::tracker_processor_status::kInitialized;
  int32_t coordinate_system = es::coordinate_system::kRHR;
  int32_t angle_unit = es::angle_unit::kRadian;
  bool wrong_convention = false;
  std::map<int32_t, std::function<std::vector<std::string>()>> overrides;
  std::vector<es::Request> received;
  size_t chunk = 0;  // > 0: deliver the answer in chunks of this many bytes

  FakeTracker() {
    // Hz 1.25 rad, V 1.5 rad, 4000 mm (SCC), sigmas, 21.5 °C, 1002.5 hPa, 38 %RH.
    result.value = {1.25, 1.5, 4000.0};
    result.std_dev = {2e-6, 3e-6, 0.01};
    result.temperature = 21.5;
    result.pressure = 1002.5;
    result.humidity = 38.0;
  }

  // The result packet in the coordinate system type set.
  std::string ResultPacket() const {
    if (coordinate_system != es::coordinate_system::kRHR) return es::EncodePacket(result);
    const double rad = *es::RadiansPer(angle_unit);
    const double hz = result.value[0] * rad, v = result.value[1] * rad, d = result.value[2];
    const Eigen::Vector3d p =
        wrong_convention ? es::PointFromSpherical({hz, v, d}) : es::PointFromScc({hz, v, d});
    es::MeasResult cartesian = result;
    cartesian.value = {p.x(), p.y(), p.z()};
    cartesian.std_dev = {0.01, 0.01, 0.01};
    return es::EncodePacket(cartesian);
  }

  std::vector<std::string> Answer(std::string_view bytes) {
    const auto d = es::DecodeRequest(bytes);
    EXPECT_TRUE(d.request) << d.why;
    if (!d.request) return {};
    received.push_back(*d.request);
    if (const auto* c = std::get_if<es::SetCoordinateSystemType>(&*d.request))
      coordinate_system = c->type;
    if (const auto* u = std::get_if<es::SetUnits>(&*d.request)) angle_unit = u->units.angle;
    const int32_t id = es::CommandOf(*d.request);
    std::vector<std::string> out;
    if (auto it = overrides.find(id); it != overrides.end()) {
      out = it->second();
    } else {
      es::CommandAnswer a{id, 0, {}};
      switch (id) {
        case es::GetSystemStatus::kCommand:
          a.data = es::SystemStatus{0, processor_status, 3, 2, 3, 6, 1234, 2, 0, 391234};
          break;
        case es::GetSystemSettings::kCommand: {
          es::SystemSettings s;
          s.apply_transformation = true;  // the driver must switch this off
          s.weather_monitor_status = 2;
          s.has_nivel = true;
          a.data = s;
          break;
        }
        case es::GetReflector::kCommand:
          a.data = es::Int32Value{3};
          break;
        case es::GetFace::kCommand:
          a.data = es::Int32Value{2};
          break;
        case es::GetEnvironmentParams::kCommand:
          a.data = es::EnvironmentParams{21.5, 1002.5, 38.0};
          break;
        case es::GetLongSystemParameter::kCommand:
          a.data = es::LongParameter{5002, 2};
          break;
        case es::GetReflectors::kCommand:
          out.push_back(es::EncodePacket(
              es::CommandAnswer{id, 0, es::ReflectorInfo{2, 1, 1, 0, "CCR 1.5in"}}));
          a.data = es::ReflectorInfo{2, 4, 4, 0, "RFI 0.5in"};
          break;
        default:
          break;
      }
      out.push_back(es::EncodePacket(a));
      if (id == es::StartMeasurement::kCommand) out.push_back(ResultPacket());
    }
    if (chunk == 0) return out;
    std::string all;
    for (const auto& p : out) all += p;
    std::vector<std::string> chunks;
    for (size_t at = 0; at < all.size(); at += chunk) chunks.push_back(all.substr(at, chunk));
    return chunks;
  }

  std::vector<int32_t> Commands() const {
    std::vector<int32_t> ids;
    for (const auto& r : received) ids.push_back(es::CommandOf(r));
    return ids;
  }
};

struct Rig {
  FakeTracker tracker;
  FakePacketTransport* transport = nullptr;
  std::unique_ptr<EmsconDevice> device;
  explicit Rig(EmsconOptions options = {}, RetryPolicy policy = EmsconFast()) {
    auto t = std::make_unique<FakePacketTransport>(
        [this](std::string_view request) { return tracker.Answer(request); }, "AT960 on fake");
    transport = t.get();
    t->Close();  // the driver opens it
    device = std::make_unique<EmsconDevice>(std::move(t), policy, options);
  }
};

int CodeOf(const std::function<void()>& call) {
  try {
    call();
  } catch (const InstrumentError& e) {
    return e.code();
  }
  ADD_FAILURE() << "expected an InstrumentError";
  return -1;
}

}  // namespace

TEST(EmsconDevice, ConnectSetsEveryStateExplicitlyInOrder) {
  Rig rig;
  rig.device->Connect();
  const std::vector<int32_t> expected = {es::SetUnits::kCommand,
                                         es::GetSystemStatus::kCommand,
                                         es::GetSystemSettings::kCommand,
                                         es::SetSystemSettings::kCommand,
                                         es::SetCoordinateSystemType::kCommand,
                                         es::SetMeasurementMode::kCommand,
                                         es::SetStationaryModeParams::kCommand,
                                         es::GetReflector::kCommand};
  EXPECT_EQ(rig.tracker.Commands(), expected);  // initialised: no Initialize
  const auto& r = rig.tracker.received;
  EXPECT_EQ(std::get<es::SetUnits>(r[0]).units,
            (es::Units{es::length_unit::kMillimeter, es::angle_unit::kRadian,
                       es::temperature_unit::kCelsius, es::pressure_unit::kMbar,
                       es::humidity_unit::kRelativeHumidity}));
  const auto& settings = std::get<es::SetSystemSettings>(r[3]).settings;
  EXPECT_FALSE(settings.apply_transformation);  // was on: results in the tracker's frame
  EXPECT_FALSE(settings.apply_station_orientation);
  EXPECT_TRUE(settings.send_unsolicited_messages);
  EXPECT_FALSE(settings.send_reflector_position);
  EXPECT_FALSE(settings.try_measurement_mode);
  EXPECT_EQ(settings.weather_monitor_status, 2);  // kept as read
  EXPECT_TRUE(settings.has_nivel);                // kept as read
  EXPECT_EQ(std::get<es::SetCoordinateSystemType>(r[4]).type, es::coordinate_system::kSCC);
  EXPECT_EQ(std::get<es::SetMeasurementMode>(r[5]).mode, es::meas_mode::kStationary);
  EXPECT_EQ(std::get<es::SetStationaryModeParams>(r[6]).meas_time_ms, 500);
  EXPECT_EQ(rig.device->reflector_id(), 3);
  // The first reading is read again in RHR (the convention self-check), then SCC is set
  // back.
  rig.tracker.received.clear();
  rig.device->Measure();
  EXPECT_EQ(rig.tracker.Commands(),
            (std::vector<int32_t>{
                es::StartMeasurement::kCommand, es::SetCoordinateSystemType::kCommand,
                es::StartMeasurement::kCommand, es::SetCoordinateSystemType::kCommand}));
  EXPECT_EQ(std::get<es::SetCoordinateSystemType>(rig.tracker.received[1]).type,
            es::coordinate_system::kRHR);
  EXPECT_EQ(std::get<es::SetCoordinateSystemType>(rig.tracker.received[3]).type,
            es::coordinate_system::kSCC);
  EXPECT_TRUE(rig.device->convention_checked());
  // Once set up and checked, a measurement is one command.
  rig.tracker.received.clear();
  rig.device->Measure();
  EXPECT_EQ(rig.tracker.Commands(), std::vector<int32_t>{es::StartMeasurement::kCommand});
}

// `armsig instrument probe` asks and changes nothing: no set-up before GetSystemStatus.
TEST(EmsconDevice, IdentifyChangesNothing) {
  Rig rig;
  const DeviceInfo info = rig.device->Identify();
  EXPECT_EQ(info.serial, "391234");
  EXPECT_EQ(rig.tracker.Commands(), std::vector<int32_t>{es::GetSystemStatus::kCommand});
  EXPECT_EQ(rig.device->statistics().configurations, 0);
}

TEST(EmsconDevice, InitializesOnlyAnUninitialisedTrackerOrWhenForced) {
  Rig cold;
  cold.tracker.processor_status = 3;  // Booted
  cold.device->Connect();
  EXPECT_EQ(cold.tracker.Commands()[2], es::Initialize::kCommand);
  EmsconOptions force;
  force.force_initialize = true;
  Rig forced(force);
  forced.device->Connect();
  EXPECT_EQ(forced.tracker.Commands()[2], es::Initialize::kCommand);
}

TEST(EmsconDevice, ReflectorByIdOrByName) {
  EmsconOptions by_id;
  by_id.reflector_id = 4;
  Rig a(by_id);
  a.device->Connect();
  EXPECT_EQ(std::get<es::SetReflector>(a.tracker.received.back()).reflector_id, 4);
  EmsconOptions by_name;
  by_name.reflector_name = "RFI 0.5in";
  Rig b(by_name);
  b.device->Connect();
  EXPECT_EQ(std::get<es::SetReflector>(b.tracker.received.back()).reflector_id, 4);
  EXPECT_EQ(b.device->reflector_id(), 4);
  by_name.reflector_name = "Glass prism";
  Rig c(by_name);
  try {
    c.device->Connect();
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("CCR 1.5in, RFI 0.5in"), std::string::npos) << e.what();
  }
}

// Result → reading: SCC values (Hz counter-clockwise from the tracker's +x, V the zenith
// angle, d) are the point d (sin V cos Hz, sin V sin Hz, cos V) of the tracker's frame; the
// reading's angles are the theodolite convention's of that point (Hz clockwise from +y:
// π/2 − Hz).
TEST(EmsconDevice, ReadingCarriesAnglesDistancePointSigmasAndEnvironment) {
  Rig rig;
  const auto before = std::chrono::system_clock::now();
  const Reading r = rig.device->Measure();
  EXPECT_NEAR(r.angles.hz_rad, std::numbers::pi / 2 - 1.25, 1e-12);
  EXPECT_NEAR(r.angles.v_rad, 1.5, 1e-12);
  EXPECT_EQ(r.angles.face, 1);
  ASSERT_TRUE(r.distance_mm);
  EXPECT_NEAR(*r.distance_mm, 4000.0, 1e-9);
  ASSERT_TRUE(r.point_in_instrument_mm);
  EXPECT_NEAR(r.point_in_instrument_mm->x(), 4000.0 * std::sin(1.5) * std::cos(1.25), 1e-9);
  EXPECT_NEAR(r.point_in_instrument_mm->y(), 4000.0 * std::sin(1.5) * std::sin(1.25), 1e-9);
  EXPECT_NEAR(r.point_in_instrument_mm->z(), 4000.0 * std::cos(1.5), 1e-9);
  ASSERT_TRUE(r.sigma);
  EXPECT_DOUBLE_EQ(r.sigma->hz_rad, 2e-6);
  EXPECT_DOUBLE_EQ(r.sigma->v_rad, 3e-6);
  EXPECT_DOUBLE_EQ(r.sigma->distance_mm, 0.01);
  ASSERT_TRUE(r.environment);
  EXPECT_EQ(r.environment->temperature_c, 21.5);
  EXPECT_EQ(r.environment->pressure_hpa, 1002.5);
  EXPECT_EQ(r.environment->humidity_percent, 38.0);
  EXPECT_GE(r.time, before);
  EXPECT_FALSE(rig.device->MeasureAngles().distance_mm);  // angles only, as asked
  EXPECT_TRUE(rig.device->MeasureDistanceAndAngles().distance_mm);
}

TEST(EmsconDevice, AnglesInDegreesWhenRadiansAreNotAvailable) {
  EmsconOptions degrees;
  degrees.angle_unit = es::angle_unit::kDegree;
  Rig rig(degrees);
  rig.tracker.result.value = {30.0, 45.0, 1000.0};
  rig.tracker.result.std_dev = {1e-4, 2e-4, 0.01};
  const Reading r = rig.device->Measure();
  EXPECT_EQ(std::get<es::SetUnits>(rig.tracker.received[0]).units.angle, es::angle_unit::kDegree);
  EXPECT_NEAR(r.angles.hz_rad, std::numbers::pi / 3, 1e-12);  // π/2 − 30°
  EXPECT_NEAR(r.angles.v_rad, std::numbers::pi / 4, 1e-12);
  EXPECT_DOUBLE_EQ(r.sigma->hz_rad, 1e-4 * std::numbers::pi / 180);
}

// Status changes, an unsolicited error about something else and a late reply to another
// command arrive between StartMeasurement and its result: recorded, never the answer.
TEST(EmsconDevice, AsynchronousPacketsBetweenCommandAndAnswerAreRecordedNotTaken) {
  Rig rig;
  rig.device->CheckConvention();  // set up, the first reading checked
  rig.tracker.overrides[es::StartMeasurement::kCommand] = [&] {
    return std::vector<std::string>{
        es::EncodePacket(es::StatusChange{es::status_change::kMeasStatusBusy}),
        es::EncodePacket(es::ErrorResponse{64, 10013}),  // unsolicited: SensorNotStable
        es::EncodePacket(es::CommandAnswer{es::GetFace::kCommand, 0, es::Int32Value{1}}),
        es::EncodePacket(es::CommandAnswer{es::StartMeasurement::kCommand, 0, {}}),
        es::EncodePacket(es::ReflectorPosition{0, {1, 2, 3}}),
        es::EncodePacket(es::StatusChange{es::status_change::kMeasStatusReady}),
        rig.tracker.ResultPacket()};
  };
  const Reading r = rig.device->Measure();
  EXPECT_DOUBLE_EQ(*r.distance_mm, 4000.0);
  const auto& s = rig.device->statistics();
  EXPECT_EQ(s.status_changes, 2);
  EXPECT_EQ(s.unsolicited_errors, 1);
  EXPECT_EQ(s.stale_answers, 1);
  EXPECT_EQ(s.position_packets, 1);
  ASSERT_EQ(rig.device->events().size(), 3u);
  EXPECT_EQ(rig.device->events()[1].kind, EmsconDevice::Event::Kind::kUnsolicitedError);
  EXPECT_EQ(rig.device->events()[1].value, 10013);
  EXPECT_EQ(rig.device->events()[2].value, es::status_change::kMeasStatusReady);
}

// The same, with every packet cut into 5-byte reads and then all of them in one read.
TEST(EmsconDevice, ResultsSplitAcrossReadsOrSharingOneRead) {
  for (size_t chunk : {size_t{5}, size_t{1}, size_t{100000}}) {
    Rig rig;
    rig.tracker.chunk = chunk;
    const Reading r = rig.device->Measure();
    EXPECT_NEAR(r.angles.hz_rad, std::numbers::pi / 2 - 1.25, 1e-12) << chunk;
    EXPECT_NEAR(*r.distance_mm, 4000.0, 1e-9) << chunk;
    if (chunk == 5) {
      EXPECT_GT(rig.transport->reads(), 40);
    }
  }
}

TEST(EmsconDevice, AnAnswerMustEchoTheCommandId) {
  Rig rig;
  // Every SetUnits is "answered" with another command's reply: never taken.
  rig.tracker.overrides[es::SetUnits::kCommand] = [] {
    return std::vector<std::string>{es::EncodePacket(es::CommandAnswer{10, 0, {}})};
  };
  try {
    rig.device->Measure();
    FAIL() << "expected InstrumentError";
  } catch (const InstrumentError& e) {
    EXPECT_EQ(e.code(), 3093) << e.what();  // COM_TR_ID_MISMATCH
    EXPECT_NE(std::string(e.what()).find("echoed other command ids"), std::string::npos);
  }
  EXPECT_EQ(rig.device->statistics().stale_answers, 3);  // one per attempt
}

TEST(EmsconDevice, ResultsThatAreNoReadingAreRefused) {
  struct Case {
    const char* what;
    std::function<void(es::MeasResult&)> spoil;
    int code;
  };
  const Case cases[] = {
      {"status", [](es::MeasResult& m) { m.status = es::status::kNoStationaryResult; }, 10009},
      {"continuous mode", [](es::MeasResult& m) { m.meas_mode = 1; }, 3074},
      {"try mode", [](es::MeasResult& m) { m.try_mode = true; }, 3074},
      {"NaN", [](es::MeasResult& m) { m.value[2] = std::nan(""); }, 3074},
      {"negative zenith angle", [](es::MeasResult& m) { m.value[1] = -0.5; }, 3074},
      {"Hz in gon", [](es::MeasResult& m) { m.value[0] = 350.0; }, 3074},
      {"negative distance", [](es::MeasResult& m) { m.value[2] = -1.0; }, 3074},
      {"negative sigma", [](es::MeasResult& m) { m.std_dev[0] = -1e-6; }, 3074},
      {"temperature in °F", [](es::MeasResult& m) { m.temperature = 95.0; }, 3074},
      {"pressure in kPa", [](es::MeasResult& m) { m.pressure = 101.3; }, 3074},
      {"humidity above 100 %", [](es::MeasResult& m) { m.humidity = 140.0; }, 3074},
  };
  for (const Case& c : cases) {
    Rig rig;
    c.spoil(rig.tracker.result);
    EXPECT_EQ(CodeOf([&] { rig.device->Measure(); }), c.code) << c.what;
  }
  // A temperature in °F that is no reading names what was expected.
  Rig rig;
  rig.tracker.result.temperature = 95.0;
  try {
    rig.device->Measure();
  } catch (const ReadingRangeError& e) {
    EXPECT_EQ(e.quantity(), "temperature");
    EXPECT_EQ(e.max(), 80.0);
  }
}

TEST(EmsconDevice, TrackerErrorsAreTypedWithTheirStatus) {
  Rig rig;
  rig.device->CheckConvention();  // set up, the first reading checked
  // Beam broken during the measurement: ErrorResponse for StartMeasurement.
  rig.tracker.overrides[es::StartMeasurement::kCommand] = [] {
    return std::vector<std::string>{
        es::EncodePacket(es::CommandAnswer{es::StartMeasurement::kCommand, 0, {}}),
        es::EncodePacket(es::ErrorResponse{es::StartMeasurement::kCommand, 37})};
  };
  try {
    rig.device->Measure();
    FAIL() << "expected InstrumentError";
  } catch (const InstrumentError& e) {
    EXPECT_EQ(e.code(), 37);
    EXPECT_NE(std::string(e.what()).find("ES_RS_NoDistanceSet"), std::string::npos) << e.what();
  }
  EXPECT_EQ(rig.device->statistics().retries, 0);  // a tracker's error is not retried
  // A reply with a failure status.
  rig.tracker.overrides[es::GoPosition::kCommand] = [] {
    return std::vector<std::string>{
        es::EncodePacket(es::CommandAnswer{es::GoPosition::kCommand, 13, {}})};
  };
  EXPECT_EQ(CodeOf([&] { rig.device->GoPosition({1000, 1000, 0}); }), 13);
}

TEST(EmsconDevice, ServerBusyIsRetriedThenTyped) {
  Rig rig;
  rig.device->CheckConvention();  // set up, the first reading checked
  int busy = 2;
  rig.tracker.overrides[es::StartMeasurement::kCommand] = [&]() -> std::vector<std::string> {
    if (busy-- > 0) {
      return {es::EncodePacket(es::CommandAnswer{es::StartMeasurement::kCommand, 1, {}})};
    }
    return {es::EncodePacket(es::CommandAnswer{es::StartMeasurement::kCommand, 0, {}}),
            rig.tracker.ResultPacket()};
  };
  EXPECT_DOUBLE_EQ(*rig.device->Measure().distance_mm, 4000.0);
  EXPECT_EQ(rig.device->statistics().busy, 2);
  busy = 100;
  EXPECT_EQ(CodeOf([&] { rig.device->Measure(); }), 1);  // ES_RS_ServerBusy
}

// A timeout, then silence: every attempt waits its share; the error names the timeout and
// an unsolicited error the tracker sent meanwhile.
TEST(EmsconDevice, SilenceTimesOutNamingAnUnsolicitedError) {
  Rig rig;
  rig.device->CheckConvention();  // set up, the first reading checked
  rig.tracker.overrides[es::StartMeasurement::kCommand] = [] {
    return std::vector<std::string>{
        es::EncodePacket(es::CommandAnswer{es::StartMeasurement::kCommand, 0, {}}),
        es::EncodePacket(es::ErrorResponse{64, 37})};  // beam broken, reported unsolicited
  };
  try {
    rig.device->Measure();
    FAIL() << "expected InstrumentError";
  } catch (const InstrumentError& e) {
    EXPECT_EQ(e.code(), 3077) << e.what();
    EXPECT_NE(std::string(e.what()).find("ES_RS_NoDistanceSet (37) unsolicited"), std::string::npos)
        << e.what();
  }
}

TEST(EmsconDevice, ALostConnectionIsReopenedAndSetUpAgain) {
  Rig rig;
  rig.device->Measure();
  EXPECT_EQ(rig.device->statistics().configurations, 1);
  rig.transport->Close();  // the server went away
  rig.device->Measure();
  EXPECT_EQ(rig.device->statistics().configurations, 2);
  EXPECT_EQ(rig.device->statistics().reconnects, 1);
  EXPECT_EQ(rig.transport->opens(), 2);
}

TEST(EmsconDevice, GoPositionSendsHzVDistanceOfThePoint) {
  Rig rig;
  const Eigen::Vector3d point(-1000.0, 0.0, 1000.0);  // along −x, 45° above the horizon
  rig.device->GoPosition(point);
  const auto& go = std::get<es::GoPosition>(rig.tracker.received.back());
  EXPECT_NEAR(go.val1, std::numbers::pi, 1e-12);         // SCC: atan2(0, −1000)
  EXPECT_NEAR(go.val2, 0.25 * std::numbers::pi, 1e-12);  // V 50 gon
  EXPECT_NEAR(go.val3, std::sqrt(2.0) * 1000.0, 1e-9);
  EXPECT_EQ(CodeOf([&] { rig.device->GoPosition({std::nan(""), 0, 0}); }), 3074);
}

// The first reading on a connection is read again in RHR: a tracker whose SCC values are
// not what the driver reads (here: Hz clockwise from +y, a theodolite's circle) is
// refused, naming both points and the reading that would match, and no reading comes
// from it; a tracker of the public convention passes.
TEST(EmsconDevice, TheSelfCheckRefusesATrackerOfAnotherSphericalConvention) {
  Rig rig;
  rig.tracker.wrong_convention = true;
  try {
    rig.device->Measure();
    FAIL() << "expected ConventionMismatch";
  } catch (const ConventionMismatch& e) {
    EXPECT_EQ(e.code(), 3074);
    const std::string what = e.what();
    EXPECT_NE(what.find("self-check failed"), std::string::npos) << what;
    // By the public convention, and as the RHR reading (the theodolite convention's point).
    const double sv = 4000.0 * std::sin(1.5);
    EXPECT_NE(what.find(fmt::format("({:.3f}, {:.3f},", sv * std::cos(1.25), sv * std::sin(1.25))),
              std::string::npos)
        << what;
    EXPECT_NE(what.find(fmt::format("({:.3f}, {:.3f},", sv * std::sin(1.25), sv * std::cos(1.25))),
              std::string::npos)
        << what;
    EXPECT_NE(what.find("read with Hz clockwise from +y"), std::string::npos) << what;
  }
  EXPECT_FALSE(rig.device->convention_checked());
  EXPECT_THROW(rig.device->Measure(), ConventionMismatch);  // checked again, refused again
  // The tracker is left in SCC.
  const auto& r = rig.tracker.received;
  const auto last = std::find_if(r.rbegin(), r.rend(), [](const es::Request& q) {
    return std::holds_alternative<es::SetCoordinateSystemType>(q);
  });
  ASSERT_NE(last, r.rend());
  EXPECT_EQ(std::get<es::SetCoordinateSystemType>(*last).type, es::coordinate_system::kSCC);
  rig.tracker.wrong_convention = false;
  EXPECT_NO_THROW(rig.device->Measure());
  EXPECT_TRUE(rig.device->convention_checked());
}

TEST(EmsconDevice, FaceCompensatorEnvironmentStatusAndReflectors) {
  Rig rig;
  EXPECT_EQ(rig.device->Face(), 2);
  EXPECT_TRUE(rig.device->CompensatorOn());
  const Environment e = rig.device->GetEnvironment();
  EXPECT_EQ(e.temperature_c, 21.5);
  EXPECT_EQ(e.pressure_hpa, 1002.5);
  const DeviceInfo info = rig.device->Identify();
  EXPECT_EQ(info.serial, "391234");
  EXPECT_EQ(info.firmware, "emScon 3.6.1234");
  const auto reflectors = rig.device->Reflectors();
  ASSERT_EQ(reflectors.size(), 2u);
  EXPECT_EQ(reflectors[1].name, "RFI 0.5in");
  rig.tracker.overrides[es::GetFace::kCommand] = [] {
    return std::vector<std::string>{
        es::EncodePacket(es::CommandAnswer{es::GetFace::kCommand, 0, es::Int32Value{0}})};
  };
  EXPECT_EQ(CodeOf([&] { rig.device->Face(); }), 3074);  // face unknown: no reading
}

TEST(EmsconDevice, InterruptEndsTheCall) {
  Rig rig;
  std::atomic<bool> stop{true};
  rig.device->SetInterrupt(&stop);
  try {
    rig.device->Measure();
    FAIL() << "expected an interrupt";
  } catch (const TransportError& e) {
    EXPECT_EQ(e.kind(), TransportError::Kind::kInterrupted);
  }
}

// The transport alone: a bad size field is kBadFrame and drops what was buffered.
TEST(FakePacketTransport, SplitsChunksIntoPacketsAndRefusesABrokenFraming) {
  const std::string ready = es::EncodePacket(es::StatusChange{27});
  FakePacketTransport t([&](std::string_view) {
    return std::vector<std::string>{ready.substr(0, 3), ready.substr(3) + ready,
                                    "\xff\xff\xff\x7f"};
  });
  t.Write("x", Clock::now());
  EXPECT_EQ(t.ReadPacket(Clock::now()), ready);
  EXPECT_EQ(t.ReadPacket(Clock::now()), ready);
  try {
    t.ReadPacket(Clock::now());
    FAIL() << "expected kBadFrame";
  } catch (const TransportError& e) {
    EXPECT_EQ(e.kind(), TransportError::Kind::kBadFrame);
    EXPECT_NE(std::string(e.what()).find("2147483647"), std::string::npos) << e.what();
  }
}

}  // namespace armsig::instruments
