#include "workflows/virtual_instrument.h"

#include "calibration/simulation.h"
#include "core/error.h"
#include "core/units.h"
#include "io/model_yaml.h"
#include "reduction/observation.h"
#include "workflows/builtin_models.h"

namespace armsig::workflows {

VirtualInstrument StartVirtualInstrument(const std::string& protocol, const std::string& link) {
  if (protocol != "geocom" && protocol != "gsi" && protocol != "val" && protocol != "as") {
    throw InputError({"--protocol", 0, 0, ""},
                     "unknown protocol '" + protocol + "' (expected geocom, gsi, val or as)");
  }
  VirtualInstrument v;
  const auto model = io::ParseRobotModel(kPuma760Yaml, "built-in PUMA 760");
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
  if (protocol == "geocom") {
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

}  // namespace armsig::workflows
