#include "instruments/device.h"

#include <fmt/format.h>

#include <cmath>
#include <numbers>

#include "core/plausibility.h"

namespace armsig::instruments {

namespace {

std::string RangeMessage(const std::string& quantity, double value, double min, double max,
                         const std::string& unit) {
  return fmt::format("{} = {} {} is no reading: expected {} to {} {}", quantity, value, unit, min,
                     max, unit);
}

}  // namespace

ReadingRangeError::ReadingRangeError(const std::string& device, std::string quantity, double value,
                                     double min, double max, const std::string& unit)
    : InstrumentError(device, grc::kComCantDecode, RangeMessage(quantity, value, min, max, unit)),
      quantity_(std::move(quantity)),
      value_(value),
      min_(min),
      max_(max) {}

ControllerError::ControllerError(Kind kind, std::string controller, const std::string& what,
                                 std::string action)
    : InstrumentError(std::move(controller), 4000 + static_cast<int>(kind),
                      std::string(KindName(kind)) + ": " + what + "; " + action),
      kind_(kind),
      what_(what),
      action_(std::move(action)) {}

const char* KindName(ControllerError::Kind kind) {
  using K = ControllerError::Kind;
  switch (kind) {
    case K::kProtectiveStop: return "protective stop";
    case K::kEmergencyStop: return "emergency stop";
    case K::kNotRemote: return "not in remote control";
    case K::kNotRunning: return "not running";
    case K::kArmMoving: return "arm moving";
    case K::kVersionRefused: return "protocol version refused";
    case K::kConnectionLost: return "connection lost";
    case K::kMoveRefused: return "move refused";
  }
  return "controller fault";
}

StampedJoints RobotController::ReadStampedJoints() {
  StampedJoints s;
  s.joints_rad = ReadJointsRad();
  s.received = std::chrono::system_clock::now();
  return s;
}

void RobotController::ClearProtectiveStop() {
  throw ControllerError(ControllerError::Kind::kProtectiveStop, name(),
                        "armsig cannot clear a protective stop on this controller",
                        "clear it on the controller's pendant");
}

void RobotController::Sweep(const std::vector<Eigen::VectorXd>&, const SweepMotion&,
                            const std::function<void(const JointSample&)>&) {
  throw ControllerError(ControllerError::Kind::kMoveRefused, name(),
                        "this controller does not stream its joints, so it cannot be measured "
                        "on the move",
                        "capture stop-and-go (without --on-the-move), or use a controller "
                        "that streams its joints (protocol: ur)");
}

void CheckAngles(const std::string& device, double hz_rad, double v_rad) {
  // The one rule for circle readings (core/plausibility.h), as in files: [0, 2π], 2π itself
  // being what a value just below it rounds to.
  constexpr double kFull = plausible::kFullCircleRad;
  if (!plausible::IsPlausible(plausible::Quantity::kCircleReading, hz_rad))
    throw ReadingRangeError(device, "Hz", hz_rad, 0.0, kFull, "rad");
  if (!plausible::IsPlausible(plausible::Quantity::kZenithAngle, v_rad))
    throw ReadingRangeError(device, "V (zenith angle)", v_rad, 0.0, kFull, "rad");
}

void CheckDistance(const std::string& device, double distance_mm) {
  // 0: no distance measured; else a distance by the rule files follow.
  if (distance_mm != 0.0 && !plausible::IsPlausible(plausible::Quantity::kDistance, distance_mm))
    throw ReadingRangeError(device, "slope distance", distance_mm, 0.0, kMaxDistanceMm, "mm");
}

void CheckJoints(const std::string& device, const Eigen::VectorXd& joints_rad) {
  for (Eigen::Index j = 0; j < joints_rad.size(); ++j) {
    const double deg = joints_rad(j) * 180.0 / std::numbers::pi;
    if (!(std::abs(deg) <= kMaxJointDeg)) {
      throw ReadingRangeError(device, "joint " + std::to_string(j + 1), deg, -kMaxJointDeg,
                              kMaxJointDeg, "deg");
    }
  }
}

}  // namespace armsig::instruments
