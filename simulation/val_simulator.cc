#include "simulation/val_simulator.h"

#include <cstdio>
#include <numbers>

namespace armsig::simulation {

ValSimulator::ValSimulator(VirtualLab& lab, std::string link_path, Layout layout,
                           SimulatorOptions options)
    : LineSimulator(std::move(link_path), options), lab_(lab), layout_(layout) {}

std::optional<LineSimulator::Response> ValSimulator::Handle(const std::string& line,
                                                            const FaultSpec& fault) {
  const std::string echo = line + "\r\n";
  const std::string prompt = robots::FormatMonitorPrompt(layout_);
  if (fault.fault == Fault::kErrorCode) {
    return Response{echo +
                        robots::FormatMonitorError(
                            1000, "Cannot execute program because motor power is OFF.") +
                        prompt,
                    options_.angle_latency};
  }
  const auto command = robots::ParseMonitorCommand(line);
  if (!command) {
    return Response{echo + robots::FormatMonitorError(2000, "Unknown command.") + prompt,
                    std::chrono::milliseconds(5)};
  }
  const double to_deg = 180.0 / std::numbers::pi;
  if (command->kind == robots::MonitorCommand::Kind::kWhere &&
      fault.fault == Fault::kOtherReply) {
    return Response{echo + prompt, options_.angle_latency};  // what a move prints
  }
  if (command->kind == robots::MonitorCommand::Kind::kWhere) {
    Eigen::VectorXd q = lab_.Joints() * to_deg;
    if (fault.fault == Fault::kOutOfRange) q(0) = 1000.0;  // no joint turns that far
    const Eigen::Vector3d x = lab_.TruePosition("robot");
    Eigen::VectorXd pose(6);
    pose << x.x(), x.y(), x.z(), 0.0, 0.0, 0.0;
    return Response{echo + robots::FormatWhere(q, pose, layout_) + prompt,
                    options_.angle_latency};
  }
  if (command->joints_deg.size() != lab_.model().num_joints()) {
    return Response{
        echo + robots::FormatMonitorError(2008, "Wrong number of joint values.") + prompt,
        std::chrono::milliseconds(5)};
  }
  Eigen::VectorXd reached = command->joints_deg / to_deg;
  if (fault.fault == Fault::kStopShort && reached.size() >= 2) {
    reached(1) -= (reached(1) >= 0.0 ? 2.0 : -2.0) / to_deg;
  }
  lab_.SetJoints(reached);
  return Response{echo + prompt, options_.motion_latency};
}

std::string ValSimulator::FloodLine(const std::string&, int64_t k) {
  // Rows of numbers, never the prompt.
  char row[96];
  std::snprintf(row, sizeof row, "%9.3f %9.3f %9.3f %9.3f %9.3f %9.3f\r\n",
                static_cast<double>(k % 360), 1.0, 2.0, 3.0, 4.0, 5.0);
  return row;
}

}  // namespace armsig::simulation
