// A virtual robot controller's monitor on a pseudo-terminal (VAL II / Kawasaki AS,
// robots/robot_codec.h): WHERE reads the VirtualLab's robot, DO JMOVE moves it.
#pragma once

#include <optional>
#include <string>

#include "robots/robot_codec.h"
#include "simulation/line_simulator.h"
#include "simulation/virtual_lab.h"

namespace armsig::simulation {

// VAL II / Kawasaki AS monitor: WHERE and DO JMOVE #[…].
class ValSimulator : public LineSimulator {
 public:
  using Layout = robots::MonitorDialect;
  ValSimulator(VirtualLab& lab, std::string link_path, Layout layout = Layout::kKawasakiAs,
               SimulatorOptions options = {});
  // Stops the io thread before this part of the object goes: it calls Handle and
  // FloodLine.
  ~ValSimulator() override { Stop(); }

 protected:
  std::optional<Response> Handle(const std::string& line, const FaultSpec& fault) override;
  std::string FloodLine(const std::string& request, int64_t k) override;

 private:
  VirtualLab& lab_;
  Layout layout_;
};

}  // namespace armsig::simulation
