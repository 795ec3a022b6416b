#include "simulation/emscon_simulator.h"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <numbers>
#include <stdexcept>
#include <type_traits>

#include "instruments/packet_transport.h"

namespace armsig::simulation {

namespace asio = boost::asio;
namespace es = instruments::emscon;
using tcp = asio::ip::tcp;

struct EmsconSimulator::Connection : FramedPeer {
  explicit Connection(asio::io_context& io) : FramedPeer(io, instruments::kEmsconFrames) {}
  bool flooding = false;  // one flood at a time
};

namespace {

// The reflectors this tracker knows (GetReflectors).
struct KnownReflector {
  int32_t id;
  int32_t target_type;  // ES_TargetType
  const char* name;
};
constexpr KnownReflector kReflectors[] = {
    {1, 1, "CCR 1.5in"}, {2, 5, "RRR 1.5in"}, {3, 6, "RRR 0.5in"}, {4, 4, "RFI 0.5in"}};

// An id whose reply this tracker never sends unasked (Park, or GoLastMeasuredPoint for Park).
int32_t OtherCommand(int32_t command) { return command == 10 ? 62 : 10; }

std::string Noise() { return std::string("\x13\xfe~#garbage\r\n\x07", 13); }

// A point (tracker frame, mm) as spherical values (Hz, V in rad, d in mm) of coordinate
// system type SCC or SCW, by `convention` (SphericalConvention), and back.
std::array<double, 3> SphericalOf(const Eigen::Vector3d& p, int32_t type,
                                  SphericalConvention convention) {
  const double d = p.norm();
  if (!(d > 0.0)) return {0.0, 0.0, 0.0};
  const double zenith = std::acos(std::clamp(p.z() / d, -1.0, 1.0));
  if (type == es::coordinate_system::kSCW) return {std::atan2(-p.y(), p.x()), zenith, d};
  switch (convention) {
    case SphericalConvention::kClockwiseFromY:
      return {std::atan2(p.x(), p.y()), zenith, d};
    case SphericalConvention::kElevation:
      return {std::atan2(p.y(), p.x()), std::asin(std::clamp(p.z() / d, -1.0, 1.0)), d};
    case SphericalConvention::kPublic:
      break;
  }
  const es::SphericalCcw scc = es::SccFromPoint(p);
  return {scc.hz_rad, scc.v_rad, scc.distance_mm};
}

Eigen::Vector3d PointOf(double hz, double v, double d, int32_t type,
                        SphericalConvention convention) {
  if (type == es::coordinate_system::kSCW) return es::PointFromScc({-hz, v, d});
  switch (convention) {
    case SphericalConvention::kClockwiseFromY:
      return es::PointFromSpherical({hz, v, d});
    case SphericalConvention::kElevation:
      return d *
             Eigen::Vector3d(std::cos(v) * std::cos(hz), std::cos(v) * std::sin(hz), std::sin(v));
    case SphericalConvention::kPublic:
      break;
  }
  return es::PointFromScc({hz, v, d});
}

}  // namespace

EmsconSimulator::EmsconSimulator(VirtualLab& lab, int station, std::string host,
                                 unsigned short port, EmsconSimulatorOptions options)
    : lab_(lab),
      station_(station),
      host_(std::move(host)),
      port_(port),
      address_(host_ + ":" + std::to_string(port)),
      options_(options),
      rng_(options.seed) {
  // Deliberately not armsig's: every one of these must be set by the client.
  state_.units = {es::length_unit::kMeter, es::angle_unit::kGon, es::temperature_unit::kFahrenheit,
                  es::pressure_unit::kMmHg, es::humidity_unit::kRelativeHumidity};
  state_.coordinate_system = es::coordinate_system::kRHR;
  state_.meas_mode = 1;  // ContinuousTime
  state_.meas_time_ms = 2500;
  state_.reflector = 1;
  state_.initialized = options.initialized;
  state_.settings.weather_monitor_status = 2;  // ReadAndCalculateRefractions
  state_.settings.apply_transformation = true;
  state_.settings.apply_station_orientation = true;
  state_.settings.send_reflector_position = true;
  state_.settings.has_nivel = true;
}

EmsconSimulator::~EmsconSimulator() { Stop(); }

std::chrono::milliseconds EmsconSimulator::Scaled(std::chrono::milliseconds latency) const {
  return std::chrono::milliseconds(
      static_cast<long>(std::llround(static_cast<double>(latency.count()) * options_.time_scale)));
}

double TrackerSigmaMm(const EmsconSimulatorOptions& options, double distance_mm) {
  return 0.5 * (options.mpe_constant_mm + options.mpe_per_metre_mm * distance_mm / 1000.0);
}

double EmsconSimulator::SigmaMm(double distance_mm) const { return TrackerSigmaMm(options_, distance_mm); }

double EmsconSimulator::Seconds() const {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count() *
         options_.environment_time_scale;
}

es::EnvironmentParams EmsconSimulator::WeatherAt(double t) {
  constexpr double kTwoPi = 2.0 * std::numbers::pi;
  return {20.0 + 0.3 * std::sin(kTwoPi * t / 3600.0) + 0.1 * t / 3600.0,
          1013.25 + 0.8 * std::sin(kTwoPi * t / 7200.0 + 1.0),
          45.0 + 2.0 * std::sin(kTwoPi * t / 5400.0 + 2.0)};
}

void EmsconSimulator::Start() {
  acceptor_ = ListenTcp(io_, host_, port_, "virtual tracker");
  port_ = acceptor_->local_endpoint().port();
  address_ = host_ + ":" + std::to_string(port_);
  start_ = std::chrono::steady_clock::now();
  work_.emplace(asio::make_work_guard(io_));
  StartAccept();
  thread_ = std::thread([this] { io_.run(); });
}

void EmsconSimulator::Stop() {
  if (!thread_.joinable()) return;
  asio::post(io_, [this] {
    boost::system::error_code ignored;
    if (acceptor_) acceptor_->close(ignored);
    if (connection_) connection_->Close();
    work_.reset();
  });
  io_.stop();
  thread_.join();
  // The io thread is gone: close what the posted handler may not have closed.
  boost::system::error_code ignored;
  if (acceptor_) acceptor_->close(ignored);
  if (connection_) connection_->Close();
}

void EmsconSimulator::InjectOnce(FaultSpec fault) { faults_.Once(fault); }

void EmsconSimulator::InjectAlways(FaultSpec fault) { faults_.Always(fault); }

void EmsconSimulator::ClearFaults() {
  faults_.Clear();
  ++flood_generation_;  // a flood stops at its next chunk
}

EmsconSimulator::State EmsconSimulator::state() const {
  std::lock_guard lock(mutex_);
  return state_;
}

Eigen::Vector3d EmsconSimulator::TruePointInTracker() const {
  const VirtualStation& s = lab_.station(station_);
  const Eigen::Vector3d x = lab_.TruePosition(lab_.AimedAt(station_));
  return s.pose.world_from_station.transpose() * (x - s.pose.position_mm);
}

namespace {
// How far a beam along `beam` (unit) passes from `point`, measured at the point; a point
// behind the tracker is never in the beam.
double MissOf(const Eigen::Vector3d& beam, const Eigen::Vector3d& point) {
  const double along = point.dot(beam);
  if (along <= 0.0) return std::numeric_limits<double>::infinity();
  return (point - along * beam).norm();
}
}  // namespace

double EmsconSimulator::BeamMissMm() const {
  const Eigen::Vector3d truth = TruePointInTracker();
  std::lock_guard lock(mutex_);
  return MissOf(state_.beam, truth);
}

void EmsconSimulator::GuideBeamToReflector() {
  const Eigen::Vector3d truth = TruePointInTracker();
  std::lock_guard lock(mutex_);
  if (truth.norm() > 0.0) state_.beam = truth.normalized();
  ++state_.guided;
}

void EmsconSimulator::DegradeNextMeasurements(int count, double noise_factor,
                                              double stated_factor) {
  std::lock_guard lock(mutex_);
  degraded_ = count;
  noise_factor_ = noise_factor;
  stated_factor_ = stated_factor;
}

void EmsconSimulator::StartAccept() {
  auto c = std::make_shared<Connection>(io_);
  acceptor_->async_accept(c->socket, [this, c](const boost::system::error_code& ec) {
    if (ec) {
      if (ec != asio::error::operation_aborted && acceptor_->is_open()) StartAccept();
      return;
    }
    if (connection_) connection_->Close();  // one client at a time, the newest wins
    connection_ = c;
    ++connections_;
    boost::system::error_code ignored;
    c->socket.set_option(tcp::no_delay(true), ignored);
    StartRead(c);
    StartAccept();
  });
}

void EmsconSimulator::StartRead(std::shared_ptr<Connection> c) {
  FramedPeer::ReadFrames(c, "virtual tracker",
                         [this, c](const std::string& frame) { OnFrame(c, frame); });
}

void EmsconSimulator::OnFrame(const std::shared_ptr<Connection>& c, const std::string& frame) {
  ++requests_;
  const FaultSpec fault = faults_.Next();
  switch (fault.fault) {
    case Fault::kVanish:
      c->Close();
      return;
    case Fault::kFloodBytes:
    case Fault::kEndlessLine:
    case Fault::kFloodLines:
      if (!c->flooding) {
        c->flooding = true;
        Flood(c, fault.fault == Fault::kFloodLines, fault.fault == Fault::kEndlessLine, 0,
              flood_generation_.load());
      }
      return;
    default:
      break;
  }
  const es::DecodedRequest decoded = es::DecodeRequest(frame);
  std::vector<Step> steps;
  if (decoded.request) {
    steps = Answer(*decoded.request, fault);
  } else if (decoded.command >= 0) {
    // A command this server does not model: NotImplemented, as emScon answers.
    steps.push_back(
        {Scaled(options_.command_latency),
         es::EncodePacket(es::CommandAnswer{decoded.command, es::status::kNotImplemented, {}})});
  } else {
    spdlog::debug("virtual tracker: ignored a packet that is no command: {}", decoded.why);
    return;
  }
  if (steps.empty() || fault.fault == Fault::kDropReply) return;
  switch (fault.fault) {
    case Fault::kNoiseBytes:
      steps.front().bytes = Noise() + steps.front().bytes;
      break;
    case Fault::kTruncateReply:
      steps.resize(1);
      steps.front().bytes.resize(steps.front().bytes.size() / 2);
      break;
    case Fault::kStatusInside: {
      std::string& b = steps.front().bytes;
      b = b.substr(0, es::kHeaderBytes) +
          es::EncodePacket(es::StatusChange{es::status_change::kMeasStatusReady}) +
          b.substr(es::kHeaderBytes);
      break;
    }
    default:
      break;
  }
  TcpPeer::Send(c, std::move(steps));
  bool start = false;
  {
    std::lock_guard lock(mutex_);
    std::swap(start, start_stream_);
  }
  if (start) StartStream(c);
}

// --- Continuous measurement -------------------------------------------------------------

// The continuous modes' commands (under the lock, FromTable's part for them).
void EmsconSimulator::ContinuousCommand(const es::Request& request, es::CommandAnswer& a,
                                        std::vector<std::string>& after) {
  const auto change = [&](int32_t value) { after.push_back(es::EncodePacket(es::StatusChange{value})); };
  if (std::holds_alternative<es::StopMeasurement>(request)) {
    ++stream_generation_;  // a stream that runs ends; none: nothing to stop, AllOK
  } else if (const auto* t = std::get_if<es::SetContinuousTimeModeParams>(&request)) {
    if (t->time_separation_ms < 1 || t->time_separation_ms > 100000 || t->number_of_points < 0) {
      a.status = es::status::kWrongParameter1;
    } else {
      continuous_time_ms_ = t->time_separation_ms;
      continuous_distance_mm_ = 0.0;
      change(19);  // ContinuousTimeModeParamsChanged
    }
  } else if (const auto* d = std::get_if<es::SetContinuousDistanceModeParams>(&request)) {
    const double mm = d->spatial_distance * *es::MillimetresPer(state_.units.length);
    if (!(mm > 0.0) || mm > 1e5 || d->number_of_points < 0) {
      a.status = es::status::kWrongParameter1;
    } else {
      continuous_distance_mm_ = mm;
      change(20);  // ContinuousDistanceModeParamsChanged
    }
  }
}

void EmsconSimulator::FollowArm(const VirtualArm* arm) {
  std::lock_guard lock(mutex_);
  arm_ = arm;
}

void EmsconSimulator::BreakBeam(double from_s, double to_s) {
  std::lock_guard lock(mutex_);
  beam_break_.emplace(from_s, to_s);
}

double EmsconSimulator::TrackerTime(double physical_s) const {
  return options_.clock_offset_s + (1.0 + options_.clock_drift_ppm * 1e-6) * physical_s;
}

double EmsconSimulator::PhysicalNow() const {
  if (arm_) return arm_->clock().Now();
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count() /
         std::max(options_.time_scale, 1e-3);
}

Eigen::Vector3d EmsconSimulator::TrackerPointAt(double physical_s) const {
  if (!arm_ || lab_.AimedAt(station_) != "robot") return TruePointInTracker();
  const VirtualStation& st = lab_.station(station_);
  const Eigen::Vector3d x = lab_.RobotTargetAt(arm_->At(physical_s).q);
  return st.pose.world_from_station.transpose() * (x - st.pose.position_mm);
}

// One record of the point at physical time t, in the client's units and coordinate type, with
// the model's noise, stamped with the tracker's clock then (under the lock).
es::MeasRecord EmsconSimulator::RecordAt(double physical_s) {
  const Eigen::Vector3d truth = TrackerPointAt(physical_s);
  std::normal_distribution<double> noise(0.0, SigmaMm(truth.norm()));
  const Eigen::Vector3d p = truth + Eigen::Vector3d(noise(rng_), noise(rng_), noise(rng_));
  const State& s = state_;
  const double mm = *es::MillimetresPer(s.units.length);
  const double rad = *es::RadiansPer(s.units.angle);
  es::MeasRecord r;
  if (s.coordinate_system == es::coordinate_system::kRHR) {
    for (int i = 0; i < 3; ++i) r.value[i] = p[i] / mm;
  } else {
    const auto [hz, v, d] = SphericalOf(p, s.coordinate_system, options_.scc_convention);
    r.value = {hz / rad, v / rad, d / mm};
  }
  es::SetTime(r, TrackerTime(physical_s));
  last_streamed_ = truth;
  return r;
}

void EmsconSimulator::StartStream(const std::shared_ptr<Connection>& c) {
  const uint64_t generation = ++stream_generation_;
  {
    std::lock_guard lock(mutex_);
    next_sample_s_ = PhysicalNow();
    last_streamed_.reset();
    broken_now_ = false;
  }
  StreamTick(c, generation);
}

// Every tick (5 ms of wall time) the records due since the last: time-triggered at every
// separation of the tracker's clock, distance-triggered whenever the point has travelled the
// distance (looked at every physical millisecond), in packets of at most 500 records.
void EmsconSimulator::StreamTick(std::shared_ptr<Connection> c, uint64_t generation) {
  if (c->closed || generation != stream_generation_.load()) return;
  std::vector<Step> steps;
  std::vector<es::MeasRecord> records;
  es::MultiMeasResult head;
  const auto flush = [&] {
    if (records.empty()) return;
    es::MultiMeasResult m = head;
    m.records = std::move(records);
    records.clear();
    continuous_records_ += static_cast<int>(m.records.size());
    steps.push_back({std::chrono::microseconds(0), es::EncodePacket(m)});
  };
  {
    std::lock_guard lock(mutex_);
    const double now = PhysicalNow();
    const State& s = state_;
    head.meas_mode = s.meas_mode;
    const auto w = WeatherAt(Seconds());
    head.temperature = *es::FromCelsius(w.temperature, s.units.temperature);
    head.pressure = *es::FromHectopascal(w.pressure, s.units.pressure);
    head.humidity = w.humidity;
    const double drift = 1.0 + options_.clock_drift_ppm * 1e-6;
    // Time-triggered: evenly spaced on the tracker's clock.
    const double step_s = continuous_distance_mm_ > 0.0 ? 1e-3 : continuous_time_ms_ * 1e-3 / drift;
    while (next_sample_s_ <= now) {
      const double t = next_sample_s_;
      next_sample_s_ += step_s;
      const bool broken = beam_break_ && t >= beam_break_->first && t < beam_break_->second;
      if (broken != broken_now_) {
        flush();
        broken_now_ = broken;
        steps.push_back(
            {std::chrono::microseconds(0),
             broken ? es::EncodePacket(es::ErrorResponse{es::StartMeasurement::kCommand,
                                                         es::status::kNoDistanceSet}) +
                          es::EncodePacket(es::StatusChange{es::status_change::kMeasStatusNotReady})
                    : es::EncodePacket(es::StatusChange{es::status_change::kMeasStatusReady})});
        last_streamed_.reset();
      }
      if (broken) {
        if (continuous_distance_mm_ <= 0.0) ++records_broken_;
        continue;
      }
      if (continuous_distance_mm_ > 0.0 && last_streamed_ &&
          (TrackerPointAt(t) - *last_streamed_).norm() < continuous_distance_mm_) {
        continue;
      }
      records.push_back(RecordAt(t));
      if (records.size() >= 500) flush();
    }
    flush();
  }
  if (!steps.empty()) TcpPeer::Send(c, std::move(steps));
  if (!stream_timer_) stream_timer_.emplace(io_);
  stream_timer_->expires_after(std::chrono::milliseconds(5));
  stream_timer_->async_wait([this, c, generation](const boost::system::error_code& ec) {
    if (!ec) StreamTick(c, generation);
  });
}

// One decoded request to the packets it answers with: the faults that answer instead, the
// protocol's table (FromTable), a measurement's sequence (MeasurementSteps), the faults that
// reorder the packets (InterleaveStatus).
std::vector<EmsconSimulator::Step> EmsconSimulator::Answer(const es::Request& request,
                                                           const FaultSpec& fault) {
  const int32_t id = es::CommandOf(request);
  const auto latency = Scaled(options_.command_latency);
  if (fault.fault == Fault::kBusy) {
    return {{latency, es::EncodePacket(es::CommandAnswer{id, es::status::kServerBusy, {}})}};
  }
  if (fault.fault == Fault::kErrorCode) {
    const int32_t code = fault.code != 0 ? fault.code : es::status::kTrackerNotInitialized;
    return {{latency, es::EncodePacket(es::ErrorResponse{id, code})}};
  }
  TableAnswer t = FromTable(request, id, latency, fault);
  es::CommandAnswer& a = t.answer;
  std::vector<std::string>& after = t.after;
  std::vector<Step> steps = std::move(t.before);
  const bool wrong_id = fault.fault == Fault::kWrongCommandId;
  if (wrong_id) a.command = OtherCommand(id);
  if (!t.measured) {
    steps.push_back({t.latency, es::EncodePacket(a)});
  } else {
    MeasurementSteps(a, fault, wrong_id, steps, after);
  }
  if (fault.fault == Fault::kStatusBetween) steps = InterleaveStatus(std::move(steps));
  for (auto& bytes : after) steps.push_back({std::chrono::milliseconds(0), std::move(bytes)});
  return steps;
}

// The protocol's table: one branch per emScon command (an `if constexpr` per request type),
// each a few lines, read side by side with the emScon TPI manual and
// instruments/emscon_codec.h; the tracker's state under its lock.
// Under the lock: the beam to a GoPosition in the set-up's units and coordinate system.
void EmsconSimulator::PointBeam(const es::GoPosition& r) {
  State& s = state_;
  const double mm = *es::MillimetresPer(s.units.length);
  const double rad = *es::RadiansPer(s.units.angle);
  if (s.coordinate_system == es::coordinate_system::kRHR) {
    s.go_position_mm = Eigen::Vector3d(r.val1, r.val2, r.val3) * mm;
  } else {
    s.go_position_mm = PointOf(r.val1 * rad, r.val2 * rad, r.val3 * mm, s.coordinate_system,
                               options_.scc_convention);
  }
  if (s.go_position_mm->norm() > 0.0) s.beam = s.go_position_mm->normalized();
  ++s.go_positions;
}

// Under the lock: FindReflector's search around the beam; false when the reflector is not
// within the search radius (or a planted fault hides it).
bool EmsconSimulator::SearchReflector(const FaultSpec& fault) {
  State& s = state_;
  ++s.searches;
  const Eigen::Vector3d truth = TruePointInTracker();
  const bool near =
      options_.acquire_radius_mm <= 0.0 || MissOf(s.beam, truth) <= options_.search_radius_mm;
  if (fault.fault == Fault::kReflectorNotFound || !near) {
    ++s.not_found;
    return false;
  }
  if (truth.norm() > 0.0) s.beam = truth.normalized();
  ++s.found;
  return true;
}

EmsconSimulator::TableAnswer EmsconSimulator::FromTable(const es::Request& request, int32_t id,
                                                        std::chrono::milliseconds latency,
                                                        const FaultSpec& fault) {
  TableAnswer t{{id, es::status::kAllOk, {}}, latency, false, {}, {}};
  std::vector<Step>& steps = t.before;
  es::CommandAnswer& a = t.answer;
  auto& reply_latency = t.latency;
  bool& measured = t.measured;
  std::vector<std::string>& after = t.after;
  {
    std::lock_guard lock(mutex_);
    State& s = state_;
    const auto change = [&](int32_t value) {
      after.push_back(es::EncodePacket(es::StatusChange{value}));
    };
    std::visit(
        [&](const auto& r) {
          using T = std::decay_t<decltype(r)>;
          if constexpr (std::is_same_v<T, es::Initialize>) {
            s.initialized = true;
            reply_latency = Scaled(options_.initialize_latency);
            change(es::status_change::kInitializationStatusChanged);
          } else if constexpr (std::is_same_v<T, es::GetSystemStatus>) {
            a.data = es::SystemStatus{0,    s.initialized ? 5 : 3,
                                      3,    2,
                                      3,    6,
                                      1234, s.settings.weather_monitor_status,
                                      0,    391234};
          } else if constexpr (std::is_same_v<T, es::SetUnits>) {
            const auto& u = r.units;
            if (!es::MillimetresPer(u.length) || !es::RadiansPer(u.angle) ||
                !es::ToCelsius(0.0, u.temperature) || !es::ToHectopascal(0.0, u.pressure) ||
                u.humidity != es::humidity_unit::kRelativeHumidity) {
              a.status = es::status::kWrongParameter;
            } else {
              s.units = u;
              change(es::status_change::kUnitsChanged);
            }
          } else if constexpr (std::is_same_v<T, es::SetEnvironmentParams>) {
            // The weather station keeps measuring.
            change(es::status_change::kEnvironmentParamsChanged);
          } else if constexpr (std::is_same_v<T, es::GetEnvironmentParams>) {
            const auto w = WeatherAt(Seconds());
            a.data = es::EnvironmentParams{*es::FromCelsius(w.temperature, s.units.temperature),
                                           *es::FromHectopascal(w.pressure, s.units.pressure),
                                           w.humidity};
          } else if constexpr (std::is_same_v<T, es::SetMeasurementMode>) {
            const bool continuous = r.mode == es::meas_mode::kContinuousTime ||
                                    r.mode == es::meas_mode::kContinuousDistance;
            if (r.mode != es::meas_mode::kStationary &&
                !(continuous && options_.continuous_modes)) {
              a.status = es::status::kNotImplemented;  // AT4xx: stationary only
            } else {
              s.meas_mode = r.mode;
              change(es::status_change::kMeasurementModeChanged);
            }
          } else if constexpr (std::is_same_v<T, es::SetCoordinateSystemType>) {
            if (r.type == es::coordinate_system::kRHR || r.type == es::coordinate_system::kSCW ||
                r.type == es::coordinate_system::kSCC) {
              s.coordinate_system = r.type;
              change(es::status_change::kCoordinateSystemTypeChanged);
            } else {
              a.status = r.type >= 0 && r.type <= 7 ? es::status::kNotImplemented
                                                    : es::status::kWrongParameter;
            }
          } else if constexpr (std::is_same_v<T, es::SetStationaryModeParams>) {
            if (r.meas_time_ms < 1 || r.meas_time_ms > 100000) {
              a.status = es::status::kWrongParameter1;
            } else {
              s.meas_time_ms = r.meas_time_ms;
              s.use_adm = r.use_adm;
              change(es::status_change::kStationaryModeParamsChanged);
            }
          } else if constexpr (std::is_same_v<T, es::SetReflector>) {
            bool known = false;
            for (const auto& k : kReflectors) known = known || k.id == r.reflector_id;
            if (known) {
              s.reflector = r.reflector_id;
              change(es::status_change::kReflectorChanged);
            } else {
              a.status = es::status::kWrongParameter1;
            }
          } else if constexpr (std::is_same_v<T, es::GetReflector>) {
            a.data = es::Int32Value{s.reflector};
          } else if constexpr (std::is_same_v<T, es::GetReflectors>) {
            const auto n = static_cast<int32_t>(std::size(kReflectors));
            for (int32_t i = 0; i + 1 < n; ++i) {  // all but the last; `a` is the last
              const auto& k = kReflectors[i];
              steps.push_back(
                  {latency, es::EncodePacket(es::CommandAnswer{
                                id, 0, es::ReflectorInfo{n, k.id, k.target_type, 0.0, k.name}})});
            }
            const auto& k = kReflectors[n - 1];
            a.data = es::ReflectorInfo{n, k.id, k.target_type, 0.0, k.name};
          } else if constexpr (std::is_same_v<T, es::SetSystemSettings>) {
            s.settings = r.settings;
            change(es::status_change::kSystemSettingsChanged);
          } else if constexpr (std::is_same_v<T, es::GetSystemSettings>) {
            a.data = s.settings;
          } else if constexpr (std::is_same_v<T, es::StartMeasurement>) {
            if (s.meas_mode == es::meas_mode::kStationary) {
              measured = true;
            } else if (!s.initialized) {
              a.status = es::status::kTrackerNotInitialized;
            } else {
              start_stream_ = true;  // the records follow the reply (OnFrame)
            }
          } else if constexpr (std::is_same_v<T, es::StopMeasurement> ||
                               std::is_same_v<T, es::SetContinuousTimeModeParams> ||
                               std::is_same_v<T, es::SetContinuousDistanceModeParams>) {
            ContinuousCommand(r, a, after);
          } else if constexpr (std::is_same_v<T, es::ChangeFace>) {
            s.face = 3 - s.face;
            lab_.SetFace(station_, s.face);
            reply_latency = Scaled(options_.motion_latency);
            change(s.face == 1 ? es::status_change::kIsFace1 : es::status_change::kIsFace2);
          } else if constexpr (std::is_same_v<T, es::GoPosition>) {
            PointBeam(r);
            reply_latency = Scaled(options_.motion_latency);
          } else if constexpr (std::is_same_v<T, es::FindReflector>) {
            reply_latency = Scaled(options_.motion_latency);
            if (!SearchReflector(fault)) a.status = es::status::kMeasurementStatusNotReady;
          } else if constexpr (std::is_same_v<T, es::GetFace>) {
            a.data = es::Int32Value{s.face};
          } else if constexpr (std::is_same_v<T, es::GetLongSystemParameter>) {
            if (r.parameter == es::system_parameter::kInclinationSensorState) {
              a.data = es::LongParameter{r.parameter, 2};  // apply corrections
            } else {
              a.status = es::status::kNotImplemented;
            }
          }
        },
        request);
    if (a.status != es::status::kAllOk) a.data = std::monostate{};
  }
  return t;
}

// A measurement's sequence: refused (not initialised, no reflector in the beam), or accepted
// and its result after the measuring time (a beam break instead, under that fault).
void EmsconSimulator::MeasurementSteps(es::CommandAnswer a, const FaultSpec& fault, bool wrong_id,
                                       std::vector<Step>& steps, std::vector<std::string>& after) {
  const auto latency = Scaled(options_.command_latency);
  int32_t meas_time = 0;
  bool initialized = false;
  const bool out_of_beam = options_.acquire_radius_mm > 0.0 &&
                           BeamMissMm() > options_.acquire_radius_mm;
  {
    std::lock_guard lock(mutex_);
    meas_time = state_.meas_time_ms;
    initialized = state_.initialized;
    if (out_of_beam && initialized) ++state_.not_found;
  }
  if (!initialized) {
    a.status = es::status::kTrackerNotInitialized;
    steps.push_back({latency, es::EncodePacket(a)});
  } else if (fault.fault == Fault::kReflectorNotFound || out_of_beam) {
    steps.push_back(
        {latency, es::EncodePacket(es::StatusChange{es::status_change::kMeasStatusNotReady})});
    a.status = es::status::kMeasurementStatusNotReady;
    steps.push_back({std::chrono::milliseconds(0), es::EncodePacket(a)});
  } else {
    steps.push_back({latency, es::EncodePacket(a)});  // accepted
    const auto measuring = Scaled(std::chrono::milliseconds(meas_time));
    if (fault.fault == Fault::kBeamBreak) {
      steps.push_back(
          {measuring, es::EncodePacket(es::ErrorResponse{es::StartMeasurement::kCommand,
                                                         es::status::kNoDistanceSet})});
      after.push_back(es::EncodePacket(es::StatusChange{es::status_change::kMeasStatusNotReady}));
    } else if (!wrong_id) {
      steps.push_back(
          {measuring, es::EncodePacket(MeasureNow(fault.fault == Fault::kOutOfRange))});
      after.push_back(es::EncodePacket(es::StatusChange{es::status_change::kMeasStatusReady}));
    }
  }
}

// Fault::kStatusBetween: before the reply a status change and an unsolicited error about
// something else; the reply's header and body in two writes; between the reply and the
// result another status change.
std::vector<EmsconSimulator::Step> EmsconSimulator::InterleaveStatus(std::vector<Step> steps) {
  std::vector<Step> mixed;
  mixed.push_back({steps.front().delay,
                   es::EncodePacket(es::StatusChange{es::status_change::kMeasStatusBusy}) +
                       es::EncodePacket(es::ErrorResponse{64, es::status::kSensorNotStable})});
  const std::string& reply = steps.front().bytes;
  mixed.push_back({std::chrono::milliseconds(0), reply.substr(0, es::kHeaderBytes)});
  mixed.push_back({std::chrono::milliseconds(5), reply.substr(es::kHeaderBytes)});
  for (size_t i = 1; i < steps.size(); ++i) {
    mixed.push_back({std::chrono::milliseconds(0),
                     es::EncodePacket(es::StatusChange{es::status_change::kMeasStatusReady})});
    mixed.push_back(std::move(steps[i]));
  }
  return mixed;
}

es::MeasResult EmsconSimulator::MeasureNow(bool out_of_range) {
  const Eigen::Vector3d truth = TruePointInTracker();
  std::lock_guard lock(mutex_);
  const State& s = state_;
  ++state_.measurements;
  if (truth.norm() > 0.0) state_.beam = truth.normalized();  // locked on the reflector
  double noise_factor = 1.0, stated_factor = 1.0;
  if (degraded_ > 0) {
    --degraded_;
    noise_factor = noise_factor_;
    stated_factor = stated_factor_;
  }
  const double stated = SigmaMm(truth.norm()) * stated_factor;
  std::normal_distribution<double> noise(0.0, SigmaMm(truth.norm()) * noise_factor);
  Eigen::Vector3d p = truth + Eigen::Vector3d(noise(rng_), noise(rng_), noise(rng_));
  if (s.settings.apply_transformation) p.x() += kUserTransformationShiftMm;
  const double mm = *es::MillimetresPer(s.units.length);
  const double rad = *es::RadiansPer(s.units.angle);
  es::MeasResult m;
  m.meas_mode = s.meas_mode;
  m.try_mode = s.settings.try_measurement_mode;
  if (s.coordinate_system == es::coordinate_system::kRHR) {
    for (int i = 0; i < 3; ++i) {
      m.value[i] = p[i] / mm;
      m.std_dev[i] = stated / mm;
    }
  } else {
    const auto [hz, v, d] = SphericalOf(p, s.coordinate_system, options_.scc_convention);
    const double sin_zenith = std::sqrt(std::max(0.0, 1.0 - std::pow(p.z() / d, 2)));
    m.value = {hz / rad, v / rad, d / mm};
    m.std_dev = {stated / (d * sin_zenith) / rad, stated / d / rad, stated / mm};
  }
  if (out_of_range) m.value[1] = -m.value[1];
  m.std_total = std::sqrt(3.0) * stated / mm;
  m.apriori_std = m.std_dev;
  m.apriori_std_total = m.std_total;
  const auto w = WeatherAt(Seconds());
  m.temperature = *es::FromCelsius(w.temperature, s.units.temperature);
  m.pressure = *es::FromHectopascal(w.pressure, s.units.pressure);
  m.humidity = w.humidity;
  return m;
}

void EmsconSimulator::Flood(std::shared_ptr<Connection> c, bool packets, bool printable, int64_t k,
                            uint64_t generation) {
  if (c->closed || generation != flood_generation_.load()) {
    c->flooding = false;
    return;
  }
  auto data = std::make_shared<std::string>();
  if (packets) {
    // Status changes and reflector positions: the protocol's own packets, never a reply.
    while (data->size() + 48 <= 4096) {
      *data += es::EncodePacket(es::StatusChange{k % 2 == 0 ? 26 : 27});
      *data += es::EncodePacket(
          es::ReflectorPosition{0, {1.0, 1.5, 2000.0 + static_cast<double>(k % 100)}});
    }
  } else {
    data->resize(4096);
    uint32_t x = static_cast<uint32_t>(k) * 2654435761u + 12345u;
    for (char& ch : *data) {
      x = x * 1664525u + 1013904223u;
      ch = printable ? static_cast<char>('A' + (x >> 24) % 26) : static_cast<char>(x >> 24);
    }
  }
  FloodChunk(std::move(c), std::move(data), 0, packets, printable, k, generation);
}

// One write_some at a time, so flood_bytes() counts what the connection took as it takes it.
void EmsconSimulator::FloodChunk(std::shared_ptr<Connection> c, std::shared_ptr<std::string> data,
                                 size_t offset, bool packets, bool printable, int64_t k,
                                 uint64_t generation) {
  if (c->closed || generation != flood_generation_.load()) {
    c->flooding = false;
    return;
  }
  c->socket.async_write_some(asio::buffer(data->data() + offset, data->size() - offset),
                             [this, c, data, offset, packets, printable, k, generation](
                                 const boost::system::error_code& ec, size_t n) {
                               flood_bytes_ += static_cast<int64_t>(n);
                               if (ec) {
                                 c->flooding = false;
                                 return;
                               }
                               if (offset + n < data->size()) {
                                 FloodChunk(c, data, offset + n, packets, printable, k, generation);
                               } else {
                                 Flood(c, packets, printable, k + 1, generation);
                               }
                             });
}

}  // namespace armsig::simulation
