// Robot joint readers: VAL-family controllers (PUMA VAL II, Kawasaki AS) at their
// monitor prompt, and quadrature encoder-counter boxes, each over line transports.
#pragma once

#include <memory>
#include <vector>

#include "instruments/device.h"
#include "robots/robot_codec.h"
#include "instruments/transport.h"

namespace armsig::robots {

// The longest monitor line (a WHERE row, an error message) and the most lines a reply
// may have before its prompt (WHERE: echo, two headers, two rows); beyond either the
// controller is not answering the command (a flood).
inline constexpr size_t kMaxMonitorLineBytes = 256;
inline constexpr int kMaxMonitorReplyLines = 64;
// The longest counter-box reply ("r0E0000ABCD12345678!").
inline constexpr size_t kMaxCounterLineBytes = 64;
// A move may take this many times the policy's timeout.
inline constexpr int kMoveTimeoutFactor = 10;

// VAL-family controller: WHERE (joints in degrees) and, where the controller accepts
// it, DO JMOVE #[j1,…,jn] (Kawasaki AS syntax). A reading is bounded by the policy's
// deadline; joints beyond ±kMaxJointDeg are refused (ReadingRangeError).
class ValController : public instruments::RobotController {
 public:
  ValController(std::unique_ptr<instruments::LineTransport> transport, bool can_move, instruments::RetryPolicy policy = {});
  const std::string& name() const override { return transport_->name(); }
  Eigen::VectorXd ReadJointsRad() override;
  bool CanMove() const override { return can_move_; }
  void MoveTo(const Eigen::VectorXd& joints_rad) override;
  void SetInterrupt(const std::atomic<bool>* flag) override { transport_->SetInterrupt(flag); }

 private:
  // Sends a command and collects the lines up to the monitor prompt, by `deadline`.
  std::string Command(const MonitorCommand& command, instruments::Deadline deadline);
  std::unique_ptr<instruments::LineTransport> transport_;
  bool can_move_;
  instruments::RetryPolicy policy_;
};

// One QSB-style counter channel per joint ("R0E" → "r0E<count>!"). The channels are
// read one after another within one deadline (RetryPolicy::timeout).
class CounterBox : public instruments::RobotController {
 public:
  CounterBox(std::vector<std::unique_ptr<instruments::LineTransport>> channels, EncoderCalibration calibration,
             instruments::RetryPolicy policy = {});
  const std::string& name() const override { return name_; }
  Eigen::VectorXd ReadJointsRad() override;
  Eigen::VectorXd ReadCounts();
  bool CanMove() const override { return false; }
  void MoveTo(const Eigen::VectorXd&) override;
  void SetInterrupt(const std::atomic<bool>* flag) override {
    for (auto& c : channels_) c->SetInterrupt(flag);
  }

 private:
  std::vector<std::unique_ptr<instruments::LineTransport>> channels_;
  EncoderCalibration calibration_;
  instruments::RetryPolicy policy_;
  std::string name_;
};

}  // namespace armsig::robots
