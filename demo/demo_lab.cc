#include "demo/demo_lab.h"

#include <fmt/format.h>

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cstring>
#include <random>
#include <cmath>
#include <stdexcept>

#include "calibration/synthetic.h"
#include "core/units.h"
#include "instruments/geocom_device.h"
#include "io/atomic_file.h"
#include "io/builtin_models.h"
#include "io/network_files.h"
#include "reduction/observation.h"
#include "simulation/geocom_simulator.h"
#include "workflows/orient_triangulate.h"

namespace armsig::demo {

namespace {

constexpr double kSigmaArcsec = 0.5;

// The robot's base in the lab frame: about 3 m from a tracker at the origin and lower; in
// the middle of the three theodolites otherwise.
Eigen::Isometry3d BaseOf(bool tracker) {
  Eigen::Isometry3d base = Eigen::Isometry3d::Identity();
  if (tracker) {
    base.translate(Eigen::Vector3d(2300.0, 1600.0, -1100.0));
    base.rotate(Eigen::AngleAxisd(2.6, Eigen::Vector3d::UnitZ()));
  } else {
    base.translate(Eigen::Vector3d(120.0, -80.0, 0.0));
    base.rotate(Eigen::AngleAxisd(0.35, Eigen::Vector3d::UnitZ()));
  }
  return base;
}

// The robot's hidden truth: the paper's Table 3 for the PUMA, a virtual robot's drawn errors
// (simulation/virtual_robots.h) for the others; the planted change added to either.
simulation::VirtualRobot TruthOf(const DemoRobot& robot, const calibration::RobotModel& model,
                                 const DemoLabOptions& options) {
  simulation::VirtualRobot truth;
  if (robot.name == "puma") {
    truth.model = model;
    truth.true_params = calibration::PaperTable3Parameters();
    truth.world_from_base = BaseOf(options.tracker);
  } else {
    truth = simulation::MakeVirtualRobot(robot.name, model, options.seed);
  }
  if (options.planted.size() == model.num_parameters()) truth.true_params += options.planted;
  // Another day's set-up: the instruments (the lab frame: a tracker at its origin) stand
  // elsewhere, so the base lies elsewhere in their frame: turned 0.45 rad a place about the
  // frame's vertical (the robot seen from another side, a metre away for a tracker's robot)
  // and shifted by up to 0.3 m; the robot and its errors are the same.
  if (options.setup > 0) {
    const double n = options.setup;
    Eigen::Isometry3d moved = Eigen::Isometry3d::Identity();
    moved.translate(Eigen::Vector3d(300.0 * std::cos(n), -250.0 * std::sin(n),
                                    80.0 * (options.setup % 3 - 1.0)));
    moved.rotate(Eigen::AngleAxisd(0.45 * n, Eigen::Vector3d::UnitZ()));
    truth.world_from_base = moved * truth.world_from_base;
  }
  return truth;
}

// The instruments' noise: drawn anew on another day's set-up.
unsigned NoiseSeed(const DemoLabOptions& options) {
  return options.seed + 7919u * static_cast<unsigned>(options.setup);
}

// A secret file as a lab keeps one: its owner's alone (mode 0600) before anything is in it.
void WriteSecretFile(const std::string& path, const std::string& text) {
  const int fd =
      ::open(path.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_NOFOLLOW | O_CLOEXEC, 0600);
  if (fd < 0) throw std::runtime_error("demo: cannot create " + path + ": " + std::strerror(errno));
  const bool written = ::fchmod(fd, 0600) == 0 &&
                       ::write(fd, text.data(), text.size()) == static_cast<ssize_t>(text.size());
  ::close(fd);
  if (!written) throw std::runtime_error("demo: cannot write " + path);
}

}  // namespace

DemoLab::DemoLab(const calibration::RobotModel& model, const DemoLabOptions& options)
    : options_(options),
      robot_(FindDemoRobot(options.robot)),
      truth_(TruthOf(robot_, model, options)),
      base_(truth_.world_from_base),
      lab_(model, truth_.true_params, base_, NoiseSeed(options)) {
  using namespace std::chrono_literals;
  if (robot_.tracker_only) options_.tracker = true;
  lab_.SetJointErrors(truth_.joint_errors);
  simulator_options_.time_scale = options.time_scale;
  simulator_options_.angle_latency = 40ms;
  simulator_options_.motion_latency = 60ms;
  lab_file_.model_path = robot_.model_file;
  lab_file_.stations_path = "stations.yaml";
  lab_file_.controller.protocol = robot_.controller;
  lab_file_.controller.can_move = true;
  lab_file_.tolerances.max_miss_mm = 0.1;
  lab_file_.tolerances.settle_ms = 0;
  lab_file_.tolerances.readings = 1;
  lab_file_.timeout_ms = 2000;
  lab_.SetRepeatability(options.repeatability_mm);
  if (options_.tracker) {
    AddTracker();
  } else {
    AddTheodolites();
  }
  StartController();
}


// The virtual OmniCore (RWS 2.0 over TLS) with the module's contract: its own user and a
// password drawn for this run, in a credentials file beside the lab file; the lab file pins
// its certificate.
void DemoLab::StartAbb() {
  simulation::RwsSimulatorOptions o;
  o.version = robots::rws::Version::kRws2;
  o.model = truth_.identity.model;
  const std::string& serial = truth_.identity.serial;
  const size_t dash = serial.find('-');
  o.serial_high = serial.substr(0, dash);
  o.serial_low = dash == std::string::npos ? "" : serial.substr(dash + 1);
  o.user = "armsig";
  std::random_device rd;
  o.password = fmt::format("{:08x}{:08x}", rd(), rd());
  for (int i = 0; i < 6; ++i) o.start_deg[static_cast<size_t>(i)] = truth_.home_rad(i) / kRadPerDeg;
  o.time_scale = options_.time_scale;
  abb_ = std::make_unique<simulation::RwsSimulator>(lab_, o);
  abb_->Start();
  WriteSecretFile((options_.folder / kAbbCredentials).string(),
                  "user: " + o.user + "\npassword: \"" + o.password + "\"\n");
  auto& c = lab_file_.controller;
  c.host = "127.0.0.1";
  c.ports = {{"rws_port", abb_->port()}};
  c.credentials_path = kAbbCredentials;
  c.settings = {{"rws", "2"},
                {"certificate_sha256", abb_->certificate_sha256()},
                {"speed_percent", "25"}};
}

// The robot's controller, by the protocol its DemoRobot names.
void DemoLab::StartController() {
  if (robot_.controller == io::ControllerProtocol::kAbb) return StartAbb();
  if (robot_.controller == io::ControllerProtocol::kUr) {
    simulation::UrSimulatorOptions o;
    o.model = truth_.identity.model;
    o.serial = truth_.identity.serial;
    o.kinematics = truth_.kinematics;
    o.home_rad = truth_.home_rad;
    o.time_scale = options_.time_scale;
    ur_ = std::make_unique<simulation::UrSimulator>(lab_, o);
    ur_->Start();
    if (tracker_ && options_.on_the_move) tracker_->FollowArm(&ur_->arm());
    auto& c = lab_file_.controller;
    c.host = ur_->host();
    c.ports = {{"rtde_port", ur_->ports().rtde},
               {"primary_port", ur_->ports().primary},
               {"secondary_port", ur_->ports().secondary},
               {"dashboard_port", ur_->ports().dashboard}};
    return;
  }
  if (robot_.controller == io::ControllerProtocol::kKuka) {
    simulation::KukaSimulatorOptions o;
    o.time_scale = options_.time_scale;
    o.trafo_name = "#" + truth_.identity.model + " C4 FLR";
    o.serial = std::stoi(truth_.identity.serial);
    o.software = truth_.identity.software;
    o.home_rad = truth_.home_rad;
    kuka_ = std::make_unique<simulation::KukaSimulator>(lab_, "127.0.0.1", 0, o);
    kuka_->Start();
    auto& c = lab_file_.controller;
    c.host = "127.0.0.1";
    c.ports = {{"variable_server_port", kuka_->port()}};
    return;
  }
  controller_ = std::make_unique<simulation::ValSimulator>(
      lab_, (options_.folder / "robot").string(), simulation::ValSimulator::Layout::kKawasakiAs,
      simulator_options_);
  controller_->Start();
  lab_file_.controller.port = controller_->path();
}

std::string DemoLab::controller_address() const {
  if (abb_) return abb_->path() + " (Robot Web Services 2.0, TLS)";
  if (ur_) {
    return fmt::format("{} (RTDE {}, primary {}, secondary {}, dashboard {})", ur_->host(),
                       ur_->ports().rtde, ur_->ports().primary, ur_->ports().secondary,
                       ur_->ports().dashboard);
  }
  if (kuka_) return kuka_->path();
  return controller_ ? controller_->path() : std::string();
}

void DemoLab::AddTracker() {
  simulation::VirtualStation station;
  station.pose.id = "LT1";  // at the origin, levelled, circle zero along +y: the lab frame
  lab_.AddStation(station);
  simulation::EmsconSimulatorOptions o;
  o.time_scale = options_.time_scale;
  o.seed = NoiseSeed(options_);
  // The reflector is found only near the beam: within 25 mm where it points, within
  // 150 mm by a search (FindReflector).
  o.acquire_radius_mm = 25.0;
  o.search_radius_mm = 150.0;
  o.continuous_modes = options_.on_the_move;
  o.clock_offset_s = options_.tracker_clock_offset_s;
  o.clock_drift_ppm = options_.tracker_clock_drift_ppm;
  auto tracker = std::make_unique<simulation::EmsconSimulator>(lab_, 0, "127.0.0.1", 0, o);
  tracker->Start();
  tracker_ = tracker.get();
  io::InstrumentConfig i;
  i.station = "LT1";
  i.protocol = io::InstrumentProtocol::kEmScon;
  i.tcp = io::SplitHostPort(tracker->path());
  i.distance = true;
  i.measurement_time_ms = 200;
  lab_file_.instruments.push_back(i);
  simulators_.push_back(std::move(tracker));
}

void DemoLab::AddTheodolites() {
  const double angles[3] = {0.2, 2.3, 4.3};
  for (int s = 0; s < 3; ++s) {
    simulation::VirtualStation st;
    st.pose.id = "T" + std::to_string(s + 1);
    st.pose.position_mm = {3600.0 * std::cos(angles[s]), 3600.0 * std::sin(angles[s]),
                           450.0 + 150.0 * s};
    st.pose.azimuth_rad = WrapTwoPi(1.1 + 2.0 * s);
    st.pose.world_from_station = reduction::LevelledRotation(st.pose.azimuth_rad);
    st.sigma_angle_rad = kSigmaArcsec * kRadPerArcsec;
    lab_.AddStation(st);
  }
  for (int s = 0; s < 3; ++s) {
    const std::string id = "T" + std::to_string(s + 1);
    simulators_.push_back(std::make_unique<simulation::GeoComSimulator>(
        lab_, s, (options_.folder / id).string(), simulator_options_, "TDRA6000", 358120 + s));
    simulators_.back()->Start();
    io::InstrumentConfig i;
    i.station = id;
    i.protocol = io::InstrumentProtocol::kGeoCom;
    i.port = simulators_.back()->path();
    i.sigma_hz_arcsec = i.sigma_v_arcsec = kSigmaArcsec;
    lab_file_.instruments.push_back(i);
  }
}

DemoOrientation DemoLab::OrientTheodolites() {
  if (tracker_) throw std::logic_error("OrientTheodolites: a tracker lab needs no orientation");
  DemoOrientation out;
  reduction::OrientationProblem& setup = out.setup;
  std::vector<std::unique_ptr<instruments::GeoComDevice>> drivers;
  for (int s = 0; s < 3; ++s) {
    instruments::SerialSettings port;
    port.path = simulators_[s]->path();
    drivers.push_back(
        std::make_unique<instruments::GeoComDevice>(instruments::MakeSerialTransport(port)));
    setup.station_ids.push_back("T" + std::to_string(s + 1));
  }
  std::vector<std::string> targets = {"T1", "T2", "T3"};
  const Eigen::Vector3d bar_centres[3] = {{-300, 400, 600}, {500, -200, 1100}, {200, 600, 200}};
  const Eigen::Vector3d bar_dirs[3] = {{1, 0, 0}, {0, 0.6, 0.8}, {0.6, -0.8, 0}};
  for (int b = 0; b < 3; ++b) {
    const std::string a = "BAR" + std::to_string(b + 1) + "a",
                      c = "BAR" + std::to_string(b + 1) + "b";
    lab_.AddPoint(a, bar_centres[b] - 500.0 * bar_dirs[b].normalized());
    lab_.AddPoint(c, bar_centres[b] + 500.0 * bar_dirs[b].normalized());
    targets.push_back(a);
    targets.push_back(c);
    setup.scale_bars.push_back({a, c, 1000.0, 0.005});
  }
  for (int s = 0; s < 3; ++s) {
    for (const auto& t : targets) {
      if (t == setup.station_ids[s]) continue;
      lab_.Aim(s, t);
      reduction::Observation o;
      o.station = setup.station_ids[s];
      o.point = t;
      o.reading = drivers[s]->MeasureAngles().angles;
      o.sigma_hz_rad = o.sigma_v_rad = kSigmaArcsec * kRadPerArcsec;
      setup.observations.push_back(o);
    }
    lab_.Aim(s, "robot");
  }
  out.result = reduction::Orient(setup);
  if (!out.result.status.ok())
    throw std::runtime_error("demo: orientation failed: " + out.result.status.message);
  return out;
}

std::vector<reduction::Station> DemoLab::TrackerStations() const {
  reduction::Station lt1;
  lt1.pose = lab_.station(0).pose;
  return {lt1};
}

io::LabConfig DemoLab::WriteLabFiles(const std::vector<reduction::Station>& stations,
                                     bool base_by_hand) {
  const std::filesystem::path& folder = options_.folder;
  io::WriteFileAtomically((folder / robot_.model_file).string(), robot_.model_yaml);
  io::WriteFileAtomically((folder / "stations.yaml").string(),
                          io::FormatStationsYaml(stations, "armsig demo"));
  if (base_by_hand && tracker_) {
    // Measured by hand, as a lab would: 3 mm and 1 mrad off the truth.
    Eigen::Isometry3d given = base_;
    given.translate(Eigen::Vector3d(3.0, -2.0, 1.5));
    given.rotate(Eigen::AngleAxisd(1e-3, Eigen::Vector3d::UnitZ()));
    lab_file_.robot_base = given;
  }
  io::WriteFileAtomically((folder / "lab.yaml").string(), io::FormatLabYaml(lab_file_));
  return io::LoadLab((folder / "lab.yaml").string());
}

}  // namespace armsig::demo
