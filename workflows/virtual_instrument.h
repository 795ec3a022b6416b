// `armsig instrument simulate`: one virtual instrument or controller on a pseudo-terminal,
// for trying a driver, a cable set-up or a third-party program by hand.
#pragma once

#include <memory>
#include <string>

#include "simulation/simulators.h"

namespace armsig::workflows {

// The virtual lab behind it (a PUMA 760 with the paper's Table 3 errors in one fixed
// configuration, one station 3 m away) and the simulator speaking `protocol` (geocom,
// gsi, val or as) on a pseudo-terminal reachable as `link`.
struct VirtualInstrument {
  std::unique_ptr<simulation::VirtualLab> lab;
  std::unique_ptr<simulation::LineSimulator> simulator;
};

// Started; an unknown protocol is an InputError naming it.
VirtualInstrument StartVirtualInstrument(const std::string& protocol, const std::string& link);

}  // namespace armsig::workflows
