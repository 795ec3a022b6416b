// A virtual Leica GeoCOM total station / theodolite on a pseudo-terminal: the ASCII RPC
// protocol (instruments/geocom_codec.h), angles and distances of its station of the
// VirtualLab.
#pragma once

#include <optional>
#include <string>

#include "simulation/line_simulator.h"
#include "simulation/virtual_lab.h"

namespace armsig::simulation {

// Leica GeoCOM total station / theodolite attached to one station of the lab.
class GeoComSimulator : public LineSimulator {
 public:
  GeoComSimulator(VirtualLab& lab, int station, std::string link_path,
                  SimulatorOptions options = {}, std::string instrument_name = "TDRA6000",
                  long serial = 358123);
  // Stops the io thread before this part of the object goes: it calls Handle and
  // FloodLine.
  ~GeoComSimulator() override { Stop(); }

 protected:
  std::optional<Response> Handle(const std::string& line, const FaultSpec& fault) override;
  std::string FloodLine(const std::string& request, int64_t k) override;

 private:
  VirtualLab& lab_;
  int station_;
  std::string name_;
  long serial_;
  bool distance_ready_ = false;
};

}  // namespace armsig::simulation
