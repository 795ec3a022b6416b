// `armsig instrument probe|read`: one exchange with one instrument or robot controller.
#pragma once

#include <string>

namespace armsig::workflows {

struct InstrumentRequest {
  std::string action = "read";  // probe | read
  std::string protocol = "geocom";
  std::string port, tcp;  // a serial port (or pty) path, or HOST:PORT
  unsigned baud = 19200;
  bool crc = false, distance = false, json = false;
  int timeout_ms = 3000;  // the whole exchange, retries included
};

// Identifies the instrument (probe) or takes one reading (read; a controller's joints for
// val/as) and returns what to print: one line, or one JSON object with --json. An
// instrument that keeps failing throws instruments::InstrumentError (its code and the
// device named); a malformed request is an InputError.
std::string QueryInstrument(const InstrumentRequest& request);

}  // namespace armsig::workflows
