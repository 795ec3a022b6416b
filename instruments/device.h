// Small device interfaces the acquisition layer uses without knowing the protocol.
#pragma once

#include <Eigen/Core>
#include <chrono>
#include <optional>
#include <stdexcept>
#include <string>

#include "core/types.h"

namespace armsig::instruments {

struct DeviceInfo {
  std::string name, serial, firmware;
};

// One measurement as the instrument gave it. A warning code that still carries valid
// data (GeoCOM 1283/1284) is kept in return_code; a reading is never invented.
struct Reading {
  AngleReading angles;
  std::optional<double> distance_mm;
  int return_code = 0;
  std::string note;  // e.g. "TMC_ACCURACY_GUARANTEE: data valid, accuracy not guaranteed"
  std::chrono::system_clock::time_point time;
};

// The instrument answered, but with an error code: no data.
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

class Theodolite {
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

class RobotController {
 public:
  virtual ~RobotController() = default;
  virtual const std::string& name() const = 0;
  virtual Eigen::VectorXd ReadJointsRad() = 0;
  virtual bool CanMove() const = 0;
  virtual void MoveTo(const Eigen::VectorXd& joints_rad) = 0;
};

// How a driver retries: busy codes and timeouts, then gives up with a typed error.
struct RetryPolicy {
  int attempts = 3;
  std::chrono::milliseconds timeout{3000};
  std::chrono::milliseconds busy_delay{100};
  std::chrono::milliseconds reconnect_delay{200};
};

}  // namespace armsig::instruments
