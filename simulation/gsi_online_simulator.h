// A virtual GSI Online theodolite on a pseudo-terminal (instruments/gsi_codec.h): GET and
// PUT of GSI words, angles and distances of its station of the VirtualLab.
#pragma once

#include <optional>
#include <string>

#include "simulation/line_simulator.h"
#include "simulation/virtual_lab.h"

namespace armsig::simulation {

// GSI Online theodolite (GSI-8 words; SET/137/1 switches to GSI-16).
class GsiOnlineSimulator : public LineSimulator {
 public:
  GsiOnlineSimulator(VirtualLab& lab, int station, std::string link_path,
                     SimulatorOptions options = {});
  // Stops the io thread before this part of the object goes: it calls Handle and
  // FloodLine.
  ~GsiOnlineSimulator() override { Stop(); }

 protected:
  std::optional<Response> Handle(const std::string& line, const FaultSpec& fault) override;
  std::string FloodLine(const std::string& request, int64_t k) override;

 private:
  VirtualLab& lab_;
  int station_;
  bool gsi16_ = false;
  AngleReading last_{};
  double last_distance_mm_ = 0.0;
};

}  // namespace armsig::simulation
