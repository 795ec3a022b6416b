#include "acquisition/lab.h"

#include <fmt/format.h>

#include <charconv>
#include <regex>

#include "core/error.h"
#include "core/text.h"
#include "robots/abb_controller.h"
#include "instruments/emscon_device.h"
#include "instruments/geocom_device.h"
#include "instruments/gsi_device.h"
#include "robots/kuka_controller.h"
#include "robots/robot_controllers.h"
#include "robots/ur_device.h"
#include "io/credentials.h"

namespace armsig::acquisition {

using io::ControllerConfig;
using io::InstrumentConfig;
using io::LabConfig;

namespace {
std::unique_ptr<instruments::LineTransport> Transport(const std::string& port,
                                                      const std::optional<io::HostPort>& tcp,
                                                      unsigned baud) {
  if (tcp) return instruments::MakeTcpTransport(tcp->host, tcp->port);
  if (port.empty()) throw InputError({"port", 0, 0, ""}, "give a serial port or HOST:PORT");
  instruments::SerialSettings s;
  s.path = port;
  s.baud = baud;
  return instruments::MakeSerialTransport(s);
}
}  // namespace

std::unique_ptr<instruments::DistanceInstrument> OpenInstrument(
    const InstrumentConfig& c, const instruments::RetryPolicy& policy) {
  switch (c.protocol) {
    case io::InstrumentProtocol::kGeoCom:
      return std::make_unique<instruments::GeoComDevice>(Transport(c.port, c.tcp, c.baud), policy,
                                                         c.crc);
    case io::InstrumentProtocol::kGsi:
      return std::make_unique<instruments::GsiOnlineDevice>(Transport(c.port, c.tcp, c.baud), policy);
    case io::InstrumentProtocol::kEmScon: {  // a laser tracker: binary packets over TCP only
      if (!c.tcp) {
        throw InputError({"tcp", 0, 0, ""},
                         "protocol emscon needs --tcp HOST:PORT (port 1 to "
                         "65535; emScon servers listen on 700)");
      }
      instruments::EmsconOptions options;
      options.measurement_time_ms = c.measurement_time_ms;
      return std::make_unique<instruments::EmsconDevice>(
          instruments::MakeEmsconTcpTransport(c.tcp->host, c.tcp->port), policy, options);
    }
  }
  throw InputError({"protocol", 0, 0, ""}, "unknown instrument protocol");
}

namespace {

// The robot controllers reached over the network (io::NetworkControllerProtocols), each
// opened by its device: adding a controller is one entry here.
using NetworkOpener = std::unique_ptr<instruments::RobotController> (*)(
    const ControllerConfig&, const instruments::RetryPolicy&);
struct NetworkController {
  io::ControllerProtocol protocol;
  NetworkOpener open;
};
std::unique_ptr<instruments::RobotController> OpenUr(const ControllerConfig& c,
                                                     const instruments::RetryPolicy& policy) {
  robots::UrOptions o;
  o.host = c.host;
  o.rtde_port = c.Port("rtde_port");
  o.primary_port = c.Port("primary_port");
  o.secondary_port = c.Port("secondary_port");
  o.dashboard_port = c.Port("dashboard_port");
  o.can_move = c.can_move;
  return std::make_unique<robots::UrController>(o, policy);
}

// ABB through Robot Web Services: the lab file's settings, each checked here and refused
// naming its key: rws (1: IRC5 / RobotWare 6 over HTTP; 2, the default: OmniCore /
// RobotWare 7 over TLS), certificate_sha256 or ca_file (RWS 2.0's trust), task, module,
// mechunit (RAPID names), speed_percent (1 … 100), representation (RWS 1.0: xhtml or json).
std::unique_ptr<instruments::RobotController> OpenAbb(const ControllerConfig& c,
                                                      const instruments::RetryPolicy& policy) {
  namespace rws = robots::rws;
  auto setting = [&](const char* key) -> std::optional<std::string> {
    const auto it = c.settings.find(key);
    if (it == c.settings.end()) return std::nullopt;
    return it->second;
  };
  auto refuse = [](const char* key, const std::string& expected, const std::string& got) {
    throw InputError({"", 0, 0, ""}, "robot.controller." + std::string(key) + ": expected " +
                                          expected + ", got " + Quoted(got));
  };
  robots::AbbSettings s;
  const std::string version = setting("rws").value_or("2");
  if (version == "1") {
    s.version = rws::Version::kRws1;
    s.representation = rws::Representation::kXhtml;
  } else if (version == "2") {
    s.version = rws::Version::kRws2;
  } else {
    refuse("rws", "1 (IRC5, RobotWare 6) or 2 (OmniCore, RobotWare 7)", version);
  }
  if (const auto r = setting("representation")) {
    if (*r == "json" && s.version == rws::Version::kRws1) {
      s.representation = rws::Representation::kJson1;
    } else if (*r != "xhtml" || s.version != rws::Version::kRws1) {
      refuse("representation", "xhtml or json (RWS 1.0 only: RWS 2.0 speaks hal+json)", *r);
    }
  }
  static const std::regex kRapidName("[A-Za-z][A-Za-z0-9_]{0,31}");
  for (auto [key, field] : {std::pair<const char*, std::string*>{"task", &s.task},
                            {"module", &s.module}, {"mechunit", &s.mechunit}}) {
    if (const auto v = setting(key)) {
      if (!std::regex_match(*v, kRapidName)) refuse(key, "a RAPID name (letters, digits, _)", *v);
      *field = *v;
    }
  }
  if (const auto v = setting("speed_percent")) {
    double percent = 0.0;
    const auto [end, ec] = std::from_chars(v->data(), v->data() + v->size(), percent);
    if (ec != std::errc() || end != v->data() + v->size() || !(percent >= 1 && percent <= 100)) {
      refuse("speed_percent", "a velocity override from 1 to 100 (%)", *v);
    }
    s.speed_percent = percent;
  }
  robots::TlsSettings tls;
  tls.enabled = s.version == rws::Version::kRws2;
  const auto pin = setting("certificate_sha256");
  const auto ca = setting("ca_file");
  if ((pin || ca) && !tls.enabled) {
    throw InputError({"", 0, 0, ""},
                     "robot.controller: RWS 1.0 (rws: 1) is plain HTTP: no certificate to pin");
  }
  if (pin) {
    const auto canonical = robots::http::CanonicalFingerprint(*pin);
    if (!canonical) refuse("certificate_sha256", "a SHA-256 fingerprint (64 hex digits)", *pin);
    tls.pinned_sha256 = *canonical;
  }
  if (ca) tls.ca_file = *ca;
  const auto credentials = io::LoadCredentials(c);
  if (!credentials) {
    throw InputError({"", 0, 0, ""},
                     fmt::format("robot.controller: protocol abb logs in: give `credentials: "
                                 "FILE` (YAML {{user: NAME, password: SECRET}}, mode 0600) or set "
                                 "{} and {}",
                                 io::kUserVariable, io::kPasswordVariable));
  }
  s.user = credentials->user();
  s.password = credentials->password();
  s.credentials_source = c.credentials_path.empty()
                             ? fmt::format("{} and {}", io::kUserVariable, io::kPasswordVariable)
                             : "the credentials file " + c.credentials_path;
  s.can_move = c.can_move;
  unsigned short port = c.Port("rws_port");
  if (port == 0) port = s.version == rws::Version::kRws1 ? 80 : 443;
  return std::make_unique<robots::AbbController>(
      s, robots::MakeHttpTransport(c.host, port, tls), policy);
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
  robots::KukaOptions o;
  o.velocity_percent = Percent(c, "velocity_percent", o.velocity_percent);
  o.acceleration_percent = Percent(c, "acceleration_percent", o.acceleration_percent);
  return std::make_unique<robots::KukaController>(
      instruments::MakeFramedTcpTransport(c.host, c.Port("variable_server_port"),
                                          robots::kuka::kResponseFrames),
      c.can_move, policy, o);
}

constexpr NetworkController kNetworkControllers[] = {
    {io::ControllerProtocol::kUr, OpenUr},
    {io::ControllerProtocol::kAbb, OpenAbb},
    {io::ControllerProtocol::kKuka, OpenKuka},
};

}  // namespace

std::unique_ptr<instruments::RobotController> OpenController(
    const ControllerConfig& c, const instruments::RetryPolicy& policy) {
  if (io::FindNetworkControllerProtocol(c.protocol)) {
    if (c.host.empty()) {
      throw InputError({"host", 0, 0, ""}, std::string("protocol ") + io::NameOf(c.protocol) + " needs a host");
    }
    for (const auto& n : kNetworkControllers) {
      if (n.open && c.protocol == n.protocol) return n.open(c, policy);
    }
    throw InputError({"protocol", 0, 0, ""},
                     "controller protocol " + Quoted(io::NameOf(c.protocol)) +
                         ": its driver is not built into this armsig yet");
  }
  switch (c.protocol) {
    case io::ControllerProtocol::kCounter: {
      std::vector<std::unique_ptr<instruments::LineTransport>> ports;
      for (const auto& p : c.counter_ports) ports.push_back(Transport(p, std::nullopt, c.baud));
      return std::make_unique<robots::CounterBox>(std::move(ports), c.encoders, policy);
    }
    case io::ControllerProtocol::kValII:
    case io::ControllerProtocol::kKawasakiAs:
      return std::make_unique<robots::ValController>(Transport(c.port, std::nullopt, c.baud), c.can_move,
                                                     policy);
    default:
      break;
  }
  throw InputError({"protocol", 0, 0, ""}, "unknown controller protocol " + Quoted(io::NameOf(c.protocol)) +
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
