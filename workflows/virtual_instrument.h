// `armsig instrument simulate`: one virtual instrument or controller on a pseudo-terminal,
// for trying a driver, a cable set-up or a third-party program by hand.
#pragma once

#include <memory>
#include <string>

#include "simulation/simulators.h"

namespace armsig::workflows {

// The virtual lab behind it (a PUMA 760 with the paper's Table 3 errors in one fixed
// configuration, one station 3 m away) and the simulator speaking `protocol` (geocom,
// gsi, val or as) on a pseudo-terminal reachable as `link`, or (emscon) a virtual laser
// tracker listening on `tcp` (HOST:PORT, e.g. 127.0.0.1:7000).
struct VirtualInstrument {
  std::unique_ptr<simulation::VirtualLab> lab;
  std::unique_ptr<simulation::Simulator> simulator;
};

// Started; an unknown protocol, or emscon without a valid HOST:PORT, is an InputError
// naming it.
VirtualInstrument StartVirtualInstrument(const std::string& protocol, const std::string& link,
                                         const std::string& tcp = "");

}  // namespace armsig::workflows
