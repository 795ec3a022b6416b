// A Universal Robots controller (CB3 from software 3.4, e-Series), over its four network
// interfaces (robots/ur_codec.h for the documents followed):
//   - RTDE (30004): protocol version 2 is requested (a controller that refuses it is a
//     ControllerError kVersionRefused), the controller's version read, and one output recipe
//     set up — timestamp, actual_q, actual_qd, robot_mode, safety_mode, runtime_state — at the
//     controller's highest frequency (125 Hz CB3, 500 Hz e-Series) unless asked for less; a
//     variable the controller answers NOT_FOUND is refused by name. The stream runs only
//     during a call (start … pause).
//   - the secondary interface (30002): a move is one URScript line `movej([q1, …, q6], a=…,
//     v=…)`; the driver follows it on RTDE until the arm stands at the target, and says what
//     stopped it otherwise (a protective or emergency stop, the arm not running, a move the
//     controller did not start).
//   - the primary interface (30001): the version message and KinematicsInfo (the checksum
//     and DH table of the controller's own calibration).
//   - the dashboard server (29999): PolyscopeVersion, get robot model, get serial number,
//     robotmode, safetystatus (e-Series 5.4+) or safetymode, is in remote control (e-Series
//     5.6+), close safety popup and unlock protective stop.
// A configuration's joints are RTDE's actual_q, taken only when every joint's actual_qd has
// stayed below a threshold over a window of the controller's own clock, and stamped with
// that clock (ReadStampedJoints). A connection that drops is opened again, every
// RetryPolicy::reconnect_delay, until the call's deadline (RetryPolicy::timeout, a move's
// longer by its own time); one that does not come back by then is a ControllerError
// kConnectionLost.
#pragma once

#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "instruments/device.h"
#include "instruments/packet_transport.h"
#include "instruments/transport.h"
#include "robots/ur_codec.h"

namespace armsig::robots {

struct UrOptions {
  std::string host;
  unsigned short rtde_port = ur::rtde::kPort, primary_port = ur::primary::kPrimaryPort,
                 secondary_port = ur::primary::kSecondaryPort,
                 dashboard_port = ur::dashboard::kPort;
  bool can_move = false;
  // movej's joint speed and acceleration of the leading joint (URScript's defaults).
  double speed_rad_s = 1.05, acceleration_rad_s2 = 1.4;
  // RTDE output frequency; 0: the controller's highest (125 Hz CB3, 500 Hz e-Series).
  double frequency_hz = 0.0;
  // The arm stands when no joint turns faster than this over `still_window_s` of the
  // controller's clock (at least three packages).
  double still_speed_rad_s = 2e-4;
  double still_window_s = 0.03;
  // A move has arrived when every joint is this close to its target.
  double arrive_tolerance_rad = 1e-4;
  // A move the arm has not begun after this much of the controller's time was not run.
  double start_timeout_s = 2.0;
};

class UrController : public instruments::RobotController {
 public:
  // The transports are made from the options' host and ports; tests may hand their own.
  explicit UrController(UrOptions options, instruments::RetryPolicy policy = {});
  UrController(UrOptions options, instruments::RetryPolicy policy, std::unique_ptr<instruments::PacketTransport> rtde,
               std::unique_ptr<instruments::PacketTransport> primary, std::unique_ptr<instruments::PacketTransport> secondary,
               std::unique_ptr<instruments::LineTransport> dashboard);
  ~UrController() override;

  const std::string& name() const override { return name_; }
  Eigen::VectorXd ReadJointsRad() override { return ReadStampedJoints().joints_rad; }
  instruments::StampedJoints ReadStampedJoints() override;
  bool CanMove() const override { return options_.can_move; }
  void MoveTo(const Eigen::VectorXd& joints_rad) override;
  std::optional<instruments::ControllerIdentity> Identify() override;
  std::optional<instruments::ControllerKinematics> Kinematics() override;
  void CheckReady() override;
  void ClearProtectiveStop() override;
  bool StreamsJoints() const override { return true; }
  // One `movej` (or, for linear motion, `movel` to the waypoint's joints) line per waypoint
  // on the secondary interface, the next sent as the arm arrives at the one before (within
  // arrive_tolerance_rad: it does not wait to stand still), every RTDE package to `each`.
  void Sweep(const std::vector<Eigen::VectorXd>& waypoints, const instruments::SweepMotion& motion,
             const std::function<void(const instruments::JointSample&)>& each) override;
  void SetInterrupt(const std::atomic<bool>* flag) override;

  // What RTDE was set up with (after the first call that used it).
  double frequency_hz() const { return frequency_hz_; }
  const std::optional<ur::SoftwareVersion>& version() const { return version_; }

  // One RTDE data package, decoded.
  struct Sample {
    double timestamp_s = 0.0;
    Eigen::Matrix<double, 6, 1> q = Eigen::Matrix<double, 6, 1>::Zero(),
                                qd = Eigen::Matrix<double, 6, 1>::Zero();
    int robot_mode = 0, safety_mode = 0, runtime_state = 0;
  };
  struct Statistics {
    int rtde_setups = 0, reconnects = 0, streams = 0, packages = 0, moves = 0, text_messages = 0;
    double last_move_s = 0.0;  // the controller's time the last move took
  };
  const Statistics& statistics() const { return stats_; }
  // The controller's last text message (RTDE or secondary), "" when none.
  const std::string& last_message() const { return last_message_; }

 private:
  // Streams RTDE packages to `each` (true: done) by `deadline` (which `each` may move on),
  // reconnecting on a lost connection; the stream is paused again however it ends.
  template <typename Each>
  void Stream(instruments::Deadline& deadline, const char* what, Each&& each);
  // Runs attempt() until it returns by `deadline`: a transport failure closes `transport` and
  // tries again after reconnect_delay; past the deadline, kConnectionLost naming `interface`.
  template <typename F>
  auto Reconnecting(instruments::TransportBase& transport, const std::string& interface, instruments::Deadline deadline,
                    F&& attempt);
  void SetUpRtde(instruments::Deadline deadline);
  ur::rtde::Package RtdeAnswer(ur::rtde::Type type, instruments::Deadline deadline);
  void PauseStream(instruments::Deadline deadline);
  Sample SampleOf(const ur::rtde::DataPackage& data) const;
  // Throws the ControllerError a sample's modes mean (stops, the arm not running).
  void CheckSample(const Sample& s) const;
  std::string Dashboard(const std::string& command, instruments::Deadline deadline);
  void SendScript(const std::string& line, instruments::Deadline deadline);
  void ReadPrimary(instruments::Deadline deadline);
  [[noreturn]] void ConnectionLost(const std::string& interface, const std::string& why) const;

  UrOptions options_;
  instruments::RetryPolicy policy_;
  std::string name_;
  std::unique_ptr<instruments::PacketTransport> rtde_, primary_, secondary_;
  std::unique_ptr<instruments::LineTransport> dashboard_;
  bool rtde_ready_ = false;
  bool dashboard_ready_ = false;
  std::vector<ur::rtde::ValueType> recipe_types_;
  uint8_t recipe_ = 0;
  double frequency_hz_ = 0.0;
  std::optional<ur::SoftwareVersion> version_;             // URControl (RTDE)
  std::optional<ur::SoftwareVersion> polyscope_;           // the dashboard's
  std::optional<instruments::ControllerKinematics> kinematics_;         // primary interface
  std::optional<ur::primary::VersionMessage> primary_version_;
  std::string last_message_;
  Statistics stats_;
};

// The output recipe the driver sets up, in order.
const std::vector<std::string>& UrOutputRecipe();

}  // namespace armsig::robots
