// The fault matrix: every protocol's driver against its simulator over a real
// pseudo-terminal (Boost.Asio on both ends), the simulator misbehaving on every request
// (floods, an endless line, silence, partial frames, wrong transaction ids, CRC errors,
// busy codes, the port vanishing, another command's reply, readings out of range). Each
// case must end by the driver's deadline with a typed error and no reading. Shared by
// tests/simulation/faults_pty_test.cc (generous bounds) and bench/instruments_bench.cc
// (the figures in the README).
#pragma once

#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "instruments/device.h"
#include "simulation/simulator.h"
#include "simulation/virtual_lab.h"

namespace armsig::simulation {

// The name a fault has on the command line (`armsig instrument simulate --fault NAME`).
std::string FaultName(Fault fault);
std::optional<Fault> FaultFromName(std::string_view name);
// Every name FaultFromName knows, comma-separated.
std::string FaultNames();

enum class Protocol { kGeoCom, kGeoComCrc, kGsiOnline, kValII, kKawasakiAs, kCounter, kEmscon };
// geocom, geocom+crc, gsi, val, as, counter, emscon
std::string ProtocolName(Protocol protocol);

struct FaultCase {
  Protocol protocol = Protocol::kGeoCom;
  Fault fault = Fault::kNone;
  std::vector<int> codes;  // the typed error's code is one of these
  std::string name() const { return ProtocolName(protocol) + "/" + FaultName(fault); }
};
// Every protocol with every fault that applies to it.
std::vector<FaultCase> FaultMatrix();

struct FaultOutcome {
  double ms = 0.0;          // from the driver call to its end
  bool reading = false;     // the driver returned a reading: the case failed
  std::optional<int> code;  // the InstrumentError's code
  std::string error;        // what the error said (or the unexpected exception)
  int64_t flood_bytes = 0;  // bytes the simulator flooded during the call
};

// Starts the case's simulator at `link` on `lab` (a 6-joint robot seen from station 0;
// emscon: a virtual tracker on 127.0.0.1 at a free port, `link` unused), makes it
// misbehave on every request, and takes one reading through the driver (MeasureAngles or
// ReadJointsRad, what `armsig instrument read` calls) with `policy`.
FaultOutcome RunFaultCase(VirtualLab& lab, const FaultCase& fault_case, const std::string& link,
                          const instruments::RetryPolicy& policy);

}  // namespace armsig::simulation
