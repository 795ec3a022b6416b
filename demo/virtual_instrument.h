// `armsig instrument simulate`: one virtual instrument or controller on a pseudo-terminal,
// for trying a driver, a cable set-up or a third-party program by hand.
#pragma once

#include <atomic>
#include <functional>
#include <memory>
#include <string>

#include "simulation/simulator.h"
#include "simulation/virtual_lab.h"

namespace armsig::demo {

// The virtual lab behind it (a PUMA 760 with the paper's Table 3 errors in one fixed
// configuration, one station 3 m away) and the simulator speaking `protocol` (geocom,
// gsi, val or as) on a pseudo-terminal reachable as `link`, or (emscon) a virtual laser
// tracker listening on `tcp` (HOST:PORT, e.g. 127.0.0.1:7000).
struct VirtualInstrument {
  std::unique_ptr<simulation::VirtualLab> lab;
  std::unique_ptr<simulation::Simulator> simulator;
};

// Started; an unknown protocol, or emscon without a valid HOST:PORT, is an InputError
// naming it, and so is a `link` path that exists and is not a link to a pseudo-terminal
// (armsig never replaces a user's file).
VirtualInstrument StartVirtualInstrument(const std::string& protocol, const std::string& link,
                                         const std::string& tcp = "");

// `armsig instrument simulate`: a virtual instrument that misbehaves on every request when
// `fault` names one (simulation::FaultNames()), served until `stop` is raised or
// `seconds` have passed (0 = until stopped). `started` is told the port's path once it
// answers. Returns the number of requests served.
struct SimulateRequest {
  std::string protocol = "geocom", link = "armsig-sim-port", tcp, fault;
  double seconds = 0.0;
  const std::atomic<bool>* stop = nullptr;
};
int64_t RunVirtualInstrument(const SimulateRequest& request,
                             const std::function<void(const std::string& path)>& started);

}  // namespace armsig::demo
