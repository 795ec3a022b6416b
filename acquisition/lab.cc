#include "acquisition/lab.h"

#include <charconv>

#include "core/error.h"
#include "core/text.h"
#include "instruments/emscon_device.h"
#include "instruments/geocom_device.h"
#include "instruments/gsi_device.h"
#include "instruments/kuka_controller.h"
#include "instruments/robot_controllers.h"
#include "instruments/ur_device.h"

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

namespace {

// The robot controllers reached over the network (io::NetworkControllerProtocols), each
// opened by its device: adding a controller is one entry here.
using NetworkOpener = std::unique_ptr<instruments::RobotController> (*)(
    const ControllerConfig&, const instruments::RetryPolicy&);
struct NetworkController {
  const char* protocol;
  NetworkOpener open;
};
std::unique_ptr<instruments::RobotController> OpenUr(const ControllerConfig& c,
                                                     const instruments::RetryPolicy& policy) {
  instruments::UrOptions o;
  o.host = c.host;
  o.rtde_port = c.Port("rtde_port");
  o.primary_port = c.Port("primary_port");
  o.secondary_port = c.Port("secondary_port");
  o.dashboard_port = c.Port("dashboard_port");
  o.can_move = c.can_move;
  return std::make_unique<instruments::UrController>(o, policy);
}

// ARMSIG's PTP velocity and acceleration (% of each axis's maximum) from the lab file's
// `velocity_percent` and `acceleration_percent`.
int Percent(const ControllerConfig& c, const std::string& key, int fallback) {
  const auto it = c.settings.find(key);
  if (it == c.settings.end()) return fallback;
  int value = 0;
  const std::string& text = it->second;
  const auto [end, error] = std::from_chars(text.data(), text.data() + text.size(), value);
  if (error != std::errc() || end != text.data() + text.size() || value < 1 || value > 100) {
    throw InputError({key, 0, 0, ""},
                     "kuka: " + key + " is a whole percentage from 1 to 100 (ARMSIG refuses "
                     "others), got " + Quoted(text));
  }
  return value;
}

std::unique_ptr<instruments::RobotController> OpenKuka(const ControllerConfig& c,
                                                       const instruments::RetryPolicy& policy) {
  instruments::KukaOptions o;
  o.velocity_percent = Percent(c, "velocity_percent", o.velocity_percent);
  o.acceleration_percent = Percent(c, "acceleration_percent", o.acceleration_percent);
  return std::make_unique<instruments::KukaController>(
      instruments::MakeFramedTcpTransport(c.host, c.Port("variable_server_port"),
                                          instruments::kuka::kResponseFrames),
      c.can_move, policy, o);
}

constexpr NetworkController kNetworkControllers[] = {
    {"ur", OpenUr},
    {"kuka", OpenKuka},
};

}  // namespace

std::unique_ptr<instruments::RobotController> OpenController(
    const ControllerConfig& c, const instruments::RetryPolicy& policy) {
  if (io::FindNetworkControllerProtocol(c.protocol)) {
    if (c.host.empty()) throw InputError({"host", 0, 0, ""}, "protocol " + c.protocol + " needs a host");
    for (const auto& n : kNetworkControllers) {
      if (n.open && c.protocol == n.protocol) return n.open(c, policy);
    }
    throw InputError({"protocol", 0, 0, ""},
                     "controller protocol " + Quoted(c.protocol) +
                         ": its driver is not built into this armsig yet");
  }
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
                                               " (expected val, as, counter or a network "
                                               "controller's)");
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
