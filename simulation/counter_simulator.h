// A virtual encoder counter box on a pseudo-terminal (robots/robot_codec.h): one
// channel reading one joint of the VirtualLab's robot.
#pragma once

#include <optional>
#include <string>

#include "robots/robot_codec.h"
#include "simulation/line_simulator.h"
#include "simulation/virtual_lab.h"

namespace armsig::simulation {

// One QSB-style counter channel reading one joint's encoder.
class CounterSimulator : public LineSimulator {
 public:
  CounterSimulator(VirtualLab& lab, int joint, robots::EncoderCalibration calibration,
                   std::string link_path, SimulatorOptions options = {});
  // Stops the io thread before this part of the object goes: it calls Handle and
  // FloodLine.
  ~CounterSimulator() override { Stop(); }

 protected:
  std::optional<Response> Handle(const std::string& line, const FaultSpec& fault) override;
  std::string FloodLine(const std::string& request, int64_t k) override;

 private:
  VirtualLab& lab_;
  int joint_;
  robots::EncoderCalibration calibration_;
};

}  // namespace armsig::simulation
