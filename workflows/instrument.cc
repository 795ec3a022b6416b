#include "workflows/instrument.h"

#include <fmt/format.h>

#include <algorithm>

#include <nlohmann/json.hpp>

#include "acquisition/lab.h"
#include "core/error.h"
#include "core/text.h"
#include "core/units.h"

namespace armsig::workflows {

namespace {

nlohmann::json ReadingJson(const instruments::Reading& r, const std::string& device) {
  nlohmann::json j = {
      {"instrument", device},
      {"hz_rad", r.angles.hz_rad},
      {"v_rad", r.angles.v_rad},
      {"distance_mm", r.distance_mm ? nlohmann::json(*r.distance_mm) : nlohmann::json(nullptr)},
      {"face", r.angles.face},
      {"return_code", r.return_code},
      {"warning", r.note.empty() ? nlohmann::json(nullptr) : nlohmann::json(r.note)}};
  // What a laser tracker reports besides (absent for theodolites).
  if (const auto& p = r.point_in_instrument_mm)
    j.update({{"x_mm", p->x()}, {"y_mm", p->y()}, {"z_mm", p->z()}});
  if (const auto& s = r.sigma) {
    j.update({{"sigma_hz_rad", s->hz_rad},
              {"sigma_v_rad", s->v_rad},
              {"sigma_distance_mm", s->distance_mm}});
  }
  if (const auto& e = r.environment) {
    j.update({{"temperature_c", e->temperature_c},
              {"pressure_hpa", e->pressure_hpa},
              {"humidity_percent", e->humidity_percent}});
  }
  return j;
}

// A network controller's configuration from --tcp HOST[:PORT] and --controller-port KEY=PORT.
io::ControllerConfig NetworkControllerOf(const InstrumentRequest& o,
                                         const io::NetworkControllerProtocol& protocol) {
  if (!o.port.empty())
    throw InputError({"--port", 0, 0, ""}, o.protocol + " is reached over the network: give --tcp HOST[:PORT]");
  if (o.tcp.empty()) throw InputError({"--tcp", 0, 0, ""}, o.protocol + " needs --tcp HOST[:PORT]");
  io::ControllerConfig c;
  c.protocol = protocol.id;
  c.host = o.tcp;
  for (const auto& [key, port] : protocol.ports) c.ports[key] = port;
  if (const auto address = io::SplitHostPort(o.tcp)) {
    c.host = address->host;
    c.ports[protocol.tcp_port] = address->port;
  } else if (o.tcp.find(':') != std::string::npos && o.tcp.find(':') == o.tcp.rfind(':')) {
    throw InputError({"--tcp", 0, 0, ""},
                     Quoted(o.tcp) + ": expected HOST or HOST:PORT with a port from 1 to 65535");
  }
  for (const auto& item : o.controller_ports) {
    const size_t eq = item.find('=');
    const std::string key = item.substr(0, eq);
    const auto port = eq == std::string::npos ? std::nullopt : io::SplitHostPort("h:" + item.substr(eq + 1));
    if (!c.ports.count(key) || !port) {
      std::string keys;
      for (const auto& [name, unused] : protocol.ports) keys += (keys.empty() ? "" : ", ") + name;
      throw InputError({"--controller-port", 0, 0, ""},
                       Quoted(item) + ": expected KEY=PORT with KEY one of " + keys);
    }
    c.ports[key] = port->port;
  }
  for (const auto& item : o.controller_settings) {
    const size_t eq = item.find('=');
    const std::string key = item.substr(0, eq);
    const bool known = std::find(protocol.settings.begin(), protocol.settings.end(), key) !=
                       protocol.settings.end();
    if (eq == std::string::npos || !known) {
      std::string keys;
      for (const auto& name : protocol.settings) keys += (keys.empty() ? "" : ", ") + name;
      throw InputError({"--controller-setting", 0, 0, ""},
                       Quoted(item) + ": expected KEY=VALUE with KEY one of " +
                           (keys.empty() ? std::string("(none for ") + o.protocol + ")" : keys));
    }
    c.settings[key] = item.substr(eq + 1);
  }
  return c;
}

std::string ReadController(const InstrumentRequest& o, io::ControllerProtocol protocol,
                           const instruments::RetryPolicy& policy) {
  io::ControllerConfig config;
  config.protocol = protocol;
  config.port = o.port;
  config.baud = o.baud;
  if (const auto* network = io::FindNetworkControllerProtocol(protocol))
    config = NetworkControllerOf(o, *network);
  const auto robot = acquisition::OpenController(config, policy);
  if (o.action == "probe") {
    const auto who = robot->Identify();
    if (!who) return Printable(robot->name()) + ": the controller does not say who it is\n";
    const auto kinematics = robot->Kinematics();
    if (o.json) {
      nlohmann::json j = {{"controller", robot->name()},     {"vendor", who->vendor},
                          {"model", who->model},             {"serial", who->serial},
                          {"software", who->software},
                          {"kinematics_checksum", who->kinematics_checksum}};
      if (kinematics) {
        j["kinematics"] = {{"dh_theta_rad", kinematics->dh_theta_rad},
                           {"dh_a_mm", kinematics->dh_a_mm},
                           {"dh_d_mm", kinematics->dh_d_mm},
                           {"dh_alpha_rad", kinematics->dh_alpha_rad},
                           {"calibration_status", kinematics->calibration_status}};
      }
      return JsonText(j) + "\n";
    }
    return fmt::format("{}: {} {} serial {} software {}{}\n", Printable(robot->name()),
                       Printable(who->vendor), Printable(who->model), Printable(who->serial),
                       Printable(who->software),
                       who->kinematics_checksum.empty()
                           ? std::string()
                           : " kinematics checksum " + Printable(who->kinematics_checksum));
  }
  const instruments::StampedJoints stamped = robot->ReadStampedJoints();
  const Eigen::VectorXd& q = stamped.joints_rad;
  if (o.json) {
    std::vector<double> joints(q.data(), q.data() + q.size());
    nlohmann::json j = {{"controller", robot->name()}, {"joints_rad", joints}};
    j["controller_time_s"] = stamped.controller_time_s ? nlohmann::json(*stamped.controller_time_s)
                                                       : nlohmann::json(nullptr);
    return JsonText(j) + "\n";
  }
  std::string text = fmt::format("{}: {} joints (deg):", Printable(robot->name()), q.size());
  for (int i = 0; i < q.size(); ++i) text += fmt::format(" {:.3f}", q(i) / kRadPerDeg);
  if (stamped.controller_time_s)
    text += fmt::format(" (controller time {:.3f} s)", *stamped.controller_time_s);
  return text + "\n";
}

}  // namespace

std::string QueryInstrument(const InstrumentRequest& o) {
  if (o.port.empty() && o.tcp.empty())
    throw InputError({"--port", 0, 0, ""}, "give --port PATH or --tcp HOST:PORT");
  instruments::RetryPolicy policy;
  policy.timeout = std::chrono::milliseconds(o.timeout_ms);
  if (!o.controller_ports.empty() && !io::FindNetworkControllerProtocol(o.protocol))
    throw InputError({"--controller-port", 0, 0, ""}, "only for a network controller (ur, …)");
  if (!o.controller_settings.empty() && !io::FindNetworkControllerProtocol(o.protocol)) {
    throw InputError({"--controller-setting", 0, 0, ""},
                     "only for a network controller (abb, …)");
  }
  if (const auto controller = io::ControllerProtocolNamed(o.protocol);
      controller && *controller != io::ControllerProtocol::kCounter) {
    return ReadController(o, *controller, policy);
  }
  io::InstrumentConfig config;
  const auto protocol = io::InstrumentProtocolNamed(o.protocol);
  if (!protocol) {
    throw InputError({"--protocol", 0, 0, ""}, "unknown instrument protocol " + Quoted(o.protocol) +
                                                   " (expected geocom, gsi or emscon)");
  }
  config.protocol = *protocol;
  config.port = o.port;
  if (!o.tcp.empty()) {
    config.tcp = io::SplitHostPort(o.tcp);
    if (!config.tcp) {
      throw InputError({"--tcp", 0, 0, ""},
                       Quoted(o.tcp) + ": expected HOST:PORT with a port from 1 to 65535" +
                           (*protocol == io::InstrumentProtocol::kEmScon ? " (emScon servers listen on 700)" : ""));
    }
  }
  config.baud = o.baud;
  config.crc = o.crc;
  const auto device = acquisition::OpenInstrument(config, policy);
  if (o.action == "probe") {
    const auto info = device->Identify();
    if (o.json) {
      return JsonText(nlohmann::json{{"port", device->name()},
                                     {"name", info.name},
                                     {"serial", info.serial},
                                     {"firmware", info.firmware}}) +
             "\n";
    }
    // What a device says is shown, never obeyed (an escape sequence in its name).
    return fmt::format("{}: {} serial {} firmware {}\n", Printable(device->name()),
                       Printable(info.name), Printable(info.serial), Printable(info.firmware));
  }
  const bool distance = o.distance || o.protocol == "emscon";  // a tracker always has one
  const auto r = distance ? device->MeasureDistanceAndAngles() : device->MeasureAngles();
  if (o.json) return JsonText(ReadingJson(r, device->name())) + "\n";
  return fmt::format("{}: Hz {:.5f} gon  V {:.5f} gon  face {}{}{}\n", Printable(device->name()),
                     FromRad(r.angles.hz_rad, AngleUnit::kGon),
                     FromRad(r.angles.v_rad, AngleUnit::kGon), r.angles.face,
                     r.distance_mm ? fmt::format("  distance {:.3f} mm", *r.distance_mm) : "",
                     r.note.empty() ? "" : "  (" + Printable(r.note) + ")");
}

}  // namespace armsig::workflows
