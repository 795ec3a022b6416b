#include "instruments/emscon_device.h"

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <stdexcept>

#include "core/error.h"
#include "core/plausibility.h"
#include "core/text.h"
#include "instruments/line_retry.h"

namespace armsig::instruments {

namespace es = emscon;

namespace {

// What a tracker's weather station or its operator may plausibly report; beyond it the
// result is no reading (another unit than the one set, or garbage).
constexpr double kMinTemperatureC = -40.0, kMaxTemperatureC = 80.0;
constexpr double kMinPressureHpa = 300.0, kMaxPressureHpa = 1200.0;
constexpr double kMinHumidity = 0.0, kMaxHumidity = 100.0;

// A tracker's result arrives after its measurement time; an attempt never waits less than
// that plus this margin (still never past the call's deadline).
constexpr Millis kMeasurementMargin{200};

// The convention self-check's tolerance: two readings of one still reflector agree to the
// tracker's accuracy (about 10 µm per metre); a wrong convention moves the point by a good
// part of its distance (a mirror image), so the check allows 2 mm per metre (turbulent
// air, a reflector not quite still), at least 0.5 mm, or 10 stated sigmas if more.
constexpr double kConventionToleranceMm = 0.5;
constexpr double kConventionTolerancePerMm = 2e-3;

std::string CodeText(int code) {
  // Transport failures carry GeoCOM client codes, tracker answers emScon statuses.
  if (code >= 3000 && code < 3200) return geocom::CodeName(code);
  return es::StatusName(code);
}

bool Finite(const std::array<double, 3>& v) {
  return std::all_of(v.begin(), v.end(), [](double x) { return std::isfinite(x); });
}

}  // namespace

EmsconDevice::EmsconDevice(std::unique_ptr<PacketTransport> transport, RetryPolicy policy,
                           EmsconOptions options)
    : transport_(std::move(transport)), policy_(policy), options_(std::move(options)) {
  if (!es::RadiansPer(options_.angle_unit)) {
    throw std::invalid_argument("EmsconOptions::angle_unit " + std::to_string(options_.angle_unit) +
                                " is no ES_AngleUnit");
  }
}

void EmsconDevice::Record(Event::Kind kind, int32_t value, int32_t command) {
  Event e{kind, value, command, std::chrono::system_clock::now()};
  if (kind == Event::Kind::kStatusChange) {
    ++stats_.status_changes;
    spdlog::debug("{}: status change {} ({})", name(), es::StatusChangeName(value), value);
  } else {
    ++stats_.unsolicited_errors;
    last_unsolicited_ = e;
    spdlog::info("{}: unsolicited error {} ({}) for {}", name(), es::StatusName(value), value,
                 es::CommandName(command));
  }
  events_.push_back(e);
  if (events_.size() > kMaxEvents) events_.pop_front();
}

void EmsconDevice::ThrowStatus(int32_t command, int32_t status, const char* how) const {
  const std::string advice = es::StatusAdvice(status);
  throw InstrumentError(name(), status,
                        fmt::format("{} {} {} ({}){}", es::CommandName(command), how,
                                    es::StatusName(status), status,
                                    advice.empty() ? std::string() : ": " + advice));
}

std::optional<es::Packet> EmsconDevice::NextPacket(Deadline until) {
  const std::string frame = transport_->ReadPacket(until);
  const es::DecodedPacket decoded = es::DecodePacket(frame);
  if (decoded.error) {
    ++stats_.undecodable;
    spdlog::debug("{}: skipped a packet ({}): {}", name(), es::ToString(*decoded.error),
                  decoded.why);
    return std::nullopt;
  }
  const es::Packet& p = *decoded.packet;
  if (const auto* s = std::get_if<es::StatusChange>(&p)) {
    Record(Event::Kind::kStatusChange, s->change, 0);
    return std::nullopt;
  }
  if (std::holds_alternative<es::ReflectorPosition>(p)) {
    ++stats_.position_packets;
    return std::nullopt;
  }
  return p;
}

void EmsconDevice::FailUnlessUnsolicited(const es::ErrorResponse& e, int32_t id) {
  if (e.command != id) {
    Record(Event::Kind::kUnsolicitedError, e.status, e.command);
    return;
  }
  if (e.status == es::status::kServerBusy) throw Busy{es::CommandName(id)};
  ThrowStatus(id, e.status, "failed:");
}

es::CommandAnswer EmsconDevice::Exchange(const es::Request& request, Deadline until) {
  const int32_t id = es::CommandOf(request);
  ++stats_.commands;
  last_sent_ = id;
  transport_->Write(es::EncodeRequest(request), until);
  for (;;) {
    const auto packet = NextPacket(until);
    if (!packet) continue;
    if (const auto* a = std::get_if<es::CommandAnswer>(&*packet)) {
      if (a->command != id) {
        ++stats_.stale_answers;  // a late reply to an earlier command: not ours
        ++stale_in_call_;
        spdlog::debug("{}: skipped a reply to {} while waiting for {}", name(),
                      es::CommandName(a->command), es::CommandName(id));
        continue;
      }
      if (a->status == es::status::kServerBusy) throw Busy{es::CommandName(id)};
      if (a->status != es::status::kAllOk) ThrowStatus(id, a->status, "answered");
      return *a;
    }
    if (const auto* e = std::get_if<es::ErrorResponse>(&*packet)) {
      FailUnlessUnsolicited(*e, id);
      continue;
    }
    if (in_flight_) {  // stopping a continuous measurement: its last records
      if (const auto* m = std::get_if<es::MultiMeasResult>(&*packet)) {
        DeliverRecords(*m, *in_flight_);
        continue;
      }
    }
    ++stats_.stale_results;  // a measurement result nobody asked for now
  }
}

template <typename F>
auto EmsconDevice::WithRetries(int32_t command, Deadline deadline, F&& attempt, bool set_up) {
  const std::string what = command >= 0 ? es::CommandName(command) : "set-up";
  const auto start = Clock::now();
  std::string last = "no attempt before the deadline";
  int code = grc::kComTimedOut;
  int made = 0;
  last_unsolicited_.reset();
  last_sent_ = -1;
  for (; made < policy_.attempts && Clock::now() < deadline; ++made) {
    if (made > 0) ++stats_.retries;
    stale_in_call_ = 0;
    const Deadline until = AttemptDeadline(deadline, policy_.attempts - made);
    try {
      // Initialize's own time (a cold tracker) does not count against the call.
      const Clock::duration initializing = EnsureReady(until, set_up);
      deadline += initializing;
      call_deadline_ = deadline;
      return attempt(until + initializing);
    } catch (const Busy& b) {
      ++stats_.busy;
      last = b.what + " answered ES_RS_ServerBusy (1)";
      code = es::status::kServerBusy;
      transport_->Pause(policy_.busy_delay, deadline);
    } catch (const TransportError& e) {
      if (e.kind() == TransportError::Kind::kInterrupted) throw;
      last = e.message();
      code = CodeOf(e);
      spdlog::debug("{}: {} attempt {} of {} failed: {}", name(), what, made + 1, policy_.attempts,
                    last);
      if (e.kind() == TransportError::Kind::kTimeout && stale_in_call_ > 0) {
        last = fmt::format("{} {} echoed other command ids", stale_in_call_,
                           stale_in_call_ == 1 ? "reply" : "replies");
        code = grc::kComTrIdMismatch;  // answers, but none to this command
      }
      if (e.kind() == TransportError::Kind::kBadFrame) ++stats_.bad_frames;
      if (e.kind() == TransportError::Kind::kTimeout ||
          e.kind() == TransportError::Kind::kBadFrame) {
        // No transaction ids: clear a late answer or the rest of a broken stream before
        // asking again (never for long on a flooding connection).
        try {
          transport_->Drain(Millis(50), std::min(deadline, Clock::now() + kMaxDrain));
        } catch (const TransportError& d) {
          if (d.kind() == TransportError::Kind::kInterrupted) throw;
          transport_->Close();
        }
      } else {
        transport_->Close();
        transport_->Pause(policy_.reconnect_delay, deadline);
      }
    }
  }
  if (last_unsolicited_) {
    last += fmt::format("; the tracker reported {} ({}) unsolicited",
                        es::StatusName(last_unsolicited_->value), last_unsolicited_->value);
  }
  if (last_sent_ >= 0 && last_sent_ != command) {
    last += " (last command sent: " + es::CommandName(last_sent_) + ", in the set-up)";
  }
  throw InstrumentError(name(), code,
                        what + ": " + CodeText(code) + ": " + GaveUp(made, start, last));
}

Clock::duration EmsconDevice::EnsureReady(Deadline deadline, bool set_up) {
  if (!transport_->IsOpen()) {
    configured_ = false;
    transport_->Open();
    if (opened_before_) ++stats_.reconnects;
    opened_before_ = true;
    transport_->Drain(Millis(20), std::min(deadline, Clock::now() + Millis(20)));
  }
  if (!set_up || configured_) return Clock::duration::zero();
  return Configure(deadline);
}

Clock::duration EmsconDevice::Configure(Deadline deadline) {
  // The set-up sequence shares the call's deadline (it is part of the exchange), except
  // Initialize, which moves the head and has its own: the time it took is added to the
  // deadline and returned.
  es::Units units;  // mm, the chosen angle unit, °C, mbar (= hPa), %RH
  units.angle = options_.angle_unit;
  Exchange(es::SetUnits{units}, deadline);
  Clock::duration initializing = Clock::duration::zero();
  const auto status = Exchange(es::GetSystemStatus{}, deadline);
  const auto* s = std::get_if<es::SystemStatus>(&status.data);
  if (!s)
    throw InstrumentError(name(), grc::kComCantDecode,
                          "GetSystemStatus: the reply carries no status");
  if (options_.force_initialize ||
      s->tracker_processor_status != es::tracker_processor_status::kInitialized) {
    spdlog::info("{}: initializing the tracker (processor status {})", name(),
                 s->tracker_processor_status);
    const auto begin = Clock::now();
    Exchange(es::Initialize{}, std::max(deadline, begin + options_.initialize_timeout));
    initializing = Clock::now() - begin;
    deadline += initializing;
  }
  const auto read = Exchange(es::GetSystemSettings{}, deadline);
  const auto* current = std::get_if<es::SystemSettings>(&read.data);
  if (!current)
    throw InstrumentError(name(), grc::kComCantDecode,
                          "GetSystemSettings: the reply carries no settings");
  es::SystemSettings settings = *current;  // keeps the weather station and hardware flags
  settings.apply_transformation = false;   // results in the tracker's own frame
  settings.apply_station_orientation = false;
  settings.keep_last_position = true;
  settings.send_unsolicited_messages = true;
  settings.send_reflector_position = false;
  settings.try_measurement_mode = false;
  Exchange(es::SetSystemSettings{settings}, deadline);
  Exchange(es::SetCoordinateSystemType{es::coordinate_system::kSCC}, deadline);
  Exchange(es::SetMeasurementMode{es::meas_mode::kStationary}, deadline);
  Exchange(es::SetStationaryModeParams{options_.measurement_time_ms, options_.use_adm}, deadline);
  std::optional<int32_t> reflector = options_.reflector_id;
  if (!reflector && !options_.reflector_name.empty()) {
    const auto all = ReadReflectors(deadline);
    std::string names;
    for (const auto& r : all) {
      if (r.name == options_.reflector_name) reflector = r.id;
      names += (names.empty() ? "" : ", ") + r.name;
    }
    if (!reflector) {
      throw InputError({"reflector", 0, 0, ""}, "no reflector named " +
                                                    Quoted(options_.reflector_name) + " on " +
                                                    name() + " (it has: " + names + ")");
    }
  }
  if (reflector) {
    Exchange(es::SetReflector{*reflector}, deadline);
    reflector_id_ = reflector;
  } else {
    const auto active = Exchange(es::GetReflector{}, deadline);
    const auto* id = std::get_if<es::Int32Value>(&active.data);
    if (!id)
      throw InstrumentError(name(), grc::kComCantDecode, "GetReflector: the reply carries no id");
    reflector_id_ = id->value;
  }
  configured_ = true;
  convention_checked_ = false;  // with the first reading on this connection
  ++stats_.configurations;
  spdlog::info(
      "{}: set up: mm, {}, °C, mbar, %RH; spherical counter-clockwise (SCC); stationary {} ms{}; "
      "reflector {}",
      name(),
      options_.angle_unit == es::angle_unit::kRadian
          ? "rad"
          : "angle unit " + std::to_string(options_.angle_unit),
      options_.measurement_time_ms, options_.use_adm ? " ADM" : "", *reflector_id_);
  return initializing;
}

void EmsconDevice::Connect() {
  WithRetries(-1, CallDeadline(), [](Deadline) { return 0; });
}

DeviceInfo EmsconDevice::Identify() {
  const auto s = Status();
  DeviceInfo info;
  info.name = "Leica laser tracker (emScon)";
  info.serial = std::to_string(s.serial);
  info.firmware = fmt::format("emScon {}.{}.{}", s.version_major, s.version_minor, s.version_build);
  return info;
}

es::SystemStatus EmsconDevice::Status() {
  // Asking changes nothing: no set-up first (a probe leaves the tracker as it was).
  return WithRetries(
      es::GetSystemStatus::kCommand, CallDeadline(),
      [&](Deadline until) {
        const auto a = Exchange(es::GetSystemStatus{}, until);
        const auto* s = std::get_if<es::SystemStatus>(&a.data);
        if (!s) {
          throw InstrumentError(name(), grc::kComCantDecode,
                                "GetSystemStatus: the reply carries no status");
        }
        return *s;
      },
      false);
}

void EmsconDevice::CheckResult(const es::MeasResult& m) const {
  if (m.status != es::status::kAllOk)
    ThrowStatus(es::StartMeasurement::kCommand, m.status, "result:");
  if (m.meas_mode != es::meas_mode::kStationary) {
    throw InstrumentError(
        name(), grc::kComCantDecode,
        fmt::format("a result in measurement mode {}, not stationary (0)", m.meas_mode));
  }
  if (m.try_mode)
    throw InstrumentError(name(), grc::kComCantDecode, "a try-mode result is no measurement");
  if (!Finite(m.value) || !Finite(m.std_dev) || !std::isfinite(m.temperature) ||
      !std::isfinite(m.pressure) || !std::isfinite(m.humidity)) {
    throw InstrumentError(name(), grc::kComCantDecode,
                          "a result with a value that is not a finite number");
  }
  for (int i = 0; i < 3; ++i) {
    if (!(m.std_dev[i] >= 0.0)) {
      throw ReadingRangeError(name(), "standard deviation " + std::to_string(i + 1), m.std_dev[i],
                              0.0, HUGE_VAL, "as the value");
    }
  }
}

Reading EmsconDevice::ReadingOf(const es::MeasResult& m) const {
  CheckResult(m);
  const double to_rad = *es::RadiansPer(options_.angle_unit);
  // SCC (set up so): Hz counter-clockwise from +x in (−2π, 2π), V the zenith angle.
  const es::SphericalCcw scc{m.value[0] * to_rad, m.value[1] * to_rad, m.value[2]};
  constexpr double kTurn = 2.0 * std::numbers::pi;
  if (!(std::abs(scc.hz_rad) <= kTurn))
    throw ReadingRangeError(name(), "Hz (SCC)", scc.hz_rad, -kTurn, kTurn, "rad");
  if (!plausible::IsPlausible(plausible::Quantity::kZenithAngle, scc.v_rad))
    throw ReadingRangeError(name(), "V (zenith angle)", scc.v_rad, 0.0, kTurn, "rad");
  CheckDistance(name(), scc.distance_mm);
  if (!(m.temperature >= kMinTemperatureC && m.temperature <= kMaxTemperatureC))
    throw ReadingRangeError(name(), "temperature", m.temperature, kMinTemperatureC,
                            kMaxTemperatureC, "°C");
  if (!(m.pressure >= kMinPressureHpa && m.pressure <= kMaxPressureHpa))
    throw ReadingRangeError(name(), "pressure", m.pressure, kMinPressureHpa, kMaxPressureHpa,
                            "hPa");
  if (!(m.humidity >= kMinHumidity && m.humidity <= kMaxHumidity))
    throw ReadingRangeError(name(), "humidity", m.humidity, kMinHumidity, kMaxHumidity, "%RH");
  // The station frame is the tracker's RHR frame: armsig's Hz (clockwise from +y) of the
  // point is π/2 − Hz(SCC); V is the same zenith angle.
  const Eigen::Vector3d point = es::PointFromScc(scc);
  const es::Spherical s = es::SphericalFromPoint(point);
  CheckAngles(name(), s.hz_rad, s.v_rad);
  Reading r;
  r.time = std::chrono::system_clock::now();
  r.angles = {s.hz_rad, s.v_rad, s.v_rad > std::numbers::pi ? 2 : 1};
  r.distance_mm = s.distance_mm;
  r.point_in_instrument_mm = point;
  r.sigma = ReadingSigmas{m.std_dev[0] * to_rad, m.std_dev[1] * to_rad, m.std_dev[2]};
  r.environment = Environment{m.temperature, m.pressure, m.humidity};
  return r;
}

es::MeasResult EmsconDevice::MeasureResult(Deadline share) {
  // A result comes after the measurement time: an attempt waits at least that long, never
  // past the call's deadline.
  const Deadline until = std::min(
      call_deadline_,
      std::max(share, Clock::now() + Millis(options_.measurement_time_ms) + kMeasurementMargin));
  constexpr int32_t id = es::StartMeasurement::kCommand;
  ++stats_.commands;
  last_sent_ = id;
  transport_->Write(es::EncodeRequest(es::StartMeasurement{}), until);
  for (;;) {
    const auto packet = NextPacket(until);
    if (!packet) continue;
    if (const auto* a = std::get_if<es::CommandAnswer>(&*packet)) {
      if (a->command != id) {
        ++stats_.stale_answers;
        ++stale_in_call_;
        continue;
      }
      if (a->status == es::status::kServerBusy) throw Busy{es::CommandName(id)};
      if (a->status != es::status::kAllOk) ThrowStatus(id, a->status, "answered");
      continue;  // accepted; the result follows
    }
    if (const auto* e = std::get_if<es::ErrorResponse>(&*packet)) {
      FailUnlessUnsolicited(*e, id);
      continue;
    }
    if (const auto* m = std::get_if<es::MeasResult>(&*packet)) return *m;
    ++stats_.stale_results;  // a continuous stream's results: not this reading
  }
}

Reading EmsconDevice::Measure() {
  return WithRetries(es::StartMeasurement::kCommand, CallDeadline(), [&](Deadline share) {
    const es::MeasResult m = MeasureResult(share);
    Reading r = ReadingOf(m);
    // The self-check is set-up, not this reading (as Initialize is): its own stationary
    // measurement and coordinate-type changes get their own time, so a call's deadline
    // that fits one reading also fits the first on a connection.
    if (!convention_checked_) {
      const auto own = Clock::now() + Millis(options_.measurement_time_ms) + policy_.timeout;
      CheckConventionWith(m, std::max(share, own));
    }
    return r;
  });
}

void EmsconDevice::CheckConvention() {
  if (!convention_checked_) Measure();
}

namespace {

// σ of a point (mm, root of the summed component variances) from a result's sigmas:
// spherical (Hz, V in rad, distance in mm) or Cartesian (mm).
double PointSigmaMm(const es::MeasResult& m, bool spherical, double to_rad) {
  if (!spherical)
    return std::sqrt(m.std_dev[0] * m.std_dev[0] + m.std_dev[1] * m.std_dev[1] +
                     m.std_dev[2] * m.std_dev[2]);
  const double d = m.value[2], v = m.value[1] * to_rad;
  const double across = m.std_dev[0] * to_rad * d * std::abs(std::sin(v));
  const double up = m.std_dev[1] * to_rad * d;
  return std::sqrt(across * across + up * up + m.std_dev[2] * m.std_dev[2]);
}

// Which other reading of the SCC values (hz, v, d) would give `cartesian`: named in the
// self-check's message, so a lab sees at once what the tracker does.
std::string OtherReadingThatMatches(const es::SphericalCcw& s, const Eigen::Vector3d& cartesian,
                                    double tolerance_mm) {
  const double d = s.distance_mm, sh = std::sin(s.hz_rad), ch = std::cos(s.hz_rad);
  const double sv = std::sin(s.v_rad), cv = std::cos(s.v_rad);
  const struct {
    const char* what;
    Eigen::Vector3d point;
  } candidates[] = {
      {"Hz clockwise from +y (a theodolite's circle)", d * Eigen::Vector3d(sv * sh, sv * ch, cv)},
      {"Hz clockwise from +x", d * Eigen::Vector3d(sv * ch, -sv * sh, cv)},
      {"V an elevation above the horizon, not a zenith angle",
       d * Eigen::Vector3d(cv * ch, cv * sh, sv)},
      {"Hz clockwise from +y and V an elevation", d * Eigen::Vector3d(cv * sh, cv * ch, sv)},
  };
  for (const auto& c : candidates) {
    if ((c.point - cartesian).norm() <= tolerance_mm) return c.what;
  }
  return "";
}

}  // namespace

void EmsconDevice::CheckConventionWith(const es::MeasResult& scc, Deadline until) {
  const double to_rad = *es::RadiansPer(options_.angle_unit);
  // Set up again (SCC) should anything below fail before SCC is set back.
  configured_ = false;
  Exchange(es::SetCoordinateSystemType{es::coordinate_system::kRHR}, until);
  const es::MeasResult rhr = MeasureResult(until);
  Exchange(es::SetCoordinateSystemType{es::coordinate_system::kSCC}, until);
  configured_ = true;
  CheckResult(rhr);
  const es::SphericalCcw s{scc.value[0] * to_rad, scc.value[1] * to_rad, scc.value[2]};
  const Eigen::Vector3d from_scc = es::PointFromScc(s);
  const Eigen::Vector3d cartesian(rhr.value[0], rhr.value[1], rhr.value[2]);
  const double apart = (from_scc - cartesian).norm();
  const double sigma = std::hypot(PointSigmaMm(scc, true, to_rad), PointSigmaMm(rhr, false, 1.0));
  const double tolerance = std::max({kConventionToleranceMm, 10.0 * sigma,
                                     kConventionTolerancePerMm * cartesian.norm()});
  if (apart <= tolerance) {
    convention_checked_ = true;
    spdlog::info(
        "{}: coordinate convention checked: the reflector read as SCC and as RHR "
        "agrees ({:.4f} mm apart, tolerance {:.3f} mm)",
        name(), apart, tolerance);
    return;
  }
  const std::string other = OtherReadingThatMatches(s, cartesian, tolerance);
  throw ConventionMismatch(
      name(),
      fmt::format(
          "the coordinate convention self-check failed: the reflector read as spherical "
          "counter-clockwise (SCC: Hz {:.6f} rad, V {:.6f} rad, {:.3f} mm) is at ({:.3f}, "
          "{:.3f}, {:.3f}) mm by the convention armsig reads (Hz = atan2(y, x) from +x, V the "
          "zenith angle), read as Cartesian (RHR) at ({:.3f}, {:.3f}, {:.3f}) mm: {:.3f} mm "
          "apart (tolerance {:.3f} mm). {}The tracker's readings cannot be used: nothing is "
          "measured with it (instruments/EMSCON.md §7)",
          s.hz_rad, s.v_rad, s.distance_mm, from_scc.x(), from_scc.y(), from_scc.z(), cartesian.x(),
          cartesian.y(), cartesian.z(), apart, tolerance,
          other.empty() ? std::string()
                        : "The two agree if the SCC values are read with " + other + ". "));
}

Reading EmsconDevice::MeasureAngles() {
  Reading r = Measure();
  r.distance_mm.reset();  // angles only, as asked (the sigmas and the point stay)
  return r;
}

Reading EmsconDevice::MeasureDistanceAndAngles() { return Measure(); }

int EmsconDevice::Face() {
  return WithRetries(es::GetFace::kCommand, CallDeadline(), [&](Deadline until) {
    const auto a = Exchange(es::GetFace{}, until);
    const auto* face = std::get_if<es::Int32Value>(&a.data);
    if (!face || (face->value != 1 && face->value != 2)) {
      throw InstrumentError(
          name(), grc::kComCantDecode,
          fmt::format("GetFace: face {} is neither 1 nor 2", face ? face->value : -1));
    }
    return static_cast<int>(face->value);
  });
}

void EmsconDevice::ChangeFace() {
  WithRetries(es::ChangeFace::kCommand, CallDeadline(),
              [&](Deadline until) { return Exchange(es::ChangeFace{}, until).status; });
}

bool EmsconDevice::CompensatorOn() {
  return WithRetries(es::GetLongSystemParameter::kCommand, CallDeadline(), [&](Deadline until) {
    const auto a =
        Exchange(es::GetLongSystemParameter{es::system_parameter::kInclinationSensorState}, until);
    const auto* p = std::get_if<es::LongParameter>(&a.data);
    if (!p || p->parameter != es::system_parameter::kInclinationSensorState) {
      throw InstrumentError(name(), grc::kComCantDecode,
                            "GetLongSystemParameter: the reply is for another parameter");
    }
    return p->value != 0;  // 0 off, 2 apply corrections
  });
}

void EmsconDevice::GoPosition(const Eigen::Vector3d& point_in_instrument_mm) {
  if (!point_in_instrument_mm.allFinite())
    throw InstrumentError(name(), grc::kComCantDecode, "GoPosition: the point is not finite");
  const es::SphericalCcw s = es::SccFromPoint(point_in_instrument_mm);  // SCC, as set up
  const double per_rad = 1.0 / *es::RadiansPer(options_.angle_unit);
  WithRetries(es::GoPosition::kCommand, CallDeadline(), [&](Deadline until) {
    return Exchange(es::GoPosition{s.hz_rad * per_rad, s.v_rad * per_rad, s.distance_mm,
                                   options_.use_adm},
                    until)
        .status;
  });
}

void EmsconDevice::FindReflector(double approx_distance_mm) {
  WithRetries(es::FindReflector::kCommand, CallDeadline(), [&](Deadline until) {
    return Exchange(es::FindReflector{approx_distance_mm}, until).status;
  });
}

bool EmsconDevice::ReflectorLost(int code) const {
  return code == es::status::kNoDistanceSet || code == es::status::kMeasurementStatusNotReady;
}

Environment EmsconDevice::GetEnvironment() {
  return WithRetries(es::GetEnvironmentParams::kCommand, CallDeadline(), [&](Deadline until) {
    const auto a = Exchange(es::GetEnvironmentParams{}, until);
    const auto* e = std::get_if<es::EnvironmentParams>(&a.data);
    if (!e)
      throw InstrumentError(name(), grc::kComCantDecode,
                            "GetEnvironmentParams: no values in the reply");
    return Environment{e->temperature, e->pressure, e->humidity};
  });
}

std::vector<es::ReflectorInfo> EmsconDevice::Reflectors() {
  return WithRetries(es::GetReflectors::kCommand, CallDeadline(),
                     [&](Deadline until) { return ReadReflectors(until); });
}

std::vector<es::ReflectorInfo> EmsconDevice::ReadReflectors(Deadline until) {
  {
    std::vector<es::ReflectorInfo> out;
    auto take = [&](const es::CommandAnswer& a) {
      const auto* r = std::get_if<es::ReflectorInfo>(&a.data);
      if (!r)
        throw InstrumentError(name(), grc::kComCantDecode,
                              "GetReflectors: no reflector in the reply");
      out.push_back(*r);
      return r->total;
    };
    const int32_t total = take(Exchange(es::GetReflectors{}, until));
    // The server sends one reply per reflector (EMSCON.md §3.3).
    while (static_cast<int32_t>(out.size()) < total) {
      const auto packet = NextPacket(until);
      if (!packet) continue;
      const auto* a = std::get_if<es::CommandAnswer>(&*packet);
      if (a && a->command == es::GetReflectors::kCommand && a->status == es::status::kAllOk) {
        take(*a);
      } else if (const auto* e = std::get_if<es::ErrorResponse>(&*packet)) {
        Record(Event::Kind::kUnsolicitedError, e->status, e->command);
      } else {
        ++stats_.stale_answers;
      }
    }
    return out;
  }
}

void EmsconDevice::StartContinuous(const ContinuousOptions& o) {
  if (o.spatial_distance_mm ? !(*o.spatial_distance_mm > 0.0) : o.time_separation_ms < 1) {
    throw std::invalid_argument("continuous measurement: a time separation of at least 1 ms or "
                                "a distance above 0 mm");
  }
  WithRetries(es::StartMeasurement::kCommand, CallDeadline(), [&](Deadline until) {
    if (o.spatial_distance_mm) {
      Exchange(es::SetMeasurementMode{es::meas_mode::kContinuousDistance}, until);
      Exchange(es::SetContinuousDistanceModeParams{*o.spatial_distance_mm, 0, false,
                                                   es::region_type::kSphere},
               until);
    } else {
      Exchange(es::SetMeasurementMode{es::meas_mode::kContinuousTime}, until);
      Exchange(es::SetContinuousTimeModeParams{o.time_separation_ms, 0, false,
                                               es::region_type::kSphere},
               until);
    }
    Exchange(es::StartMeasurement{}, until);
    continuous_ = true;
    last_record_time_s_ = 0.0;
    return 0;
  });
}

void EmsconDevice::ReadContinuous(Deadline until, const std::atomic<bool>& done,
                                  const std::function<void(const ContinuousRecord&)>& each,
                                  const std::function<void(const ContinuousEvent&)>& event) {
  if (!continuous_) throw std::logic_error("ReadContinuous before StartContinuous");
  while (!done.load() && Clock::now() < until) {
    std::optional<es::Packet> packet;
    try {
      packet = NextPacket(std::min(until, Clock::now() + Millis(50)));
    } catch (const TransportError& e) {
      if (e.kind() == TransportError::Kind::kTimeout) continue;  // no record yet: look again
      if (e.kind() == TransportError::Kind::kInterrupted) throw;
      throw InstrumentError(name(), CodeOf(e), "continuous measurement: " + e.message());
    }
    if (!packet) continue;
    if (const auto* e = std::get_if<es::ErrorResponse>(&*packet)) {
      Record(Event::Kind::kUnsolicitedError, e->status, e->command);
      const std::string advice = es::StatusAdvice(e->status);
      if (event) {
        event({last_record_time_s_, e->status,
               fmt::format("{} ({}){}", es::StatusName(e->status), e->status,
                           advice.empty() ? std::string() : ": " + advice)});
      }
      continue;
    }
    const auto* m = std::get_if<es::MultiMeasResult>(&*packet);
    if (!m) {
      ++stats_.stale_results;
      continue;
    }
    DeliverRecords(*m, each);
  }
}

void EmsconDevice::DeliverRecords(const es::MultiMeasResult& m,
                                  const std::function<void(const ContinuousRecord&)>& each) {
  const double to_rad = *es::RadiansPer(options_.angle_unit);
  for (const es::MeasRecord& rec : m.records) {
    const bool usable_status = rec.status == es::continuous_status::kAllOk ||
                               rec.status == es::continuous_status::kSpeedWarning;
    const es::SphericalCcw scc{rec.value[0] * to_rad, rec.value[1] * to_rad, rec.value[2]};
    const bool sane = m.status == es::status::kAllOk && !m.try_mode && Finite(rec.value) &&
                      std::abs(scc.hz_rad) <= 2.0 * std::numbers::pi &&
                      plausible::IsPlausible(plausible::Quantity::kZenithAngle, scc.v_rad) &&
                      scc.distance_mm > 0.0 && scc.distance_mm < 1e6;
    if (!usable_status || !sane) {
      ++continuous_refused_;
      continue;
    }
    ContinuousRecord r;
    r.tracker_time_s = es::TimeOf(rec);
    r.status = rec.status;
    r.point_in_instrument_mm = es::PointFromScc(scc);
    const es::Spherical s = es::SphericalFromPoint(r.point_in_instrument_mm);
    r.angles = {s.hz_rad, s.v_rad, 1};
    r.distance_mm = s.distance_mm;
    last_record_time_s_ = r.tracker_time_s;
    each(r);
  }
}

void EmsconDevice::StopContinuous(const std::function<void(const ContinuousRecord&)>& in_flight) {
  if (!continuous_) return;
  WithRetries(es::StopMeasurement::kCommand, CallDeadline(), [&](Deadline until) {
    // The records still in flight arrive before the stop's answer: to `in_flight` (Exchange).
    in_flight_ = in_flight ? &in_flight : nullptr;
    try {
      Exchange(es::StopMeasurement{}, until);
    } catch (...) {
      in_flight_ = nullptr;
      throw;
    }
    in_flight_ = nullptr;
    Exchange(es::SetMeasurementMode{es::meas_mode::kStationary}, until);
    Exchange(es::SetStationaryModeParams{options_.measurement_time_ms, options_.use_adm}, until);
    return 0;
  });
  continuous_ = false;
}

}  // namespace armsig::instruments
