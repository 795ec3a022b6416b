// armsig instrument probe|read --port PATH|--tcp HOST:PORT --protocol geocom|gsi|val|as [--json]
// armsig instrument simulate --protocol P [--link PATH] [--seconds N]
#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <atomic>
#include <csignal>
#include <iostream>
#include <nlohmann/json.hpp>
#include <thread>

#include "workflows/builtin_models.h"
#include "app/command.h"
#include "calibration/simulation.h"
#include "core/error.h"
#include "core/units.h"
#include "instruments/geocom_device.h"
#include "instruments/other_devices.h"
#include "io/model_yaml.h"
#include "reduction/observation.h"
#include "simulation/simulators.h"

namespace armsig::app {

struct InstrumentOptions {
  std::string action, port, tcp, protocol = "geocom", link = "armsig-sim-port";
  unsigned baud = 19200;
  bool json = false, crc = false, distance = false;
  int timeout_ms = 3000;
  double seconds = 0;
};

namespace {

std::atomic<bool> g_stop{false};

std::unique_ptr<instruments::LineTransport> OpenTransport(const InstrumentOptions& o) {
  if (!o.tcp.empty()) {
    const size_t colon = o.tcp.rfind(':');
    if (colon == std::string::npos) throw InputError({"--tcp", 0, 0, ""}, "expected HOST:PORT");
    return instruments::MakeTcpTransport(
        o.tcp.substr(0, colon), static_cast<unsigned short>(std::stoi(o.tcp.substr(colon + 1))));
  }
  if (o.port.empty()) throw InputError({"--port", 0, 0, ""}, "give --port PATH or --tcp HOST:PORT");
  instruments::SerialSettings s;
  s.path = o.port;
  s.baud = o.baud;
  return instruments::MakeSerialTransport(s);
}

nlohmann::json ReadingJson(const instruments::Reading& r, const std::string& device) {
  return {{"instrument", device},
          {"hz_rad", r.angles.hz_rad},
          {"v_rad", r.angles.v_rad},
          {"distance_mm", r.distance_mm ? nlohmann::json(*r.distance_mm) : nlohmann::json(nullptr)},
          {"face", r.angles.face},
          {"return_code", r.return_code},
          {"warning", r.note.empty() ? nlohmann::json(nullptr) : nlohmann::json(r.note)}};
}

}  // namespace

int RunInstrument(const InstrumentOptions& o) {
  instruments::RetryPolicy policy;
  policy.timeout = std::chrono::milliseconds(o.timeout_ms);
  if (o.protocol != "geocom" && o.protocol != "gsi" && o.protocol != "val" && o.protocol != "as") {
    throw InputError({"--protocol", 0, 0, ""},
                     "unknown protocol '" + o.protocol + "' (expected geocom, gsi, val or as)");
  }
  try {
    if (o.protocol == "val" || o.protocol == "as") {
      instruments::ValController robot(OpenTransport(o), false, policy);
      const Eigen::VectorXd q = robot.ReadJointsRad();
      if (o.json) {
        std::vector<double> joints(q.data(), q.data() + q.size());
        std::cout << nlohmann::json{{"controller", robot.name()}, {"joints_rad", joints}}.dump()
                  << "\n";
      } else {
        std::cout << robot.name() << ": " << q.size() << " joints (deg):";
        for (int i = 0; i < q.size(); ++i) std::cout << fmt::format(" {:.3f}", q(i) * 180.0 / kPi);
        std::cout << "\n";
      }
      return kOk;
    }
    std::unique_ptr<instruments::DistanceInstrument> device;
    if (o.protocol == "geocom")
      device = std::make_unique<instruments::GeoComDevice>(OpenTransport(o), policy, o.crc);
    else
      device = std::make_unique<instruments::GsiOnlineDevice>(OpenTransport(o), policy);
    if (o.action == "probe") {
      const auto info = device->Identify();
      if (o.json) {
        std::cout << nlohmann::json{{"port", device->name()},
                                    {"name", info.name},
                                    {"serial", info.serial},
                                    {"firmware", info.firmware}}
                         .dump()
                  << "\n";
      } else {
        std::cout << fmt::format("{}: {} serial {} firmware {}\n", device->name(), info.name,
                                 info.serial, info.firmware);
      }
      return kOk;
    }
    const auto r = o.distance ? device->MeasureDistanceAndAngles() : device->MeasureAngles();
    if (o.json) {
      std::cout << ReadingJson(r, device->name()).dump() << "\n";
    } else {
      std::cout << fmt::format(
          "{}: Hz {:.5f} gon  V {:.5f} gon  face {}{}{}\n", device->name(),
          FromRad(r.angles.hz_rad, AngleUnit::kGon), FromRad(r.angles.v_rad, AngleUnit::kGon),
          r.angles.face, r.distance_mm ? fmt::format("  distance {:.3f} mm", *r.distance_mm) : "",
          r.note.empty() ? "" : "  (" + r.note + ")");
    }
    return kOk;
  } catch (const instruments::InstrumentError& e) {
    spdlog::error("instrument: {} (code {})", e.what(), e.code());
    return kFailure;
  }
}

int RunSimulate(const InstrumentOptions& o) {
  // A virtual PUMA 760 with the paper's Table 3 errors, one station 3 m away.
  auto model = io::ParseRobotModel(workflows::kPuma760Yaml, "built-in PUMA 760");
  simulation::VirtualLab lab(model, calibration::PaperTable3Parameters(),
                             Eigen::Isometry3d::Identity());
  simulation::VirtualStation st;
  st.pose.id = "T1";
  st.pose.position_mm = {3000, 0, 1000};
  st.pose.azimuth_rad = 4.712;
  st.pose.world_from_station = reduction::LevelledRotation(st.pose.azimuth_rad);
  st.sigma_angle_rad = 0.5 * kRadPerArcsec;
  st.sigma_distance_mm = 0.01;
  lab.AddStation(st);
  Eigen::VectorXd q(6);
  q << 0.2, -0.6, 1.2, 0.3, -0.4, 0.5;
  lab.SetJoints(q);
  std::unique_ptr<simulation::LineSimulator> sim;
  if (o.protocol == "geocom")
    sim = std::make_unique<simulation::GeoComSimulator>(lab, 0, o.link);
  else if (o.protocol == "gsi")
    sim = std::make_unique<simulation::GsiOnlineSimulator>(lab, 0, o.link);
  else if (o.protocol == "val")
    sim = std::make_unique<simulation::ValSimulator>(lab, o.link,
                                                     simulation::ValSimulator::Layout::kValII);
  else if (o.protocol == "as")
    sim = std::make_unique<simulation::ValSimulator>(lab, o.link,
                                                     simulation::ValSimulator::Layout::kKawasakiAs);
  else
    throw InputError({"--protocol", 0, 0, ""},
                     "unknown protocol '" + o.protocol + "' (expected geocom, gsi, val or as)");
  sim->Start();
  std::cout << "virtual " << o.protocol << " instrument on " << sim->path()
            << (o.seconds > 0 ? fmt::format(" for {} s", o.seconds) : std::string(" until Ctrl-C"))
            << std::endl;
  std::signal(SIGINT, [](int) { g_stop = true; });
  std::signal(SIGTERM, [](int) { g_stop = true; });
  const auto end = std::chrono::steady_clock::now() +
                   std::chrono::milliseconds(static_cast<long>(o.seconds * 1000));
  while (!g_stop && (o.seconds <= 0 || std::chrono::steady_clock::now() < end)) {
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  sim->Stop();
  std::cout << sim->requests() << " requests served\n";
  return kOk;
}

void SetupInstrumentCommand(CLI::App& parent, const GlobalOptions&, Runner& run) {
  auto* sub =
      parent.add_subcommand("instrument", "Talk to one instrument (probe | read), or simulate one");
  sub->require_subcommand(1);
  for (const char* action : {"probe", "read"}) {
    auto o = std::make_shared<InstrumentOptions>();
    o->action = action;
    auto* a = sub->add_subcommand(action, std::string(action) == "probe"
                                              ? "Identify the instrument (name, serial, firmware)"
                                              : "Take one measurement");
    a->add_option("--port", o->port, "Serial port (or pty) path");
    a->add_option("--tcp", o->tcp, "HOST:PORT instead of a serial port");
    a->add_option("--protocol", o->protocol, "geocom | gsi | val | as")->capture_default_str();
    a->add_option("--baud", o->baud, "Baud rate")->capture_default_str();
    a->add_option("--timeout-ms", o->timeout_ms, "Reply timeout")->capture_default_str();
    a->add_flag("--crc", o->crc, "GeoCOM: CRC-16 on every frame");
    a->add_flag("--distance", o->distance, "read: measure the distance too");
    a->add_flag("--json", o->json, "Machine-readable output");
    a->callback([&run, o] { run = [o] { return RunInstrument(*o); }; });
  }
  auto o = std::make_shared<InstrumentOptions>();
  auto* s = sub->add_subcommand(
      "simulate", "Start a virtual instrument on a pseudo-terminal for manual trials");
  s->add_option("--protocol", o->protocol, "geocom | gsi | val | as")->capture_default_str();
  s->add_option("--link", o->link, "Path of the port to create (a symlink to the pty)")
      ->capture_default_str();
  s->add_option("--seconds", o->seconds, "Stop after this many seconds (default: Ctrl-C)");
  s->callback([&run, o] { run = [o] { return RunSimulate(*o); }; });
}

}  // namespace armsig::app
