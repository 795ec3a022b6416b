#include "demo/virtual_instrument.h"

#include <chrono>
#include <filesystem>
#include <optional>
#include <thread>

#include "acquisition/lab.h"
#include "calibration/synthetic.h"
#include "core/error.h"
#include "core/text.h"
#include "core/units.h"
#include "io/builtin_models.h"
#include "io/model_yaml.h"
#include "reduction/observation.h"
#include "simulation/emscon_simulator.h"
#include "simulation/fault_matrix.h"
#include "simulation/geocom_simulator.h"
#include "simulation/gsi_online_simulator.h"
#include "simulation/val_simulator.h"

namespace armsig::demo {

VirtualInstrument StartVirtualInstrument(const std::string& protocol, const std::string& link,
                                         const std::string& tcp) {
  if (protocol != "geocom" && protocol != "gsi" && protocol != "val" && protocol != "as" &&
      protocol != "emscon") {
    throw InputError({"--protocol", 0, 0, ""}, "unknown protocol " + Quoted(protocol) +
                                                   " (expected geocom, gsi, val, as or emscon)");
  }
  const auto address = protocol == "emscon" ? io::SplitHostPort(tcp) : std::nullopt;
  if (protocol == "emscon" && !address) {
    throw InputError(
        {"--tcp", 0, 0, ""},
        "protocol emscon listens on --tcp HOST:PORT (port 1 to 65535), got " + Quoted(tcp));
  }
  std::error_code ec;
  const auto status = std::filesystem::symlink_status(link, ec);
  if (protocol != "emscon" && std::filesystem::exists(status)) {
    const bool pty_link =
        std::filesystem::is_symlink(status) &&
        std::filesystem::read_symlink(link, ec).string().rfind("/dev/pts/", 0) == 0;
    if (!pty_link) {
      throw InputError({"--link", 0, 0, ""},
                       link +
                           " exists and is not a link to a pseudo-terminal: armsig leaves it as "
                           "it is (choose another --link)");
    }
  }
  VirtualInstrument v;
  const auto model = io::ParseRobotModel(io::kPuma760Yaml, "built-in PUMA 760");
  v.lab = std::make_unique<simulation::VirtualLab>(model, calibration::PaperTable3Parameters(),
                                                   Eigen::Isometry3d::Identity());
  simulation::VirtualStation station;
  station.pose.id = "T1";
  station.pose.position_mm = {3000, 0, 1000};
  station.pose.azimuth_rad = 4.712;
  station.pose.world_from_station = reduction::LevelledRotation(station.pose.azimuth_rad);
  station.sigma_angle_rad = 0.5 * kRadPerArcsec;
  station.sigma_distance_mm = 0.01;
  v.lab->AddStation(station);
  Eigen::VectorXd q(6);
  q << 0.2, -0.6, 1.2, 0.3, -0.4, 0.5;
  v.lab->SetJoints(q);
  using simulation::ValSimulator;
  if (protocol == "emscon") {
    simulation::EmsconSimulatorOptions options;
    options.initialized = true;  // a tracker that was switched on and warmed up
    v.simulator = std::make_unique<simulation::EmsconSimulator>(*v.lab, 0, address->host,
                                                                address->port, options);
  } else if (protocol == "geocom") {
    v.simulator = std::make_unique<simulation::GeoComSimulator>(*v.lab, 0, link);
  } else if (protocol == "gsi") {
    v.simulator = std::make_unique<simulation::GsiOnlineSimulator>(*v.lab, 0, link);
  } else {
    v.simulator = std::make_unique<ValSimulator>(
        *v.lab, link,
        protocol == "val" ? ValSimulator::Layout::kValII : ValSimulator::Layout::kKawasakiAs);
  }
  v.simulator->Start();
  return v;
}

int64_t RunVirtualInstrument(const SimulateRequest& request,
                             const std::function<void(const std::string& path)>& started) {
  std::optional<simulation::Fault> fault;
  if (!request.fault.empty()) {
    fault = simulation::FaultFromName(request.fault);
    if (!fault) {
      throw InputError({"--fault", 0, 0, ""}, "unknown fault " + Quoted(request.fault) +
                                                  " (expected one of " + simulation::FaultNames() +
                                                  ")");
    }
  }
  if (!(request.seconds >= 0.0 && request.seconds < 1e7)) {
    throw InputError({"--seconds", 0, 0, ""}, "expected a number of seconds ≥ 0");
  }
  const auto instrument = StartVirtualInstrument(request.protocol, request.link, request.tcp);
  auto& sim = instrument.simulator;
  if (fault) sim->InjectAlways({*fault, 0});
  if (started) started(sim->path());
  const auto end = std::chrono::steady_clock::now() +
                   std::chrono::milliseconds(static_cast<int64_t>(request.seconds * 1000));
  while (!(request.stop && request.stop->load()) &&
         (request.seconds <= 0 || std::chrono::steady_clock::now() < end)) {
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  sim->Stop();
  return sim->requests();
}

}  // namespace armsig::demo
