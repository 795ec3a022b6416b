#include "acquisition/lab.h"

#include "core/error.h"
#include "core/text.h"
#include "instruments/emscon_device.h"
#include "instruments/geocom_device.h"
#include "instruments/gsi_device.h"
#include "instruments/robot_controllers.h"

namespace armsig::acquisition {

using io::ControllerConfig;
using io::InstrumentConfig;
using io::LabConfig;
using io::SplitHostPort;

namespace {
std::unique_ptr<instruments::LineTransport> Transport(const std::string& port,
                                                      const std::string& tcp, unsigned baud) {
  if (!tcp.empty()) {
    const auto address = SplitHostPort(tcp);
    if (!address) {
      throw InputError({"tcp", 0, 0, ""},
                       Quoted(tcp) + ": expected HOST:PORT with a port from 1 to 65535");
    }
    return instruments::MakeTcpTransport(address->host, address->port);
  }
  if (port.empty()) throw InputError({"port", 0, 0, ""}, "give a serial port or HOST:PORT");
  instruments::SerialSettings s;
  s.path = port;
  s.baud = baud;
  return instruments::MakeSerialTransport(s);
}
}  // namespace

std::unique_ptr<instruments::DistanceInstrument> OpenInstrument(
    const InstrumentConfig& c, const instruments::RetryPolicy& policy) {
  if (c.protocol == "geocom") {
    return std::make_unique<instruments::GeoComDevice>(Transport(c.port, c.tcp, c.baud), policy,
                                                       c.crc);
  }
  if (c.protocol == "gsi") {
    return std::make_unique<instruments::GsiOnlineDevice>(Transport(c.port, c.tcp, c.baud), policy);
  }
  if (c.protocol == "emscon") {  // a laser tracker: binary packets over TCP only
    const auto address = SplitHostPort(c.tcp);
    if (!address) {
      throw InputError({"tcp", 0, 0, ""},
                       "protocol emscon needs --tcp HOST:PORT (port 1 to "
                       "65535; emScon servers listen on 700)");
    }
    instruments::EmsconOptions options;
    options.measurement_time_ms = c.measurement_time_ms;
    return std::make_unique<instruments::EmsconDevice>(
        instruments::MakeEmsconTcpTransport(address->host, address->port), policy, options);
  }
  throw InputError({"protocol", 0, 0, ""}, "unknown instrument protocol " + Quoted(c.protocol) +
                                               " (expected geocom, gsi or emscon)");
}

std::unique_ptr<instruments::RobotController> OpenController(
    const ControllerConfig& c, const instruments::RetryPolicy& policy) {
  if (c.protocol == "counter") {
    std::vector<std::unique_ptr<instruments::LineTransport>> ports;
    for (const auto& p : c.counter_ports) ports.push_back(Transport(p, "", c.baud));
    return std::make_unique<instruments::CounterBox>(std::move(ports), c.encoders, policy);
  }
  if (c.protocol == "val" || c.protocol == "as") {
    return std::make_unique<instruments::ValController>(Transport(c.port, "", c.baud), c.can_move,
                                                        policy);
  }
  throw InputError({"protocol", 0, 0, ""}, "unknown controller protocol " + Quoted(c.protocol) +
                                               " (expected val, as or counter)");
}

std::vector<std::unique_ptr<instruments::DistanceInstrument>> OpenInstruments(
    const LabConfig& lab) {
  std::vector<std::unique_ptr<instruments::DistanceInstrument>> out;
  for (const auto& c : lab.instruments) out.push_back(OpenInstrument(c, lab.policy));
  return out;
}

std::unique_ptr<instruments::RobotController> OpenController(const LabConfig& lab) {
  return OpenController(lab.controller, lab.policy);
}

}  // namespace armsig::acquisition
