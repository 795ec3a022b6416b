#include "robots/ur_device.h"

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <cmath>
#include <numbers>

#include "core/text.h"

namespace armsig::robots {
using instruments::CheckJoints;
using instruments::MakeTcpTransport;
using instruments::Clock;
using instruments::ControllerError;
using instruments::ControllerIdentity;
using instruments::ControllerKinematics;
using instruments::Deadline;
using instruments::InstrumentError;
using instruments::LineTransport;
using instruments::Millis;
using instruments::PacketTransport;
using instruments::RetryPolicy;
using instruments::StampedJoints;
using instruments::TransportBase;
using instruments::TransportError;

namespace {

using ur::rtde::Type;
using Kind = ControllerError::Kind;

constexpr const char* kRecipe[] = {"timestamp",  "actual_q",    "actual_qd",
                                   "robot_mode", "safety_mode", "runtime_state"};
// A running stream sends a package every 2 or 8 ms; a second without one is a lost stream.
constexpr Millis kSilence{1000};
// A move not begun is refused only after this much wall time too (as much as the controller
// time it is given, UrOptions::start_timeout_s by default): a controller whose clock runs
// faster than the wall's (a virtual one) may take longer than its own seconds to plan a linear
// move on a loaded machine; a real one's clock is the wall's, so this changes nothing there.
constexpr auto kMinStartWait = std::chrono::milliseconds(2000);
// Pausing a stream as a call ends in a failure: bounded apart from the call's deadline.
constexpr Millis kPauseTime{500};

// The deadline of a stream passed while its packages still came (the arm kept moving, a
// move did not finish): the caller says what that means.
struct StreamDeadline {};

double Seconds(Clock::duration d) { return std::chrono::duration<double>(d).count(); }

}  // namespace

const std::vector<std::string>& UrOutputRecipe() {
  static const std::vector<std::string> recipe(std::begin(kRecipe), std::end(kRecipe));
  return recipe;
}

UrController::UrController(UrOptions options, RetryPolicy policy)
    : UrController(options, policy,
                   MakeFramedTcpTransport(options.host, options.rtde_port, ur::rtde::kFrames,
                                          policy.timeout),
                   MakeFramedTcpTransport(options.host, options.primary_port,
                                          ur::primary::kFrames, policy.timeout),
                   MakeFramedTcpTransport(options.host, options.secondary_port,
                                          ur::primary::kFrames, policy.timeout),
                   MakeTcpTransport(options.host, options.dashboard_port, policy.timeout)) {}

UrController::UrController(UrOptions options, RetryPolicy policy,
                           std::unique_ptr<PacketTransport> rtde,
                           std::unique_ptr<PacketTransport> primary,
                           std::unique_ptr<PacketTransport> secondary,
                           std::unique_ptr<LineTransport> dashboard)
    : options_(std::move(options)),
      policy_(policy),
      name_("UR " + options_.host),
      rtde_(std::move(rtde)),
      primary_(std::move(primary)),
      secondary_(std::move(secondary)),
      dashboard_(std::move(dashboard)) {
  dashboard_->SetMaxLineBytes(ur::dashboard::kMaxLineBytes);
}

UrController::~UrController() {
  // A stream left running would fill the controller's buffer: paused, quietly.
  try {
    if (rtde_->IsOpen() && rtde_ready_) PauseStream(Clock::now() + Millis(200));
  } catch (const std::exception&) {
  }
}

void UrController::SetInterrupt(const std::atomic<bool>* flag) {
  rtde_->SetInterrupt(flag);
  primary_->SetInterrupt(flag);
  secondary_->SetInterrupt(flag);
  dashboard_->SetInterrupt(flag);
}

void UrController::ConnectionLost(const std::string& interface, const std::string& why) const {
  throw ControllerError(Kind::kConnectionLost, name_,
                        fmt::format("{} did not answer: {}", interface, why),
                        "check that the controller is on and its network cable and address; "
                        "the session resumes where it stopped");
}

// --- RTDE ------------------------------------------------------------------------------

ur::rtde::Package UrController::RtdeAnswer(Type type, Deadline deadline) {
  for (;;) {
    const std::string frame = rtde_->ReadPacket(deadline);
    std::string why;
    const auto package = ur::rtde::Decode(frame, &why);
    if (!package) throw TransportError(TransportError::Kind::kBadFrame, rtde_->name(), why);
    if (package->type == static_cast<uint8_t>(type)) return *package;
    if (package->type == static_cast<uint8_t>(Type::kTextMessage)) {
      if (const auto text = ur::rtde::DecodeText(package->payload)) {
        last_message_ = text->message;
        ++stats_.text_messages;
        spdlog::debug("{}: RTDE message from {}: {}", name_, Printable(text->source),
                      Printable(text->message));
      }
    }
    // Data packages of a stream being paused, anything else: not the answer.
  }
}

void UrController::SetUpRtde(Deadline deadline) {
  if (rtde_ready_ && rtde_->IsOpen()) return;
  rtde_ready_ = false;
  if (!rtde_->IsOpen()) rtde_->Open();
  rtde_->Write(ur::rtde::RequestProtocolVersion(ur::rtde::kProtocolVersion), deadline);
  const auto accepted = ur::rtde::DecodeAccepted(RtdeAnswer(Type::kRequestProtocolVersion, deadline).payload);
  if (!accepted) throw InstrumentError(name_, 3074, "RTDE: the answer to the protocol version is no answer");
  if (!*accepted) {
    throw ControllerError(Kind::kVersionRefused, name_,
                          "the controller refused RTDE protocol version 2",
                          "armsig reads joints over RTDE protocol version 2 (output recipes with "
                          "a frequency): update the controller's software (PolyScope)");
  }
  rtde_->Write(ur::rtde::GetUrControlVersion(), deadline);
  version_ = ur::rtde::DecodeUrControlVersion(RtdeAnswer(Type::kGetUrControlVersion, deadline).payload);
  if (!version_) throw InstrumentError(name_, 3074, "RTDE: the URControl version answer is no version");
  const double highest = version_->ESeries() ? ur::rtde::kESeriesMaxHz : ur::rtde::kCb3MaxHz;
  frequency_hz_ = options_.frequency_hz > 0.0 ? std::min(options_.frequency_hz, highest) : highest;
  rtde_->Write(ur::rtde::SetupOutputs(frequency_hz_, UrOutputRecipe()), deadline);
  const auto setup =
      ur::rtde::DecodeSetupOutputsAnswer(RtdeAnswer(Type::kSetupOutputs, deadline).payload);
  if (!setup || setup->types.size() != UrOutputRecipe().size()) {
    throw InstrumentError(name_, 3074,
                          fmt::format("RTDE: the answer to the output recipe names {} types for "
                                      "its {} variables",
                                      setup ? setup->types.size() : 0, UrOutputRecipe().size()));
  }
  recipe_types_.clear();
  for (size_t k = 0; k < setup->types.size(); ++k) {
    const std::string& variable = UrOutputRecipe()[k];
    const std::string& type = setup->types[k];
    if (type == "NOT_FOUND") {
      throw ControllerError(
          Kind::kVersionRefused, name_,
          fmt::format("the controller answered NOT_FOUND for RTDE output {} (URControl {})",
                      Quoted(variable), version_->Text()),
          "its software does not offer that output: update the controller's software (PolyScope)");
    }
    const auto parsed = ur::rtde::ValueTypeOf(type);
    if (!parsed || parsed != ur::rtde::OutputType(variable)) {
      throw InstrumentError(name_, 3074,
                            fmt::format("RTDE output {} comes as {}, the guide's type is {}",
                                        Quoted(variable), Printable(type),
                                        ur::rtde::ValueTypeName(*ur::rtde::OutputType(variable))));
    }
    recipe_types_.push_back(*parsed);
  }
  if (setup->recipe == 0) throw InstrumentError(name_, 3074, "RTDE: the controller refused the output recipe");
  recipe_ = setup->recipe;
  rtde_ready_ = true;
  ++stats_.rtde_setups;
  spdlog::debug("{}: RTDE protocol 2, URControl {}, outputs at {} Hz (recipe {})", name_,
                version_->Text(), frequency_hz_, recipe_);
}

void UrController::PauseStream(Deadline deadline) {
  rtde_->Write(ur::rtde::Pause(), deadline);
  RtdeAnswer(Type::kPause, deadline);
}

UrController::Sample UrController::SampleOf(const ur::rtde::DataPackage& data) const {
  Sample s;
  s.timestamp_s = data.values[0][0];
  for (int k = 0; k < 6; ++k) {
    s.q(k) = data.values[1][k];
    s.qd(k) = data.values[2][k];
  }
  s.robot_mode = static_cast<int>(data.values[3][0]);
  s.safety_mode = static_cast<int>(data.values[4][0]);
  s.runtime_state = static_cast<int>(data.values[5][0]);
  return s;
}

template <typename Each>
void UrController::Stream(Deadline& deadline, const char* what, Each&& each) {
  std::string last = "no attempt before the deadline";
  for (int attempt = 0; Clock::now() < deadline;
       ++attempt) {
    try {
      if (attempt > 0) {
        ++stats_.reconnects;
        rtde_->Close();
        rtde_ready_ = false;
        rtde_->Pause(policy_.reconnect_delay, deadline);
      }
      SetUpRtde(deadline);
      rtde_->Write(ur::rtde::Start(), deadline);
      const auto started = ur::rtde::DecodeAccepted(RtdeAnswer(Type::kStart, deadline).payload);
      if (!started || !*started)
        throw InstrumentError(name_, 3074, "RTDE: the controller did not start the stream");
      ++stats_.streams;
      try {
        int packages = 0;
        for (bool done = false; !done;) {
          if (Clock::now() >= deadline) throw StreamDeadline{};
          std::string frame;
          try {
            frame = rtde_->ReadPacket(std::min(deadline, Clock::now() + kSilence));
          } catch (const TransportError& e) {
            // The deadline came while the packages flowed: the caller's verdict, not the
            // connection's.
            if (e.kind() == TransportError::Kind::kTimeout && packages > 0 &&
                Clock::now() >= deadline)
              throw StreamDeadline{};
            throw;
          }
          std::string why;
          const auto package = ur::rtde::Decode(frame, &why);
          if (!package) throw TransportError(TransportError::Kind::kBadFrame, rtde_->name(), why);
          if (package->type == static_cast<uint8_t>(Type::kTextMessage)) {
            if (const auto text = ur::rtde::DecodeText(package->payload)) last_message_ = text->message;
            continue;
          }
          if (package->type != static_cast<uint8_t>(Type::kDataPackage)) continue;
          const auto data = ur::rtde::DecodeData(package->payload, recipe_types_, &why);
          if (!data || data->recipe != recipe_)
            throw TransportError(TransportError::Kind::kBadFrame, rtde_->name(),
                                 data ? "a data package of another recipe" : why);
          ++stats_.packages;
          ++packages;
          done = each(SampleOf(*data));
        }
      } catch (const TransportError&) {
        throw;  // the connection: reopened below
      } catch (...) {
        // The caller's verdict (a stop, a deadline): the stream paused before it goes up.
        try {
          PauseStream(Clock::now() + kPauseTime);
        } catch (const std::exception&) {
          rtde_->Close();
          rtde_ready_ = false;
        }
        throw;
      }
      PauseStream(deadline);
      return;
    } catch (const TransportError& e) {
      if (e.kind() == TransportError::Kind::kInterrupted) throw;
      last = e.message();
      spdlog::debug("{}: RTDE ({}) attempt {} failed: {}", name_, what, attempt + 1, last);
      rtde_->Close();
      rtde_ready_ = false;
    }
  }
  ConnectionLost("RTDE at " + rtde_->name(), last);
}

void UrController::CheckSample(const Sample& s) const {
  namespace sm = ur::rtde::safety_mode;
  const std::string mode = ur::rtde::SafetyModeName(s.safety_mode);
  switch (s.safety_mode) {
    case sm::kSystemEmergencyStop:
    case sm::kRobotEmergencyStop:
      throw ControllerError(Kind::kEmergencyStop, name_,
                            "an emergency stop is pressed (safety " + mode + ")",
                            "release the emergency stop button, then power the arm on and "
                            "release its brakes on the pendant, and resume the session");
    case sm::kProtectiveStop:
      throw ControllerError(Kind::kProtectiveStop, name_,
                            "the arm stopped itself (PROTECTIVE_STOP: a collision, a force or "
                            "a joint limit)",
                            "look at why, then unlock the protective stop on the pendant (or "
                            "let armsig clear it); the session goes on");
    case sm::kSafeguardStop:
    case sm::kAutomaticModeSafeguardStop:
    case sm::kSystemThreePositionEnablingStop:
      throw ControllerError(Kind::kProtectiveStop, name_,
                            "a safeguard stop (" + mode + ": the cell's safeguard is open)",
                            "close the safeguard (door, light curtain); the session goes on");
    case sm::kViolation:
    case sm::kFault:
      throw ControllerError(Kind::kNotRunning, name_,
                            "the safety system stopped the arm (safety " + mode + ")",
                            "restart the safety system on the pendant, then resume the session");
    default:
      break;
  }
  if (s.robot_mode != ur::rtde::robot_mode::kRunning) {
    const std::string robot = ur::rtde::RobotModeName(s.robot_mode);
    throw ControllerError(Kind::kNotRunning, name_,
                          "the arm is " + (robot.empty() ? std::to_string(s.robot_mode) : robot) +
                              ", not RUNNING",
                          "power the arm on and release its brakes on the pendant (ON, then "
                          "START), then resume the session");
  }
}

StampedJoints UrController::ReadStampedJoints() {
  Deadline deadline = Clock::now() + policy_.timeout;
  std::optional<double> still_since;
  int still_packages = 0;
  Sample last;
  double fastest = 0.0;
  Eigen::Index fastest_joint = 0;
  try {
    Stream(deadline, "joints", [&](const Sample& s) {
      CheckSample(s);
      last = s;
      Eigen::Index joint = 0;
      const double speed = s.qd.cwiseAbs().maxCoeff(&joint);
      if (speed >= options_.still_speed_rad_s) {
        still_since.reset();
        still_packages = 0;
        if (speed > fastest) {
          fastest = speed;
          fastest_joint = joint;
        }
        return false;
      }
      if (!still_since) still_since = s.timestamp_s;
      ++still_packages;
      return still_packages >= 3 && s.timestamp_s - *still_since >= options_.still_window_s;
    });
  } catch (const StreamDeadline&) {
    throw ControllerError(
        Kind::kArmMoving, name_,
        fmt::format("the arm kept moving for {:.1f} s (joint {} up to {:.3f} deg/s): no reading",
                    Seconds(policy_.timeout), fastest_joint + 1, fastest * 180.0 / std::numbers::pi),
        "stop whatever moves it (another program, the pendant, freedrive); armsig reads the "
        "joints only while the arm stands");
  }
  StampedJoints out;
  out.joints_rad = last.q;
  out.controller_time_s = last.timestamp_s;
  out.received = std::chrono::system_clock::now();
  CheckJoints(name_, out.joints_rad);
  return out;
}

// The longest linear leg a sweep's deadline allows for: no UR reaches farther than 1.3 m
// from its base, so no straight leg between two of its poses is longer than 2.6 m.
constexpr double kLongestLinearLegMm = 3000.0;

void UrController::Sweep(const std::vector<Eigen::VectorXd>& waypoints,
                         const instruments::SweepMotion& motion,
                         const std::function<void(const instruments::JointSample&)>& each) {
  if (!options_.can_move)
    throw InstrumentError(name_, 5, "this controller is not commanded by armsig (can_move: false)");
  if (waypoints.empty()) return;
  const double speed = motion.speed_rad_s, acceleration = motion.acceleration_rad_s2;
  if (motion.linear()) {
    if (!(motion.linear_speed_mm_s <= 5000.0) || !(motion.linear_acceleration_mm_s2 > 0.0))
      throw std::invalid_argument(fmt::format("{}: a linear sweep at {} mm/s, {} mm/s²", name_,
                                              motion.linear_speed_mm_s,
                                              motion.linear_acceleration_mm_s2));
  } else if (!(speed > 0.0 && speed <= options_.speed_rad_s * 3.0) || !(acceleration > 0.0)) {
    throw std::invalid_argument(fmt::format("{}: a sweep at {} rad/s, {} rad/s²", name_, speed,
                                            acceleration));
  }
  for (const auto& w : waypoints) {
    if (w.size() != 6)
      throw std::invalid_argument(fmt::format("{}: a UR has 6 joints, not {}", name_, w.size()));
    CheckJoints(name_, w);
  }
  CheckReady();
  size_t next = 0;  // the waypoint the arm goes to (sent), or the first to send
  bool sent = false;
  std::optional<double> arrived_since;
  int arrived_packages = 0;
  std::optional<double> sent_at;
  Clock::time_point sent_wall;
  Eigen::Matrix<double, 6, 1> from = Eigen::Matrix<double, 6, 1>::Zero();
  // The whole sweep's time on the controller's clock, with margin, on the wall (a linear
  // leg's length is the controller's to know: the longest any UR has).
  double duration = 0.0;
  for (size_t k = 1; k < waypoints.size(); ++k) {
    duration += motion.linear()
                    ? ur::MoveJDuration(kLongestLinearLegMm, motion.linear_acceleration_mm_s2,
                                        motion.linear_speed_mm_s) + 0.1
                    : ur::MoveJDuration((waypoints[k] - waypoints[k - 1]).cwiseAbs().maxCoeff(),
                                        acceleration, speed) + 0.1;
  }
  Deadline deadline = Clock::now() + policy_.timeout +
                      std::chrono::duration_cast<Clock::duration>(
                          std::chrono::duration<double>(1.5 * duration + 10.0));
  // A circular sweep's waypoints come in pairs (via point, target): one movec each.
  const size_t step = motion.circular ? 2 : 1;
  if (motion.circular && (!motion.linear() || waypoints.size() % 2 != 0))
    throw std::invalid_argument(fmt::format("{}: a circular sweep takes pairs of waypoints at a path "
                                            "speed, not {}", name_, waypoints.size()));
  const auto line = [&](size_t k) {
    const double a = motion.linear_acceleration_mm_s2 * 1e-3, v = motion.linear_speed_mm_s * 1e-3;
    if (motion.circular) return ur::MoveC(waypoints[k - 1], waypoints[k], a, v);
    return motion.linear() ? ur::MoveL(waypoints[k], a, v) : ur::MoveJ(waypoints[k], acceleration, speed);
  };
  next = step - 1;  // the first target
  try {
    Stream(deadline, "sweep", [&](const Sample& s) {
      CheckSample(s);
      each({s.timestamp_s, Eigen::VectorXd(s.q), Eigen::VectorXd(s.qd)});
      const Eigen::VectorXd& target = waypoints[next];
      if (!sent) {
        from = s.q;
        SendScript(line(next), deadline);
        ++stats_.moves;
        sent = true;
        sent_at.reset();
        sent_wall = Clock::now();
        return false;
      }
      if (!sent_at) sent_at = s.timestamp_s;
      const double off = (s.q - target).cwiseAbs().maxCoeff();
      if (off < options_.arrive_tolerance_rad) {
        if (next + step < waypoints.size()) {
          next += step;
          sent = false;  // the next line goes out with the next package
          return false;
        }
        // The last waypoint: done once the arm stands there.
        if (s.qd.cwiseAbs().maxCoeff() < options_.still_speed_rad_s) {
          if (!arrived_since) arrived_since = s.timestamp_s;
          if (++arrived_packages >= 3 && s.timestamp_s - *arrived_since >= options_.still_window_s)
            return true;
        }
        return false;
      }
      arrived_since.reset();
      arrived_packages = 0;
      const bool begun = (s.q - from).cwiseAbs().maxCoeff() > options_.arrive_tolerance_rad ||
                         s.runtime_state == ur::rtde::runtime_state::kPlaying;
      if (!begun && s.timestamp_s - *sent_at > options_.start_timeout_s &&
          Clock::now() - sent_wall > kMinStartWait) {
        throw ControllerError(
            Kind::kMoveRefused, name_,
            fmt::format("the controller did not begin the sweep's move {} of {} within {:g} s{}",
                        next + 1, waypoints.size(), options_.start_timeout_s,
                        last_message_.empty() ? ""
                                              : " (its last message: " + Printable(last_message_) + ")"),
            "check that no program is running on the pendant and that the controller takes "
            "programs from the network (remote control), then resume the session");
      }
      return false;
    });
  } catch (const StreamDeadline&) {
    throw ControllerError(Kind::kMoveRefused, name_,
                          fmt::format("the sweep did not end by its deadline (at waypoint {} of {})",
                                      next + 1, waypoints.size()),
                          "check the arm and the pendant, then resume the session");
  }
}

void UrController::MoveTo(const Eigen::VectorXd& target) {
  if (!options_.can_move)
    throw InstrumentError(name_, 5, "this controller is not commanded by armsig (can_move: false)");
  if (target.size() != 6)
    throw std::invalid_argument(fmt::format("{}: a UR has 6 joints, not {}", name_, target.size()));
  CheckJoints(name_, target);
  CheckReady();  // a stop, the arm not running, local mode: named before anything is sent
  ++stats_.moves;
  const std::string script = ur::MoveJ(target, options_.acceleration_rad_s2, options_.speed_rad_s);
  Deadline deadline = Clock::now() + policy_.timeout;
  bool sent = false;
  int sent_at_reconnects = 0;
  // The controller's time of the first package after the script was sent, and the wall time
  // it was sent: a move is called not begun only when both clocks say so (a virtual
  // controller's clock may run faster than the wall's).
  std::optional<double> sent_at;
  // The controller's time of the last package before the script: the move cannot have begun
  // earlier, so a move timed from it is never shorter than the arm took (the first package
  // after the script may arrive late on a loaded machine).
  double before_script = 0.0;
  Clock::time_point sent_wall;
  Eigen::Matrix<double, 6, 1> from = Eigen::Matrix<double, 6, 1>::Zero();
  std::optional<double> arrived_since, stopped_since;
  int arrived_packages = 0;
  bool arrived = false;  // stood at the target once
  int resent = 0;
  try {
    Stream(deadline, "move", [&](const Sample& s) {
      CheckSample(s);
      // A new connection: the move is sent again from where the arm is (the same target).
      if (!sent || sent_at_reconnects != stats_.reconnects) {
        from = s.q;
        const double duration = ur::MoveJDuration((target - s.q).cwiseAbs().maxCoeff(),
                                                  options_.acceleration_rad_s2, options_.speed_rad_s);
        // The controller's time is wall time on a real arm (a virtual one may run faster).
        deadline = std::max(deadline, Clock::now() + policy_.timeout +
                                          std::chrono::duration_cast<Clock::duration>(
                                              std::chrono::duration<double>(1.5 * duration + 2.0)));
        SendScript(script, deadline);
        sent = true;
        before_script = s.timestamp_s;
        sent_at.reset();
        sent_wall = Clock::now();
        sent_at_reconnects = stats_.reconnects;
        return false;
      }
      if (!sent_at) sent_at = s.timestamp_s;
      const double off = (s.q - target).cwiseAbs().maxCoeff();
      const bool still = s.qd.cwiseAbs().maxCoeff() < options_.still_speed_rad_s;
      if (off < options_.arrive_tolerance_rad && still) {
        if (!arrived_since) arrived_since = s.timestamp_s;
        arrived = true;
        ++arrived_packages;
        if (arrived_packages >= 3 && s.timestamp_s - *arrived_since >= options_.still_window_s) {
          stats_.last_move_s = s.timestamp_s - before_script;
          return true;
        }
        return false;
      }
      arrived_since.reset();
      arrived_packages = 0;
      if (arrived) {  // at the target, then moved away: not by this move
        Eigen::Index joint = 0;
        (s.q - target).cwiseAbs().maxCoeff(&joint);
        throw ControllerError(
            Kind::kArmMoving, name_,
            fmt::format("the arm reached its target, then joint {} moved {:.4f} deg away", joint + 1,
                        off * 180.0 / std::numbers::pi),
            "nothing else may move the arm during a capture (another program, the pendant, "
            "freedrive)");
      }
      const bool begun = (s.q - from).cwiseAbs().maxCoeff() > options_.arrive_tolerance_rad ||
                         !still || s.runtime_state == ur::rtde::runtime_state::kPlaying;
      const bool late = s.timestamp_s - *sent_at > options_.start_timeout_s &&
                        Clock::now() - sent_wall > kMinStartWait;
      if (!begun && late && resent == 0) {
        // A script can be lost with a connection the controller dropped as it was written:
        // sent once more on a new connection before the move is called refused.
        ++resent;
        secondary_->Close();
        sent = false;
        return false;
      }
      if (!begun && late) {
        throw ControllerError(
            Kind::kMoveRefused, name_,
            fmt::format("the controller did not begin the move within {:g} s{}",
                        options_.start_timeout_s,
                        last_message_.empty() ? "" : " (its last message: " + Printable(last_message_) + ")"),
            "check that no program is running on the pendant and that the controller takes "
            "programs from the network (remote control), then resume the session");
      }
      // Standing short of the target with no program running: the move was stopped.
      if (begun && still && s.runtime_state == ur::rtde::runtime_state::kStopped) {
        if (!stopped_since) stopped_since = s.timestamp_s;
        if (s.timestamp_s - *stopped_since > 10 * options_.still_window_s) {
          Eigen::Index joint = 0;
          (s.q - target).cwiseAbs().maxCoeff(&joint);
          throw ControllerError(
              Kind::kMoveRefused, name_,
              fmt::format("the move ended short of its target: joint {} stands {:.4f} deg off",
                          joint + 1, off * 180.0 / std::numbers::pi),
              "someone stopped the program (the pendant's stop button) or a limit held the arm; "
              "resume the session");
        }
      } else {
        stopped_since.reset();
      }
      return false;
    });
  } catch (const StreamDeadline&) {
    throw ControllerError(Kind::kMoveRefused, name_,
                          "the move did not end by its deadline (the arm still moving or not at "
                          "its target)",
                          "check the arm and the pendant, then resume the session");
  }
}

template <typename F>
auto UrController::Reconnecting(TransportBase& transport, const std::string& interface,
                                Deadline deadline, F&& attempt) {
  std::string last = "no attempt before the deadline";
  for (int tried = 0; Clock::now() < deadline; ++tried) {
    try {
      return attempt();
    } catch (const TransportError& e) {
      if (e.kind() == TransportError::Kind::kInterrupted) throw;
      last = e.message();
      // A late answer must never be taken for the next request's: a new connection.
      transport.Close();
      if (tried > 0) ++stats_.reconnects;
      transport.Pause(policy_.reconnect_delay, deadline);
    }
  }
  ConnectionLost(interface + " at " + transport.name(), last);
}

void UrController::SendScript(const std::string& line, Deadline deadline) {
  Reconnecting(*secondary_, "the secondary interface", deadline, [&] {
    if (!secondary_->IsOpen()) {
      secondary_->Open();
      // A connection the controller keeps sends its version message first: a script written
      // before it could go to a connection already being closed.
      for (;;) {
        std::string why;
        const auto m = ur::primary::Decode(secondary_->ReadPacket(deadline), &why);
        if (m && m->version) break;
      }
    } else {
      // The interface streams the robot's state (10 Hz): what piled up is not read.
      secondary_->Drain(Millis(0), std::min(deadline, Clock::now() + Millis(2)));
    }
    secondary_->Write(line, deadline);
  });
}

// --- Dashboard ---------------------------------------------------------------------------

std::string UrController::Dashboard(const std::string& command, Deadline deadline) {
  return Reconnecting(*dashboard_, "the dashboard server", deadline, [&]() -> std::string {
    if (!dashboard_ready_ || !dashboard_->IsOpen()) {
      dashboard_ready_ = false;
      dashboard_->Close();
      dashboard_->Open();
      const std::string welcome = dashboard_->ReadLine(deadline);
      if (welcome.rfind("Connected", 0) != 0) {
        throw InstrumentError(name_, 3074,
                              "the dashboard server at " + dashboard_->name() + " greeted with " +
                                  Quoted(Printable(welcome)) + ", not \"Connected: …\"");
      }
      dashboard_->Write("PolyscopeVersion\n", deadline);
      const std::string version = dashboard_->ReadLine(deadline);
      polyscope_ = ur::dashboard::PolyscopeVersion(version);
      if (!polyscope_) {
        throw InstrumentError(name_, 3074,
                              "the dashboard server's PolyscopeVersion is " +
                                  Quoted(Printable(version)));
      }
      dashboard_ready_ = true;
      if (command == "PolyscopeVersion") return version;
    }
    dashboard_->Write(command + "\n", deadline);
    return dashboard_->ReadLine(deadline);
  });
}

void UrController::CheckReady() {
  const Deadline deadline = Clock::now() + policy_.timeout;
  Dashboard("PolyscopeVersion", deadline);  // connects; the version decides the commands
  const bool e_series = polyscope_->ESeries();
  Sample s;
  const bool status = e_series && polyscope_->AtLeast(5, 4);
  const std::string safety_line = Dashboard(status ? "safetystatus" : "safetymode", deadline);
  const auto safety = ur::dashboard::Field(safety_line, status ? "Safetystatus" : "Safetymode");
  const auto safety_code = safety ? ur::rtde::SafetyModeFromName(*safety) : std::nullopt;
  if (!safety_code) {
    throw InstrumentError(name_, 3074, "the dashboard's safety answer is " + Quoted(Printable(safety_line)));
  }
  s.safety_mode = *safety_code;
  const std::string mode_line = Dashboard("robotmode", deadline);
  const auto mode = ur::dashboard::Field(mode_line, "Robotmode");
  const auto mode_code = mode ? ur::rtde::RobotModeFromName(*mode) : std::nullopt;
  if (!mode_code) {
    throw InstrumentError(name_, 3074, "the dashboard's robotmode answer is " + Quoted(Printable(mode_line)));
  }
  s.robot_mode = *mode_code;
  CheckSample(s);
  // Remote control exists on e-Series from 5.6; a CB3 takes programs from the network always.
  if (e_series && polyscope_->AtLeast(5, 6)) {
    const std::string remote_line = Dashboard("is in remote control", deadline);
    const auto remote = ur::dashboard::Boolean(remote_line);
    if (!remote) {
      throw InstrumentError(name_, 3074,
                            "the dashboard's remote-control answer is " + Quoted(Printable(remote_line)));
    }
    if (!*remote) {
      throw ControllerError(Kind::kNotRemote, name_,
                            "the controller is in local control: it runs no program sent over "
                            "the network",
                            "switch the pendant to Remote Control (the Local/Remote icon at its "
                            "top right; Settings > System > Remote Control enables it), then "
                            "resume the session");
    }
  }
}

void UrController::ClearProtectiveStop() {
  const Deadline deadline = Clock::now() + policy_.timeout;
  Dashboard("close safety popup", deadline);
  const std::string answer = Dashboard("unlock protective stop", deadline);
  if (answer.rfind("Protective stop releasing", 0) == 0) {
    spdlog::info("{}: protective stop unlocked from armsig", name_);
    return;
  }
  throw ControllerError(Kind::kProtectiveStop, name_,
                        "the controller did not unlock the protective stop: " + Printable(answer),
                        "a protective stop unlocks 5 s after it happened at the earliest; or "
                        "unlock it on the pendant");
}

// --- Primary interface and identity ------------------------------------------------------

void UrController::ReadPrimary(Deadline deadline) {
  Reconnecting(*primary_, "the primary interface", deadline, [&] {
    primary_->Close();
    primary_->Open();
    std::optional<ur::primary::VersionMessage> version;
    std::optional<ur::primary::KinematicsInfo> kinematics;
    // A new connection sends the version message, then the robot state at 10 Hz.
    while (!version || !kinematics) {
      const std::string frame = primary_->ReadPacket(deadline);
      std::string why;
      const auto message = ur::primary::Decode(frame, &why);
      if (!message) throw TransportError(TransportError::Kind::kBadFrame, primary_->name(), why);
      if (message->version) version = message->version;
      if (message->kinematics) kinematics = message->kinematics;
    }
    primary_->Close();
    primary_version_ = version;
    kinematics_ = kinematics->ToKinematics();
  });
}

std::optional<ControllerKinematics> UrController::Kinematics() {
  ReadPrimary(Clock::now() + policy_.timeout);  // read anew: a session checks it has not changed
  return kinematics_;
}

std::optional<ControllerIdentity> UrController::Identify() {
  const Deadline deadline = Clock::now() + policy_.timeout;
  ControllerIdentity id;
  id.protocol = "ur";
  id.vendor = "Universal Robots";
  id.software = Dashboard("PolyscopeVersion", deadline);
  // get robot model / get serial number: CB3 from 3.12, e-Series from 5.6.
  const bool named = polyscope_->ESeries() ? polyscope_->AtLeast(5, 6) : polyscope_->AtLeast(3, 12);
  if (named) {
    const std::string model = Dashboard("get robot model", deadline);
    if (!ur::dashboard::NotUnderstood(model)) id.model = model;
    const std::string serial = Dashboard("get serial number", deadline);
    if (!ur::dashboard::NotUnderstood(serial)) id.serial = serial;
  }
  ReadPrimary(deadline);
  id.kinematics_checksum = kinematics_->checksum;
  return id;
}

}  // namespace armsig::robots
