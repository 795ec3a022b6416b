// Small device interfaces the acquisition layer uses without knowing the protocol.
#pragma once

#include <Eigen/Core>
#include <atomic>
#include <chrono>
#include <functional>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "core/plausibility.h"
#include "core/types.h"
#include "instruments/return_codes.h"

namespace armsig::instruments {

struct DeviceInfo {
  std::string name, serial, firmware;
};

// Per-component standard deviations an instrument reported with its reading (a laser
// tracker's result carries them).
struct ReadingSigmas {
  double hz_rad = 0.0, v_rad = 0.0, distance_mm = 0.0;
};

// The air at the instrument when it measured (a tracker's weather station or the values
// entered on it): for refraction and for the record.
struct Environment {
  double temperature_c = 0.0, pressure_hpa = 0.0, humidity_percent = 0.0;
};

// One measurement as the instrument gave it. A warning code that still carries valid
// data (GeoCOM 1283/1284) is kept in return_code; a reading is never invented. The
// optional parts are set only by instruments that report them (laser trackers).
struct Reading {
  AngleReading angles;
  std::optional<double> distance_mm;
  int return_code = 0;
  std::string note;  // e.g. "TMC_ACCURACY_GUARANTEE: data valid, accuracy not guaranteed"
  std::chrono::system_clock::time_point time;  // when the driver received it
  // The point in the instrument frame (the theodolite frame of
  // docs/reference/conventions.md: z up, y circle zero), mm:
  // distance × (sin V sin Hz, sin V cos Hz, cos V).
  std::optional<Eigen::Vector3d> point_in_instrument_mm;
  std::optional<ReadingSigmas> sigma;
  std::optional<Environment> environment;
};

// The instrument answered with an error code, or never answered usably: no data. The
// code is in GeoCOM's code space for every protocol (transport failures as the GeoCOM
// client codes: 3077 COM_TIMEDOUT, 3100 COM_OVERRUN for an over-long line, 3085
// COM_FAILED for a lost port, 3074 COM_CANT_DECODE for a reply that is no reading).
class InstrumentError : public std::runtime_error {
 public:
  InstrumentError(std::string device, int code, const std::string& message)
      : std::runtime_error(device + ": " + message), device_(std::move(device)), code_(code) {}
  const std::string& device() const { return device_; }
  int code() const { return code_; }

 private:
  std::string device_;
  int code_;
};

// A set-up self-check found that the instrument does not report what its driver reads:
// the same point read in two of its coordinate-system types disagrees (a laser tracker
// whose spherical readings follow another convention). Code 3074: no reading can be
// trusted; never retried, the capture refuses to start.
class ConventionMismatch : public InstrumentError {
 public:
  ConventionMismatch(std::string device, const std::string& message)
      : InstrumentError(std::move(device), grc::kComCantDecode, message) {}
};

// A reply that decodes but cannot be a reading: a value outside what the instrument or
// robot can report (a zenith angle below 0, Hz beyond a full circle, a joint beyond
// ±720°, a negative distance), usually a reply in other units or another command's
// reply. Code 3074 (COM_CANT_DECODE); the message names the device, the quantity, the
// value and the expected range.
class ReadingRangeError : public InstrumentError {
 public:
  ReadingRangeError(const std::string& device, std::string quantity, double value, double min,
                    double max, const std::string& unit);
  const std::string& quantity() const { return quantity_; }
  double value() const { return value_; }
  double min() const { return min_; }
  double max() const { return max_; }

 private:
  std::string quantity_;
  double value_, min_, max_;
};

// What any instrument or controller may report; beyond it: ReadingRangeError.
inline constexpr double kMaxJointDeg = 720.0;  // two turns either way: any robot joint
// A slope distance within a robot cell's plausible range (core/plausibility.h, 1 km), as in
// files.
inline constexpr double kMaxDistanceMm = plausible::kMaxLengthMm;
// Hz in [0, 2π], V (zenith angle) in [0, 2π] (face II above π), both finite.
void CheckAngles(const std::string& device, double hz_rad, double v_rad);
// A slope distance in [0, kMaxDistanceMm] mm.
void CheckDistance(const std::string& device, double distance_mm);
// Every joint finite and within ±kMaxJointDeg.
void CheckJoints(const std::string& device, const Eigen::VectorXd& joints_rad);

// Ctrl-C in a capture session: a flag that, once raised, ends the device call in flight
// within a few milliseconds (TransportError kInterrupted, never retried). The caller keeps
// the flag alive while it is set; nullptr clears it. Devices without a port ignore it.
class Interruptible {
 public:
  virtual ~Interruptible() = default;
  virtual void SetInterrupt(const std::atomic<bool>*) {}
};

class Theodolite : public Interruptible {
 public:
  virtual ~Theodolite() = default;
  virtual const std::string& name() const = 0;
  virtual DeviceInfo Identify() = 0;
  virtual Reading MeasureAngles() = 0;
  virtual int Face() = 0;  // 1 or 2
  virtual void ChangeFace() = 0;
  virtual bool CompensatorOn() = 0;
};

// Laser tracker / total station in tracking mode: angles and distance.
class DistanceInstrument : public Theodolite {
 public:
  virtual Reading MeasureDistanceAndAngles() = 0;
};

// An instrument that points its beam (a laser tracker): its reflector on the robot is found
// only when the beam passes near it, so capture points the beam at the predicted target
// before measuring, and has it search when it misses.
class BeamSteering {
 public:
  virtual ~BeamSteering() = default;
  // Points the beam at a position in the instrument frame (mm).
  virtual void GoPosition(const Eigen::Vector3d& point_in_instrument_mm) = 0;
  // Searches the reflector around the beam's direction at about this distance.
  virtual void FindReflector(double approx_distance_mm) = 0;
  // Whether a failed measurement's code means the beam is not on the reflector (no
  // reflector where the beam points, a broken beam) rather than a fault of the instrument.
  virtual bool ReflectorLost(int code) const = 0;
  // The set-up's self-check of the reading convention (once per connection): the
  // reflector where the beam is, read in two coordinate-system types, must be one point.
  // Throws ConventionMismatch when they disagree, an InstrumentError with a ReflectorLost
  // code when no reflector is in the beam (the check then comes with the first reading).
  virtual void CheckConvention() = 0;
};

// What a modern robot controller says it is (UR: the dashboard server and the primary
// interface; KUKA, ABB: their own services). Empty fields: the controller did not say.
struct ControllerIdentity {
  std::string protocol;  // the lab file's: ur, kuka, abb
  std::string vendor;    // "Universal Robots", "KUKA", "ABB"
  std::string model;     // as the controller names the arm: "UR10", "KR 6 R900", "IRB 1200"
  std::string serial;    // the arm's (or the controller's) serial number
  std::string software;  // "URSoftware 3.15.7.106331 (Jun 01 2021)", "KSS 8.6.10", "RobotWare 6.13"
  std::string kinematics_checksum;  // UR: KinematicsInfo's checksum ("" for the others)
};

// The controller's own kinematic model, as it tells it: UR's KinematicsInfo (primary
// interface, robot state package 5): per joint a checksum and the DH parameters of its
// factory calibration, and whether that calibration is done. Lengths mm, angles rad.
struct ControllerKinematics {
  std::string checksum;  // the per-joint checksums, joined ("8 hex digits" each, space apart)
  std::vector<double> dh_theta_rad, dh_a_mm, dh_d_mm, dh_alpha_rad;
  int calibration_status = 0;     // the controller's code (UR: 0 not initialised … 4 done)
  std::string calibration_state;  // its meaning ("linearised", "not calibrated", …)
  bool operator==(const ControllerKinematics&) const = default;
};

// Joints as the controller reported them, with its own time stamp.
struct StampedJoints {
  Eigen::VectorXd joints_rad;
  // The controller's clock (UR RTDE `timestamp`: seconds since the controller started);
  // nullopt when the controller gives none (VAL, AS, counter boxes).
  std::optional<double> controller_time_s;
  std::chrono::system_clock::time_point received;  // when armsig had it
};

// A controller state that stops armsig's work, typed, with the controller's name and
// what the operator must do. Its code is 4000 + kind (outside GeoCOM's code space).
class ControllerError : public InstrumentError {
 public:
  enum class Kind {
    kProtectiveStop,  // the arm stopped itself (a collision, a limit): cleared, it goes on
    kEmergencyStop,   // an emergency stop button is pressed
    kNotRemote,       // the controller does not take commands from the network (local mode)
    kNotRunning,      // powered off, brakes on, or the controller-side program not running
    kArmMoving,       // a reading was asked while the arm moves: never a reading
    kVersionRefused,  // the controller refused the protocol version armsig speaks
    kConnectionLost,  // the connection dropped and did not come back by the deadline
    kMoveRefused,     // the controller did not carry out the move it was sent
  };
  ControllerError(Kind kind, std::string controller, const std::string& what, std::string action);
  Kind kind() const { return kind_; }
  const std::string& what_happened() const { return what_; }
  // What the operator must do ("release the emergency stop, power the arm on …").
  const std::string& action() const { return action_; }
  // A state the session waits out and then goes on (a protective stop): every other kind
  // pauses the session, resumable once the operator has done the action.
  bool WaitedOut() const { return kind_ == Kind::kProtectiveStop; }

 private:
  Kind kind_;
  std::string what_, action_;
};
// "protective stop", "emergency stop", "not in remote control", …
const char* KindName(ControllerError::Kind kind);

// One package of a controller's joint stream, on the controller's clock.
struct JointSample {
  double controller_time_s = 0.0;
  Eigen::VectorXd q_rad, qd_rad_s;
};

// How a sweep (RobotController::Sweep) moves from one waypoint to the next.
struct SweepMotion {
  // Joint moves: the leading joint's speed and acceleration.
  double speed_rad_s = 1.05, acceleration_rad_s2 = 1.4;
  // Linear moves (the TCP on a straight line to each waypoint's pose, along the controller's
  // own path) at this TCP speed and acceleration, when the speed is above 0; joint moves else.
  double linear_speed_mm_s = 0.0, linear_acceleration_mm_s2 = 1200.0;
  // Circular moves at that speed instead: the waypoints in pairs, a via point (its position
  // only) and a target, the TCP on the arc through them.
  bool circular = false;
  bool linear() const { return linear_speed_mm_s > 0.0; }
};

class RobotController : public Interruptible {
 public:
  virtual ~RobotController() = default;
  virtual const std::string& name() const = 0;
  virtual Eigen::VectorXd ReadJointsRad() = 0;
  virtual bool CanMove() const = 0;
  virtual void MoveTo(const Eigen::VectorXd& joints_rad) = 0;

  // What a modern controller adds; the defaults are those of a controller that cannot say
  // (VAL, AS, counter boxes).
  // Who it is (model, serial, software); nullopt when it cannot say.
  virtual std::optional<ControllerIdentity> Identify() { return std::nullopt; }
  // Its own kinematic model (UR KinematicsInfo); nullopt when it has none to tell.
  virtual std::optional<ControllerKinematics> Kinematics() { return std::nullopt; }
  // The joints with the controller's time stamp, taken only while the arm stands still
  // (ControllerError kArmMoving otherwise); by default ReadJointsRad stamped on arrival.
  virtual StampedJoints ReadStampedJoints();
  // Whether the controller can take a move now: returns, or throws the ControllerError
  // that stops it (a protective stop not cleared yet, an emergency stop, local mode …).
  virtual void CheckReady() {}
  // Clears a protective stop from armsig when the operator has asked for it (UR: the
  // dashboard's close safety popup + unlock protective stop). The default cannot: throws
  // ControllerError kProtectiveStop saying to clear it on the controller.
  virtual void ClearProtectiveStop();
  // Whether its joint readings are cheap and stamped (a stream such as UR RTDE): the
  // session then reads them again after the instruments and stores a configuration only
  // when the arm did not move in between.
  virtual bool StreamsJoints() const { return false; }
  // Measuring on the move: moves through `waypoints` in order without waiting to measure
  // (joint or linear moves, as `motion` says), and hands every package of the joint stream to `each` from before the first move until the
  // arm stands at the last waypoint. A stop throws its ControllerError as MoveTo does. The
  // default cannot (a controller that does not stream its joints): ControllerError
  // kMoveRefused naming the controllers that can.
  virtual void Sweep(const std::vector<Eigen::VectorXd>& waypoints, const SweepMotion& motion,
                     const std::function<void(const JointSample&)>& each);
};

// How a driver retries: busy codes, bad checksums, silence, a lost port; then it gives
// up with a typed error. `timeout` is the deadline of one device call (MeasureAngles,
// ReadJointsRad, Identify …): from the first command to the parsed reply, every attempt,
// discarded line, delay and reconnection included. Each attempt waits its share of the
// time left (left / attempts left) before the command is sent again, so a silent
// instrument is asked `attempts` times and the call still ends by its deadline.
struct RetryPolicy {
  int attempts = 3;
  std::chrono::milliseconds timeout{3000};
  std::chrono::milliseconds busy_delay{100};
  std::chrono::milliseconds reconnect_delay{200};
};

}  // namespace armsig::instruments
