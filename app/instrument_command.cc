// armsig instrument probe|read --port PATH|--tcp HOST:PORT --protocol geocom|gsi|val|as|emscon
// armsig instrument simulate --protocol P [--link PATH | --tcp HOST:PORT] [--seconds N] [--fault F]
#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <atomic>
#include <csignal>
#include <iostream>
#include <nlohmann/json.hpp>
#include <optional>
#include <thread>

#include "acquisition/lab.h"
#include "app/command.h"
#include "core/error.h"
#include "core/units.h"
#include "simulation/fault_matrix.h"
#include "workflows/virtual_instrument.h"

namespace armsig::app {

struct InstrumentOptions {
  std::string action, port, tcp, protocol = "geocom", link = "armsig-sim-port", fault;
  unsigned baud = 19200;
  bool json = false, crc = false, distance = false;
  int timeout_ms = 3000;
  double seconds = 0;
};

namespace {

std::atomic<bool> g_stop{false};

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

}  // namespace

int RunInstrument(const InstrumentOptions& o) {
  instruments::RetryPolicy policy;
  policy.timeout = std::chrono::milliseconds(o.timeout_ms);
  if (o.port.empty() && o.tcp.empty())
    throw InputError({"--port", 0, 0, ""}, "give --port PATH or --tcp HOST:PORT");
  try {
    if (o.protocol == "val" || o.protocol == "as") {
      acquisition::ControllerConfig config;
      config.protocol = o.protocol;
      config.port = o.port;
      config.baud = o.baud;
      const auto robot = acquisition::OpenController(config, policy);
      const Eigen::VectorXd q = robot->ReadJointsRad();
      if (o.json) {
        std::vector<double> joints(q.data(), q.data() + q.size());
        std::cout << nlohmann::json{{"controller", robot->name()}, {"joints_rad", joints}}.dump()
                  << "\n";
      } else {
        std::cout << robot->name() << ": " << q.size() << " joints (deg):";
        for (int i = 0; i < q.size(); ++i) std::cout << fmt::format(" {:.3f}", q(i) * 180.0 / kPi);
        std::cout << "\n";
      }
      return kOk;
    }
    acquisition::InstrumentConfig config;
    config.protocol = o.protocol;
    config.port = o.port;
    config.tcp = o.tcp;
    config.baud = o.baud;
    config.crc = o.crc;
    const auto device = acquisition::OpenInstrument(config, policy);
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
    const bool distance = o.distance || o.protocol == "emscon";  // a tracker always has one
    const auto r = distance ? device->MeasureDistanceAndAngles() : device->MeasureAngles();
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
  // --fault NAME: a misbehaving instrument, for trying a driver's deadlines by hand.
  std::optional<simulation::Fault> fault;
  if (!o.fault.empty()) {
    fault = simulation::FaultFromName(o.fault);
    if (!fault) {
      throw InputError({"--fault", 0, 0, ""}, "unknown fault '" + o.fault + "' (expected one of " +
                                                  simulation::FaultNames() + ")");
    }
  }
  const auto virtual_instrument = workflows::StartVirtualInstrument(o.protocol, o.link, o.tcp);
  auto& sim = virtual_instrument.simulator;
  if (fault) sim->InjectAlways({*fault, 0});
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
    a->add_option("--protocol", o->protocol, "geocom | gsi | val | as | emscon")
        ->capture_default_str();
    a->add_option("--baud", o->baud, "Baud rate")->capture_default_str();
    a->add_option("--timeout-ms", o->timeout_ms,
                  "Deadline of the whole exchange, from the command to the parsed reply "
                  "(retries included)")
        ->check(CLI::Range(1, 24 * 3600 * 1000))
        ->capture_default_str();
    a->add_flag("--crc", o->crc, "GeoCOM: CRC-16 on every frame");
    a->add_flag("--distance", o->distance, "read: measure the distance too");
    a->add_flag("--json", o->json, "Machine-readable output");
    a->callback([&run, o] { run = [o] { return RunInstrument(*o); }; });
  }
  auto o = std::make_shared<InstrumentOptions>();
  auto* s = sub->add_subcommand(
      "simulate", "Start a virtual instrument on a pseudo-terminal for manual trials");
  s->add_option("--protocol", o->protocol, "geocom | gsi | val | as | emscon")
      ->capture_default_str();
  s->add_option("--tcp", o->tcp, "emscon: HOST:PORT to listen on (e.g. 127.0.0.1:7000)");
  s->add_option("--link", o->link, "Path of the port to create (a symlink to the pty)")
      ->capture_default_str();
  s->add_option("--seconds", o->seconds, "Stop after this many seconds (default: Ctrl-C)");
  s->add_option("--fault", o->fault,
                "Misbehave on every request: flood-bytes, endless-line, flood-lines, silence, "
                "partial, wrong-trid, bad-crc, no-crc, busy, error, other-reply, out-of-range, "
                "wrong-unit, vanish, noise; emscon also wrong-command-id, beam-break, "
                "reflector-not-found, status-between, status-inside");
  s->callback([&run, o] { run = [o] { return RunSimulate(*o); }; });
}

}  // namespace armsig::app
