// A Leica laser tracker behind an emScon server (TPI over TCP, instruments/EMSCON.md).
//
// On every new connection the driver sets the tracker up explicitly and never assumes its
// state: SetUnits (mm, rad, °C, mbar, %RH) → GetSystemStatus → Initialize when the tracker
// is not initialised (or when asked) → GetSystemSettings → SetSystemSettings (no user
// transformation or station orientation applied, unsolicited errors on, no position
// stream, no try mode) → SetCoordinateSystemType (SCC: spherical counter-clockwise, the
// convention public clients confirm, emscon::PointFromScc) → SetMeasurementMode
// (stationary) → SetStationaryModeParams → SetReflector (when one is configured) or
// GetReflector (the active one is read and recorded).
//
// The convention self-check: the first reading on a connection is taken again in RHR
// (Cartesian): SetCoordinateSystemType RHR → StartMeasurement → SetCoordinateSystemType
// SCC. The SCC reading converted by the convention and the RHR point must agree within
// 2 mm per metre of distance (at least 0.5 mm, or 10 stated sigmas if more: a wrong
// convention mirrors the point), else ConventionMismatch names both points,
// how far apart they are, and which other reading of the SCC values would match.
//
// One command in flight; its answer must echo its command id. Packets the server pushes
// between a command and its answer (status changes, unsolicited errors, reflector
// positions, another command's reply) are recorded and skipped, never taken for the
// answer. ServerBusy, timeouts, a lost framing and a lost connection are retried with the
// RetryPolicy, all by the call's deadline (policy.timeout; Initialize alone has its own,
// options.initialize_timeout); any other status is an InstrumentError carrying the emScon
// status number (transport failures carry the GeoCOM client codes of line_retry.h). A
// result is refused (no reading) unless its status is AllOK, it is a stationary result, and
// every value is finite and in range.
#pragma once

#include <atomic>
#include <deque>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "instruments/device.h"
#include "instruments/emscon_codec.h"
#include "instruments/packet_transport.h"

namespace armsig::instruments {

struct EmsconOptions {
  int measurement_time_ms = 500;    // stationary mode: the tracker averages this long
  bool use_adm = false;             // stationary mode: measure the distance with the ADM
  std::optional<int> reflector_id;  // SetReflector; else the active reflector is kept
  std::string reflector_name;       // or the reflector of this name (GetReflectors)
  bool force_initialize = false;    // Initialize even when the tracker reports it is
  // Initialize moves the head and warms up: up to ~90 s on an AT4xx (EMSCON.md §4).
  Millis initialize_timeout{120000};
  // "radians or what is available": the angle unit set with SetUnits (emscon::angle_unit).
  int32_t angle_unit = emscon::angle_unit::kRadian;
};

// Continuous measurement (measuring on the move): time-triggered (a point every
// `time_separation_ms` of the tracker's clock) or distance-triggered (a point every
// `spatial_distance_mm` of reflector travel).
struct ContinuousOptions {
  int time_separation_ms = 10;
  std::optional<double> spatial_distance_mm;  // set: distance-triggered instead
};

// One continuous record, converted as a stationary reading is (the tracker's RHR frame, mm),
// stamped with the tracker's own clock.
struct ContinuousRecord {
  double tracker_time_s = 0.0;
  int32_t status = 0;  // ES_MeasurementStatus: 0 AllOK; 1 speed warning … (not used)
  Eigen::Vector3d point_in_instrument_mm = Eigen::Vector3d::Zero();
  AngleReading angles;
  double distance_mm = 0.0;
};

// What ended or interrupted the stream meanwhile: the tracker's own words (an unsolicited
// error such as 37 NoDistanceSet when the beam broke), on the tracker's clock of the last
// record before it.
struct ContinuousEvent {
  double after_tracker_time_s = 0.0;
  int32_t status = 0;
  std::string what;
};

class EmsconDevice : public DistanceInstrument, public BeamSteering {
 public:
  EmsconDevice(std::unique_ptr<PacketTransport> transport, RetryPolicy policy = {},
               EmsconOptions options = {});

  const std::string& name() const override { return transport_->name(); }

  // Connects (if needed) and runs the set-up sequence above, by policy.timeout.
  void Connect();
  // GetSystemStatus: serial number and emScon version. Identify and Status connect but do
  // not set the tracker up (a probe changes nothing).
  DeviceInfo Identify() override;
  // One stationary measurement (StartMeasurement → SingleMeasResult): Hz, V, distance,
  // the point, per-component sigmas, temperature, pressure, humidity; stamped when it
  // arrived (the result carries no time).
  Reading Measure();
  Reading MeasureAngles() override;             // Measure() without the distance
  Reading MeasureDistanceAndAngles() override;  // Measure()
  int Face() override;                          // GetFace: 1 or 2
  void ChangeFace() override;
  bool CompensatorOn() override;  // AT4xx inclination sensor state (system parameter 5002)
  // Points the beam at a predicted position in the instrument frame (mm), as Hz, V,
  // distance in SCC (GoPosition).
  void GoPosition(const Eigen::Vector3d& point_in_instrument_mm) override;
  // Searches the reflector around the beam's direction at about this distance.
  void FindReflector(double approx_distance_mm) override;
  // 37 NoDistanceSet (the beam broke) and 10004 MeasurementStatusNotReady (no reflector in
  // the beam).
  bool ReflectorLost(int code) const override;
  // Measure() once, unless this connection's readings were checked already.
  void CheckConvention() override;
  bool convention_checked() const { return convention_checked_; }
  Environment GetEnvironment();  // GetEnvironmentParams, °C, hPa, %RH
  emscon::SystemStatus Status();
  std::vector<emscon::ReflectorInfo> Reflectors();  // GetReflectors (one reply each)

  void SetInterrupt(const std::atomic<bool>* flag) override { transport_->SetInterrupt(flag); }

  // --- Measuring on the move ----------------------------------------------------------
  // SetMeasurementMode (continuous time or distance) → its parameters → StartMeasurement,
  // with the retry policy by policy.timeout (the set-up first on a new connection).
  void StartContinuous(const ContinuousOptions& options);
  // Reads the stream until `done` is set (checked at least every 50 ms) or `until` passes:
  // every record that is a reading goes to `each` (in the tracker's order); a record that is
  // not (a status other than AllOK or SpeedWarning, a value out of range or not finite) is
  // counted in refused(); an error the tracker pushes (the beam broke) goes to `event` and the
  // stream goes on (a tracker relocks and resumes on its own). A lost connection throws.
  void ReadContinuous(Deadline until, const std::atomic<bool>& done,
                      const std::function<void(const ContinuousRecord&)>& each,
                      const std::function<void(const ContinuousEvent&)>& event);
  // StopMeasurement, then stationary mode again, by policy.timeout. The records still in
  // flight (measured before the tracker took the stop, not read yet: a reader that fell
  // behind) go to `in_flight` as ReadContinuous would hand them over, or are dropped without
  // it: nothing the tracker measured while the caller's motion ran need be lost.
  void StopContinuous(const std::function<void(const ContinuousRecord&)>& in_flight = {});
  int continuous_refused() const { return continuous_refused_; }

  // A packet the server pushed while the driver waited for an answer.
  struct Event {
    enum class Kind { kStatusChange, kUnsolicitedError };
    Kind kind = Kind::kStatusChange;
    int32_t value = 0;    // the status change, or the error's status
    int32_t command = 0;  // an error's command id
    std::chrono::system_clock::time_point time;
  };
  static constexpr size_t kMaxEvents = 256;  // the latest ones are kept
  const std::deque<Event>& events() const { return events_; }

  struct Statistics {
    int commands = 0, retries = 0, reconnects = 0, busy = 0, status_changes = 0,
        unsolicited_errors = 0, stale_answers = 0, stale_results = 0, position_packets = 0,
        undecodable = 0, bad_frames = 0, configurations = 0;
  };
  const Statistics& statistics() const { return stats_; }
  // The active reflector after the set-up (GetReflector or SetReflector), when known.
  std::optional<int32_t> reflector_id() const { return reflector_id_; }

 private:
  struct Busy {
    std::string what;
  };
  Deadline CallDeadline() const { return Clock::now() + policy_.timeout; }
  // Runs attempt(attempt_deadline) with the retry policy by `deadline` (`command` names
  // the call, -1 the set-up), connecting first and, with `set_up`, setting the tracker up
  // whenever the connection is new.
  template <typename F>
  auto WithRetries(int32_t command, Deadline deadline, F&& attempt, bool set_up = true);
  // Both return the time Initialize took (zero when it was not needed).
  Clock::duration EnsureReady(Deadline deadline, bool set_up);
  Clock::duration Configure(Deadline deadline);
  // Sends `request` and returns its answer (status AllOK); throws Busy, InstrumentError
  // (another status, or an ErrorResponse for this command) or TransportError.
  emscon::CommandAnswer Exchange(const emscon::Request& request, Deadline until);
  // The next packet that decodes, every asynchronous one recorded on the way. Returns
  // nullopt for an asynchronous or undecodable packet (the caller reads on).
  std::optional<emscon::Packet> NextPacket(Deadline until);
  // GetReflectors: the server sends one reply per reflector.
  std::vector<emscon::ReflectorInfo> ReadReflectors(Deadline until);
  void Record(Event::Kind kind, int32_t value, int32_t command);
  [[noreturn]] void ThrowStatus(int32_t command, int32_t status, const char* how) const;
  // An error packet while command `id` waits for its answer: another command's (unsolicited:
  // recorded, the wait goes on) or this command's failure (thrown: Busy, or its status).
  void FailUnlessUnsolicited(const emscon::ErrorResponse& e, int32_t id);
  // One stationary result (StartMeasurement → SingleMeasResult), refused unless it is a
  // reading: status AllOK, stationary, no try mode, every value finite.
  emscon::MeasResult MeasureResult(Deadline share);
  void CheckResult(const emscon::MeasResult& m) const;
  Reading ReadingOf(const emscon::MeasResult& m) const;
  // The self-check against the SCC result `scc` just read (see above).
  void CheckConventionWith(const emscon::MeasResult& scc, Deadline until);

  std::unique_ptr<PacketTransport> transport_;
  RetryPolicy policy_;
  EmsconOptions options_;
  bool configured_ = false;
  bool convention_checked_ = false;  // on this connection
  bool opened_before_ = false;
  std::optional<int32_t> reflector_id_;
  std::deque<Event> events_;
  std::optional<Event> last_unsolicited_;  // during the current call
  int stale_in_call_ = 0;
  int32_t last_sent_ = -1;  // the command sent last in the current call
  Deadline call_deadline_;  // the current call's deadline (Initialize's time added)
  bool continuous_ = false;  // StartContinuous ran and StopContinuous has not yet
  double last_record_time_s_ = 0.0;
  int continuous_refused_ = 0;
  // While StopContinuous waits for the stop's answer: where the records in flight go.
  const std::function<void(const ContinuousRecord&)>* in_flight_ = nullptr;
  // A continuous result's records that are readings, to `each` (the others counted refused).
  void DeliverRecords(const emscon::MultiMeasResult& m,
                      const std::function<void(const ContinuousRecord&)>& each);
  Statistics stats_;
};

}  // namespace armsig::instruments
