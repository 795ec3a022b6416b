// `armsig instrument probe|read`: one exchange with one instrument or robot controller.
#pragma once

#include <string>
#include <vector>

namespace armsig::workflows {

struct InstrumentRequest {
  std::string action = "read";  // probe | read
  std::string protocol = "geocom";
  std::string port, tcp;  // a serial port (or pty) path, or HOST:PORT (a controller: HOST[:PORT])
  // A network controller's other ports, KEY=PORT (its lab-file keys: primary_port=30001).
  std::vector<std::string> controller_ports;
  unsigned baud = 19200;
  bool crc = false, distance = false, json = false;
  int timeout_ms = 3000;  // the whole exchange, retries included
};

// Identifies the instrument (probe) or takes one reading (read; a controller's joints for
// val/as and the network controllers) and returns what to print: one line, or one JSON
// object with --json. A network controller (ur, …) is probed for its model, serial number,
// software and (UR) kinematics checksum; `--tcp HOST[:PORT]` names its host and the port of
// its lab-file key NetworkControllerProtocol::tcp_port (UR: the dashboard server's, 29999
// when not given), its other ports their defaults or `controller_ports`. An instrument that
// keeps failing throws instruments::InstrumentError (its code and the device named); a
// malformed request is an InputError.
std::string QueryInstrument(const InstrumentRequest& request);

}  // namespace armsig::workflows
