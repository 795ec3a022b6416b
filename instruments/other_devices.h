// GSI Online theodolites, VAL-family robot controllers (PUMA VAL II, Kawasaki AS) and
// quadrature encoder-counter boxes, each over line transports.
#pragma once

#include <memory>
#include <vector>

#include "instruments/device.h"
#include "instruments/gsi_codec.h"
#include "instruments/robot_codec.h"
#include "instruments/transport.h"

namespace armsig::instruments {

// GSI Online (TPS100…1100, Wild T2000 class): GET/M/WI21 triggers a measurement and
// returns Hz, GET/I/WI22 the V of the same measurement, GET/M/WI31 a distance. No
// transaction ids: each reply's word index must be the one asked for, and after a
// timeout the line is drained before the next request.
class GsiOnlineDevice : public DistanceInstrument {
 public:
  GsiOnlineDevice(std::unique_ptr<LineTransport> transport, RetryPolicy policy = {});
  const std::string& name() const override { return transport_->name(); }
  DeviceInfo Identify() override;
  Reading MeasureAngles() override;
  Reading MeasureDistanceAndAngles() override;
  int Face() override;               // from V (> 200 gon = face II)
  void ChangeFace() override;        // not in GSI Online: InstrumentError
  bool CompensatorOn() override;     // not in GSI Online: InstrumentError
  gsi::Word Get(char mode, int wi);  // GET/<mode>/WI<wi> with retries

 private:
  std::unique_ptr<LineTransport> transport_;
  RetryPolicy policy_;
};

// VAL-family controller: WHERE (joints in degrees) and, where the controller accepts
// it, DO JMOVE #[j1,…,jn] (Kawasaki AS syntax).
class ValController : public RobotController {
 public:
  ValController(std::unique_ptr<LineTransport> transport, bool can_move, RetryPolicy policy = {});
  const std::string& name() const override { return transport_->name(); }
  Eigen::VectorXd ReadJointsRad() override;
  bool CanMove() const override { return can_move_; }
  void MoveTo(const Eigen::VectorXd& joints_rad) override;

 private:
  // Sends a command and collects lines up to the monitor prompt ('.' or '>').
  std::string Command(const std::string& command, Millis timeout);
  std::unique_ptr<LineTransport> transport_;
  bool can_move_;
  RetryPolicy policy_;
};

// One QSB-style counter channel per joint ("R0E" → "r0E<count>!").
class CounterBox : public RobotController {
 public:
  CounterBox(std::vector<std::unique_ptr<LineTransport>> channels, EncoderCalibration calibration,
             RetryPolicy policy = {});
  const std::string& name() const override { return name_; }
  Eigen::VectorXd ReadJointsRad() override;
  Eigen::VectorXd ReadCounts();
  bool CanMove() const override { return false; }
  void MoveTo(const Eigen::VectorXd&) override;

 private:
  std::vector<std::unique_ptr<LineTransport>> channels_;
  EncoderCalibration calibration_;
  RetryPolicy policy_;
  std::string name_;
};

}  // namespace armsig::instruments
