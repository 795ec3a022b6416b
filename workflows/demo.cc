#include "workflows/demo.h"


#include <fmt/format.h>
#include <signal.h>
#include <spdlog/spdlog.h>
#include <stdlib.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <filesystem>
#include <fstream>
#include <optional>
#include <random>
#include <regex>
#include <thread>

#include "acquisition/lab.h"
#include "acquisition/session_owner.h"
#include "calibration/identifiability.h"
#include "calibration/selection.h"
#include "calibration/simulation.h"
#include "core/error.h"
#include "core/text.h"
#include "core/units.h"
#include "db/database.h"
#include "db/postgres_connection.h"
#include "db/store.h"
#include "instruments/geocom_device.h"
#include "io/atomic_file.h"
#include "io/builtin_models.h"
#include "io/gsi_import.h"
#include "io/model_yaml.h"
#include "io/network_io.h"
#include "reduction/observation.h"
#include "reduction/orientation.h"
#include "simulation/emscon_simulator.h"
#include "simulation/simulators.h"
#include "workflows/calibration_run.h"
#include "workflows/capture.h"
#include "workflows/hint.h"
#include "workflows/network.h"
#include "workflows/reduce.h"

namespace armsig::workflows {

namespace {

constexpr double kSigmaArcsec = 0.5;
constexpr const char* kDemoRobot = "puma760-demo";

bool Stopped(const DemoOptions& options) { return options.stop && options.stop->load(); }

}  // namespace

Eigen::VectorXd ParsePlantedChanges(const calibration::RobotModel& model,
                                    const std::vector<std::string>& changes) {
  Eigen::VectorXd delta = Eigen::VectorXd::Zero(model.num_parameters());
  static const std::regex form(R"(^([A-Za-z][A-Za-z0-9_]*)=([+-]?[0-9]*\.?[0-9]+(?:[eE][+-]?[0-9]+)?)(mm|um|deg|mrad|urad|rad)$)");
  for (const auto& text : changes) {
    std::smatch m;
    if (!std::regex_match(text, m, form)) {
      throw InputError({"--change", 0, 0, ""},
                       Quoted(text) + ": expected NAME=VALUE with a unit, e.g. "
                                      "joint2_zero=0.02deg, link2_length=0.2mm or a3=-50um");
    }
    const std::string name = m[1].str(), unit = m[3].str();
    const double number = std::stod(m[2].str());
    const bool length = unit == "mm" || unit == "um";
    const double value = unit == "mm"     ? number
                         : unit == "um"   ? number * 1e-3
                         : unit == "deg"  ? number * kRadPerDeg
                         : unit == "mrad" ? number * 1e-3
                         : unit == "urad" ? number * 1e-6
                                          : number;
    // The change's direction in parameter space, and whether it is a length.
    Eigen::VectorXd direction = Eigen::VectorXd::Zero(model.num_parameters());
    bool is_length = false;
    std::smatch alias;
    static const std::regex zero(R"(^joint([0-9]+)_zero$)"), link(R"(^link([0-9]+)_length$)");
    if (std::regex_match(name, alias, zero)) {
      const int joint = std::stoi(alias[1].str());
      if (joint < 1 || joint > model.num_joints()) {
        throw InputError({"--change", 0, 0, ""},
                         fmt::format("{}: the robot has joints 1 to {}", Quoted(text),
                                     model.num_joints()));
      }
      direction(6 * (joint - 1) + 5) = 1.0;
    } else if (std::regex_match(name, alias, link)) {
      const int number_of_link = std::stoi(alias[1].str());
      if (number_of_link < 1 || number_of_link >= model.num_joints() ||
          model.links[number_of_link - 1].translation().norm() <= 1.0) {
        throw InputError({"--change", 0, 0, ""},
                         fmt::format("{}: expected a link 1 to {} with a nominal length",
                                     Quoted(text), model.num_joints() - 1));
      }
      const Eigen::Isometry3d& n = model.links[number_of_link - 1];
      direction.segment<3>(6 * number_of_link) =
          n.rotation().transpose() * n.translation().normalized();
      is_length = true;
    } else {
      const int index = model.IndexOf(name);
      if (index < 0) {
        throw InputError({"--change", 0, 0, ""},
                         Quoted(text) + ": no parameter " + Quoted(name) +
                             " (expected jointN_zero, linkN_length or a parameter name such as "
                             "gamma2, a3, h1)");
      }
      direction(index) = 1.0;
      is_length = model.UnitOf(index) == calibration::ParameterUnit::kMm;
    }
    if (is_length != length) {
      throw InputError({"--change", 0, 0, ""},
                       fmt::format("{}: {} is {}, expected a value in {}", Quoted(text), name,
                                   is_length ? "a length" : "an angle",
                                   is_length ? "mm or um" : "deg, mrad, urad or rad"));
    }
    delta += value * direction;
  }
  return delta;
}

DemoLimits DemoLimitsOf(const calibration::RobotModel& model, unsigned seed) {
  // Configurations spread over the joint limits, two per parameter: the model's
  // structural rank, not an accident of a few poses.
  std::mt19937 rng(seed);
  const auto spread = calibration::RandomConfigurations(model, 2 * model.num_parameters(), rng);
  std::vector<int> all(model.num_parameters());
  for (int i = 0; i < model.num_parameters(); ++i) all[i] = i;
  const auto id = calibration::AnalyseJacobian(
      calibration::StackedJacobian(model, Eigen::Isometry3d::Identity(),
                                   Eigen::VectorXd::Zero(model.num_parameters()), spread),
      all);
  DemoLimits limits;
  limits.identifiable = static_cast<int>(id.identified.size());
  limits.min_fit = limits.identifiable / 3 + 1;  // 3 equations per pose, more than unknowns
  limits.min_validation = limits.min_fit;
  limits.min_configurations = limits.min_fit + limits.min_validation;
  return limits;
}

int DemoSelectCount(int configurations, int select, const DemoLimits& limits) {
  if (configurations < limits.min_configurations) {
    throw InputError({"--configurations", 0, 0, ""},
                     fmt::format("{} configurations are too few: the calibration needs at least {} "
                                 "({} to fit the {} identifiable parameters, {} to validate)",
                                 configurations, limits.min_configurations, limits.min_fit,
                                 limits.identifiable, limits.min_validation));
  }
  const int most = configurations - limits.min_validation;
  if (select == 0) return std::clamp((2 * configurations + 2) / 5, limits.min_fit, most);
  if (select < limits.min_fit || select > most) {
    throw InputError({"--select", 0, 0, ""},
                     fmt::format("{} is outside {}…{}: with {} configurations the fit needs at "
                                 "least {} and the validation keeps at least {}",
                                 select, limits.min_fit, most, configurations, limits.min_fit,
                                 limits.min_validation));
  }
  return select;
}

namespace {

constexpr const char* kOwnerFile = "owner.pid";

// Scratch directories of demos that were killed (SIGKILL, a third Ctrl-C, a power cut):
// ours (same user), named armsig-demo-*, whose owner process no longer exists.
void RemoveAbandonedScratch() {
  std::error_code ec;
  for (const auto& entry :
       std::filesystem::directory_iterator(std::filesystem::temp_directory_path(), ec)) {
    const std::string name = entry.path().filename().string();
    if (name.rfind("armsig-demo-", 0) != 0 || !entry.is_directory(ec) || entry.is_symlink(ec))
      continue;
    struct stat info {};
    if (::lstat(entry.path().c_str(), &info) != 0 || info.st_uid != ::getuid()) continue;
    std::ifstream owner(entry.path() / kOwnerFile);
    long pid = 0;
    if (!(owner >> pid) || pid <= 0) continue;  // not one of ours, or being created
    if (::kill(static_cast<pid_t>(pid), 0) == 0 || errno != ESRCH) continue;  // alive
    std::filesystem::remove_all(entry.path(), ec);
    if (!ec) spdlog::info("demo: removed {} (left by process {}, which is gone)", name, pid);
  }
}

}  // namespace

namespace {

constexpr unsigned kFirstSeed = 1985;

// Demo sessions already stored (0 when there is no database yet: nothing is created
// here); resuming, those before the resumed one, so it keeps the seed it was begun with.
unsigned StoredDemoSessions(const std::string& db_path, int64_t resumed) {
  try {
    db::Database database(db_path, db::OpenMode::kReadOnly);
    const auto robot = db::FindRobot(database, kDemoRobot);
    if (!robot) return 0;
    unsigned count = 0;
    for (const auto& s : db::ListSessions(database, *robot)) count += resumed == 0 || s.id < resumed;
    return count;
  } catch (const InputError&) {
    return 0;  // no store there yet
  }
}

}  // namespace

DemoResult RunDemo(const DemoOptions& options, const DemoObserver& observer) {
  auto say = [&](const std::string& text) {
    if (observer.say) observer.say(text);
  };
  using namespace std::chrono_literals;
  const auto started = std::chrono::steady_clock::now();
  const calibration::RobotModel model = io::ParseRobotModel(io::kPuma760Yaml, "built-in PUMA 760");
  // A --db that can never open fails now, not after the virtual lab was built and oriented.
  db::CheckStoreAddress(options.db_path);
  const bool serving = !options.serve_dir.empty();
  if (serving && options.resume_session > 0) {
    throw InputError({"--serve", 0, 0, ""}, "a served lab captures nothing: no --resume with it");
  }
  const unsigned seed =
      options.seed ? *options.seed
      : serving    ? kFirstSeed
                   : kFirstSeed + StoredDemoSessions(options.db_path, options.resume_session);
  const DemoLimits limits = DemoLimitsOf(model, seed);
  // Everything the options decide is checked before anything is created.
  std::optional<db::Database> resumed_db;
  acquisition::Plan stored_plan;
  std::string stored_lab_yaml;
  if (options.resume_session > 0) {
    resumed_db.emplace(options.db_path, db::OpenMode::kMustExist);
    const auto row = db::LoadSession(*resumed_db, options.resume_session);
    if (!row || row->robot != kDemoRobot) {
      throw InputError({resumed_db->path(), 0, 0, ""},
                       fmt::format("no demo session {} (robot {}) to resume",
                                   options.resume_session, kDemoRobot));
    }
    stored_plan = acquisition::PlanFromJson(
        row->plan_json, {resumed_db->path(), "sessions", options.resume_session, "plan_json"});
    stored_lab_yaml = row->lab_yaml;
    if (row->state != "completed") {
      // Refused while another live process runs it (exit 2, naming the pid).
      acquisition::ClaimSession(*resumed_db, options.resume_session);
    }
  }
  if (!options.instrument.empty() && options.instrument != "theodolites" &&
      options.instrument != "tracker") {
    throw InputError({"--instrument", 0, 0, ""},
                     "expected theodolites or tracker, got '" + options.instrument + "'");
  }
  bool use_tracker = options.instrument == "tracker";
  if (options.resume_session > 0) {
    // The session keeps the instruments it was captured with.
    const bool stored_tracker = stored_lab_yaml.find("emscon") != std::string::npos;
    if (!options.instrument.empty() && stored_tracker != use_tracker) {
      throw InputError({"--instrument", 0, 0, ""},
                       fmt::format("demo session {} was captured with {}; resume it without "
                                   "--instrument or with --instrument {}",
                                   options.resume_session,
                                   stored_tracker ? "a laser tracker" : "theodolites",
                                   stored_tracker ? "tracker" : "theodolites"));
    }
    use_tracker = stored_tracker;
  }
  const int configurations =
      options.resume_session > 0 ? static_cast<int>(stored_plan.size()) : options.configurations;
  const int select_count = DemoSelectCount(configurations, options.select, limits);
  RemoveAbandonedScratch();
  std::filesystem::path work;
  if (serving) {
    std::error_code ec;
    std::filesystem::create_directories(options.serve_dir, ec);
    if (ec || !std::filesystem::is_directory(options.serve_dir)) {
      throw InputError({"--serve", 0, 0, ""},
                       "cannot make the folder " + options.serve_dir + " (" + ec.message() + ")");
    }
    work = std::filesystem::absolute(options.serve_dir);
  } else {
    // A fresh private directory (mkdtemp: mode 0700, a name nobody could plant in advance).
    std::string work_template =
        (std::filesystem::temp_directory_path() / "armsig-demo-XXXXXX").string();
    if (!::mkdtemp(work_template.data()))
      throw std::runtime_error("demo: cannot create a temporary directory in " +
                               std::filesystem::temp_directory_path().string());
    work = work_template;
    io::WriteFileAtomically((work / kOwnerFile).string(), std::to_string(::getpid()) + "\n");
  }
  struct Cleanup {
    std::filesystem::path path;  // empty: a served lab's folder stays
    ~Cleanup() {
      std::error_code ignored;
      if (!path.empty()) std::filesystem::remove_all(path, ignored);
    }
  } cleanup{serving ? std::filesystem::path() : work};

  // --- The virtual lab: the robot's hidden truth, its controller and the instruments.
  std::mt19937 rng(seed);
  simulation::SimulatorOptions sim;
  sim.time_scale = options.time_scale;
  sim.angle_latency = 40ms;
  sim.motion_latency = 60ms;
  std::vector<std::unique_ptr<simulation::Simulator>> simulators;
  simulation::EmsconSimulator* tracker = nullptr;  // in `simulators`, with a tracker
  int stations = 0;
  acquisition::LabFile lab_file;
  lab_file.model_path = "puma760.yaml";
  lab_file.stations_path = "stations.yaml";
  lab_file.controller.protocol = "as";
  lab_file.controller.can_move = true;
  lab_file.tolerances.max_miss_mm = 0.1;
  lab_file.tolerances.settle_ms = 0;
  lab_file.tolerances.readings = 1;
  lab_file.timeout_ms = 2000;
  Eigen::Isometry3d base = Eigen::Isometry3d::Identity();  // robot base in the lab frame
  if (use_tracker) {
    // The tracker's own frame is the lab frame; the robot stands about 3 m away, lower.
    base.translate(Eigen::Vector3d(2300.0, 1600.0, -1100.0));
    base.rotate(Eigen::AngleAxisd(2.6, Eigen::Vector3d::UnitZ()));
  } else {
    base.translate(Eigen::Vector3d(120.0, -80.0, 0.0));
    base.rotate(Eigen::AngleAxisd(0.35, Eigen::Vector3d::UnitZ()));
  }
  // The truth: the paper's errors, and what --change plants on top of them.
  const Eigen::VectorXd planted = ParsePlantedChanges(model, options.changes);
  simulation::VirtualLab lab(model, calibration::PaperTable3Parameters() + planted, base, seed);
  if (!options.changes.empty()) {
    std::string list;
    for (const auto& c : options.changes) list += (list.empty() ? "" : ", ") + c;
    say(fmt::format("The virtual robot is changed: {} (planted in its hidden errors).\n", list));
  }
  lab.SetRepeatability(options.repeatability_mm);
  std::vector<reduction::Station> oriented_stations;
  if (use_tracker) {
    simulation::VirtualStation st;
    st.pose.id = "LT1";  // at the origin, levelled, circle zero along +y: the lab frame
    lab.AddStation(st);
    simulation::EmsconSimulatorOptions o;
    o.time_scale = options.time_scale;
    o.seed = seed;
    // The reflector is found only near the beam: within 25 mm where it points, within
    // 150 mm by a search (FindReflector).
    o.acquire_radius_mm = 25.0;
    o.search_radius_mm = 150.0;
    auto t = std::make_unique<simulation::EmsconSimulator>(lab, 0, "127.0.0.1", 0, o);
    t->Start();
    tracker = t.get();
    acquisition::InstrumentConfig i;
    i.station = "LT1";
    i.protocol = "emscon";
    i.tcp = t->path();
    i.distance = true;
    i.measurement_time_ms = 200;
    lab_file.instruments.push_back(i);
    simulators.push_back(std::move(t));
    reduction::Station lt1;
    lt1.pose = st.pose;
    oriented_stations.push_back(lt1);
    stations = 1;
  } else {
    const double angles[3] = {0.2, 2.3, 4.3};
    for (int s = 0; s < 3; ++s) {
      simulation::VirtualStation st;
      st.pose.id = "T" + std::to_string(s + 1);
      st.pose.position_mm = {3600.0 * std::cos(angles[s]), 3600.0 * std::sin(angles[s]),
                             450.0 + 150.0 * s};
      st.pose.azimuth_rad = WrapTwoPi(1.1 + 2.0 * s);
      st.pose.world_from_station = reduction::LevelledRotation(st.pose.azimuth_rad);
      st.sigma_angle_rad = kSigmaArcsec * kRadPerArcsec;
      lab.AddStation(st);
    }
    for (int s = 0; s < 3; ++s) {
      simulators.push_back(std::make_unique<simulation::GeoComSimulator>(
          lab, s, (work / ("T" + std::to_string(s + 1))).string(), sim, "TDRA6000",
          358120 + s));
      simulators.back()->Start();
    }
  }
  simulation::ValSimulator robot_sim(lab, (work / "robot").string(),
                                     simulation::ValSimulator::Layout::kKawasakiAs, sim);
  robot_sim.Start();
  lab_file.controller.port = robot_sim.path();

  if (use_tracker) {
    say("armsig demo: virtual lab with a PUMA 760 (hidden errors: the paper's Table 3), a laser "
        "tracker\nspeaking Leica emScon on " +
        tracker->path() + " and a robot controller on a pseudo-terminal in " + work.string() +
        fmt::format("\n(seed {}: --seed {} repeats this run's noise and plan)\n\n", seed, seed));
    if (!serving) say("1. station LT1, a laser tracker: it measures direction and distance, so one station "
        "gives each point,\n   and a tracker-only lab needs no orientation by mutual pointings: "
        "the tracker's own frame is\n   the lab frame (LT1 at the origin, azimuth 0). Where the "
        "robot stands in it is not known yet:\n   the first configurations are measured where the "
        "tracker finds its reflector (here a virtual\n   operator points the beam at it, as a "
        "technician does with the tracker's camera); from three\n   measured points on, armsig "
        "fits the robot's base to them and points the beam at every next\n   target before "
        "measuring (stationary mode, 200 ms; each reading's own sigmas weight it).\n");
  } else {
    say("armsig demo: virtual lab with a PUMA 760 (hidden errors: the paper's Table 3), three "
        "GeoCOM\ntheodolites and a robot controller on pseudo-terminals in " +
        work.string() +
        fmt::format("\n(seed {}: --seed {} repeats this run's noise and plan)\n\n", seed, seed));

    // --- Station set-up: mutual pointings and a 1 m scale bar at three places, read
    // through the real GeoCOM drivers.
    reduction::OrientationProblem setup;
    std::vector<std::unique_ptr<instruments::GeoComDevice>> drivers;
    for (int s = 0; s < 3; ++s) {
      instruments::SerialSettings port;
      port.path = simulators[s]->path();
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
      lab.AddPoint(a, bar_centres[b] - 500.0 * bar_dirs[b].normalized());
      lab.AddPoint(c, bar_centres[b] + 500.0 * bar_dirs[b].normalized());
      targets.push_back(a);
      targets.push_back(c);
      setup.scale_bars.push_back({a, c, 1000.0, 0.005});
    }
    for (int s = 0; s < 3; ++s) {
      for (const auto& t : targets) {
        if (t == setup.station_ids[s]) continue;
        lab.Aim(s, t);
        reduction::Observation o;
        o.station = setup.station_ids[s];
        o.point = t;
        o.reading = drivers[s]->MeasureAngles().angles;
        o.sigma_hz_rad = o.sigma_v_rad = kSigmaArcsec * kRadPerArcsec;
        setup.observations.push_back(o);
      }
      lab.Aim(s, "robot");
    }
    const auto oriented = reduction::Orient(setup);
    if (!oriented.status.ok())
      throw std::runtime_error("demo: orientation failed: " + oriented.status.message);
    // A served lab keeps the readings it was oriented from, so a technician can orient it
    // again by hand (armsig orient --observations orientation.csv --scale-bar BAR1a:BAR1b=1000 …).
    if (serving) {
      io::WriteFileAtomically((work / "orientation.csv").string(),
                              io::FormatObservationsCsv(setup.observations));
    }
    drivers.clear();
    std::string removed;
    for (const auto& m : oriented.removed)
      removed += fmt::format("{}{} {}", removed.empty() ? "" : ", ", reduction::KindName(m.kind),
                             m.label);
    std::string text = fmt::format(
        "1. stations oriented from {} readings (mutual pointings, 3 bar set-ups): sigma0 {:.3f}, "
        "{} degrees of freedom, {}\n",
        setup.observations.size(), oriented.sigma0, oriented.dof,
        removed.empty() ? std::string("no reading removed by data snooping")
                        : "removed as blunders: " + removed);
    for (const auto& s : oriented.stations) {
      text += fmt::format(
          "   {}  x {:9.3f}  y {:9.3f}  z {:8.3f} mm  azimuth {:9.5f} gon  (sigma {:.3f} mm, "
          "{:.2f}\")\n",
          s.pose.id, s.pose.position_mm.x(), s.pose.position_mm.y(), s.pose.position_mm.z(),
          FromRad(s.pose.azimuth_rad, AngleUnit::kGon), s.sigma_position_mm.norm(),
          s.sigma_azimuth_rad / kRadPerArcsec);
    }
    say(text);
    // With the orientation's σ0, dof and method, which the session's set-ups then keep.
    oriented_stations = OrientedStations(setup, oriented);
    stations = static_cast<int>(oriented.stations.size());
    for (int s = 0; s < 3; ++s) {
      acquisition::InstrumentConfig i;
      i.station = "T" + std::to_string(s + 1);
      i.protocol = "geocom";
      i.port = simulators[s]->path();
      i.sigma_hz_arcsec = i.sigma_v_arcsec = kSigmaArcsec;
      lab_file.instruments.push_back(i);
    }
  }

  // --- The lab file a technician would write, and the capture session.
  io::WriteFileAtomically((work / "puma760.yaml").string(), io::kPuma760Yaml);
  io::WriteFileAtomically((work / "stations.yaml").string(),
                          io::FormatStationsYaml(oriented_stations, "armsig demo"));
  if (serving && use_tracker) {
    // Measured by hand, as a lab would: 3 mm and 1 mrad off the truth.
    Eigen::Isometry3d given = base;
    given.translate(Eigen::Vector3d(3.0, -2.0, 1.5));
    given.rotate(Eigen::AngleAxisd(1e-3, Eigen::Vector3d::UnitZ()));
    lab_file.robot_base = given;
  }
  io::WriteFileAtomically((work / "lab.yaml").string(), acquisition::FormatLabYaml(lab_file));
  const acquisition::LabConfig lab_config = acquisition::LoadLab((work / "lab.yaml").string());
  if (serving) {
    say(fmt::format(
        "virtual lab ready in {0}: lab.yaml, stations.yaml and puma760.yaml beside its devices.\n"
        "In another terminal:\n  armsig --db lab.db capture --lab {1} --plan auto:30 --robot "
        "puma\n{2}\n",
        work.string(), (work / "lab.yaml").string(),
        options.serve_seconds > 0 ? fmt::format("Serving for {:g} s (Ctrl-C ends it sooner).",
                                                options.serve_seconds)
                                  : std::string("Ctrl-C ends it.")));
    const auto until = std::chrono::steady_clock::now() +
                       std::chrono::duration<double>(options.serve_seconds);
    while (!Stopped(options) &&
           (options.serve_seconds <= 0 || std::chrono::steady_clock::now() < until)) {
      std::this_thread::sleep_for(50ms);
    }
    DemoResult served;
    served.completed = true;
    return served;
  }

  DemoResult result;
  if (Stopped(options) && options.resume_session == 0) {
    say("stopped before the capture began: nothing stored\n");
    return result;
  }
  // The paper's ~200 configurations: single-joint rotation tests, line and circle tests
  // (192 for six joints), the rest random; fewer than those tests: random ones, spread
  // over the joint limits.
  acquisition::Plan plan = stored_plan;
  if (options.resume_session == 0) {
    auto joints = calibration::LabTestConfigurations(model, rng);
    if (static_cast<int>(joints.size()) > configurations) joints.clear();
    for (const auto& q : calibration::RandomConfigurations(
             model, configurations - static_cast<int>(joints.size()), rng)) {
      joints.push_back(q);
    }
    for (const auto& q : joints) plan.push_back({"C" + std::to_string(plan.size() + 1), q});
  }
  if (!resumed_db) resumed_db.emplace(options.db_path);
  db::Database& database = *resumed_db;
  const int64_t session = options.resume_session > 0
                              ? options.resume_session
                              : acquisition::CreateSession(database, lab_config, kDemoRobot, plan);
  result.session = session;
  {
    std::vector<std::string> words = {"demo", "--resume", std::to_string(session), "--time-scale",
                                      fmt::format("{}", options.time_scale)};
    if (options.select > 0) words.insert(words.end(), {"--select", std::to_string(options.select)});
    if (!options.json_path.empty())
      words.insert(words.end(), {"--json", AbsolutePath(options.json_path)});
    result.resume_hint = Hint(database.path(), words);
  }
  acquisition::CaptureOptions capture;
  capture.progress = observer.progress;
  capture.stop = options.stop;
  if (tracker) {
    // The virtual operator: points the beam at the reflector when the tracker cannot find it.
    capture.prompt_reflector = [tracker](const std::string&,
                                         const acquisition::PlannedConfiguration&) {
      tracker->GuideBeamToReflector();
    };
  }
  const acquisition::CaptureSummary captured = CaptureInto(database, lab_config, session, capture);
  if (captured.stopped) {
    say(fmt::format("stopped: session {} is paused after {} of {} configurations\n", session,
                    captured.measured + captured.skipped + captured.already, captured.total));
    return result;
  }
  if (!captured.completed)
    throw std::runtime_error("demo: capture did not complete: " + captured.pause_reason);
  if (captured.failed + captured.flagged > 0) {
    std::string names;
    for (const auto* list : {&captured.failed_configurations, &captured.flagged_configurations})
      for (const auto& v : *list)
        names += (names.empty() ? "" : ", ") + v.label + " (" + v.why + ")";
    say(fmt::format("   {} failed and {} flagged configurations left out: {}\n", captured.failed,
                    captured.flagged, names));
  }
  say(fmt::format(
      "2. session {}: {} configurations captured in {:.1f} s ({:.1f} ms each, {:.2f} ms of it "
      "software, {:.2f} ms storing){}\n",
      session, captured.measured + captured.already, captured.seconds, captured.mean_cycle_ms,
      captured.mean_overhead_ms, captured.mean_store_ms,
      !tracker && captured.mean_miss_mm
          ? fmt::format("; miss distance mean {:.4f} mm, max {:.4f} mm", *captured.mean_miss_mm,
                        *captured.max_miss_mm)
          : std::string()));
  if (tracker) {
    say(fmt::format(
        "   beam: {} times pointed at the predicted target, {} searches around the beam, {} "
        "times pointed by the operator;\n   {}\n",
        captured.beam_predicted, captured.beam_searches, captured.beam_operator,
        captured.beam_base));
  }

  // --- Reduction in the database, then the poses for calibration.
  const auto reduced = ReduceSession(database, session, reduction::PointOptions{});
  std::vector<Eigen::Matrix3d> covariances;
  const std::vector<MeasuredPose> poses = db::LoadSessionPoses(database, session, &covariances);
  double noise_floor = 0.0;
  // Mean length of a 3-D normal error with these covariances ≈ 0.921·√trace (isotropic).
  for (const auto& c : covariances)
    noise_floor += 0.921 * std::sqrt(c.trace()) / covariances.size();
  say(fmt::format(
      "3. reduced {} observations into {} points ({} rays rejected); point precision: mean "
      "3-D error {:.4f} mm\n",
      reduced.observations, reduced.reduced, reduced.rejected_rays, noise_floor));

  // --- Select 80 well-spread configurations (D-optimal on all 43 parameters), fit the
  // paper's three models on them, validate on the rest.
  std::vector<Eigen::VectorXd> joints;
  for (const auto& p : poses) joints.push_back(p.joints_rad);
  std::vector<int> all(model.num_parameters());
  for (int i = 0; i < model.num_parameters(); ++i) all[i] = i;
  const auto id = calibration::AnalyseJacobian(
      calibration::StackedJacobian(model, Eigen::Isometry3d::Identity(),
                                   Eigen::VectorXd::Zero(model.num_parameters()), joints),
      all);
  calibration::SelectionOptions selection;
  selection.count =
      std::min<int>(select_count, static_cast<int>(poses.size()) - limits.min_validation);
  if (selection.count < limits.min_fit) {
    throw std::runtime_error(fmt::format(
        "demo: {} usable points of {} configurations: too few to fit and validate (need {})",
        poses.size(), plan.size(), limits.min_configurations));
  }
  const auto selected = calibration::SelectConfigurations(model, joints, id.identified, selection);
  std::vector<MeasuredPose> fit, validation;
  {
    std::vector<char> chosen(poses.size(), 0);
    for (int i : selected.selected) chosen[i] = 1;
    for (size_t i = 0; i < poses.size(); ++i) (chosen[i] ? fit : validation).push_back(poses[i]);
  }
  say(fmt::format(
      "4. selected {} of {} configurations (D-optimal, condition number {:.1f}); validating on "
      "the other {}\n\n",
      fit.size(), poses.size(), selected.condition_number, validation.size()));

  nlohmann::json stages = nlohmann::json::array();
  std::vector<CalibrationRun> runs;
  const int64_t robot_id = *db::FindRobot(database, kDemoRobot);
  for (const std::string spec : {"geometric", "geometric,h3,h4", "all"}) {
    if (Stopped(options)) {
      say(fmt::format("stopped: session {} is captured; nothing of its calibration stored\n",
                      session));
      return result;
    }
    CalibrateSettings settings;
    settings.params = spec;
    settings.model_subset = true;  // the robot's subset, as every later recalibration uses
    // The paper's stages are parametric models: their progression is compared with its
    // table without a residual map (which would hide what the missing terms cost). The last
    // stage, the set that becomes active, is fitted as `recalibrate` fits (map by CV).
    settings.residual_model = spec == "all" ? "auto" : "off";
    CalibrationRun run = RunCalibration(model, fit, validation, settings);
    say("--- params: " + spec + "\n" + FormatCalibrationReport(model, run) + "\n");
    nlohmann::json stage = CalibrationJson(model, run);
    stage["params"] = spec;
    stages.push_back(stage);
    runs.push_back(std::move(run));
  }
  // The three sets and the full model as the robot's active arm signature, in one
  // transaction: a demo stopped before this point stores none of them.
  {
    db::WriteTransaction tx(database);
    for (const auto& run : runs) {
      db::InsertCalibration(
          database,
          CalibrationRecordOf(model, run, robot_id,
                              {{"sessions", {std::to_string(session)}}, {"poses", poses.size()}},
                              {{"params", run.params_spec}, {"selection", "D-optimal"}}, false));
    }
    const auto before = db::ActiveCalibration(database, robot_id);
    const int newest = db::CalibrationHistory(database, robot_id).back().version;
    db::SetActiveVersion(database, robot_id, newest);
    db::RecordActivation(database, robot_id,
                         {newest, before ? std::optional<int>(before->version) : std::nullopt, "",
                          "demo", fmt::format("armsig demo, session {}, params all", session)});
    tx.commit();
  }

  std::string text = fmt::format(
      "The paper's progression, from this session's own data ({} fitted, {} validated):\n",
      fit.size(), validation.size());
  text += fmt::format("  {:<18}{:>12}{:>22}{:>26}{:>18}\n", "params", "identified",
                      "fit mean (max) mm", "validation mean (max) mm", "paper (fit)");
  const auto nominal_validation =
      calibration::Summarise(calibration::Distances(runs[0].validation_nominal_residuals));
  text += fmt::format(
      "  {:<18}{:>12}{:>22}{:>26}{:>18}\n", "nominal", "-",
      fmt::format("{:.3f} ({:.2f})", runs[0].estimate.nominal.mean_mm,
                  runs[0].estimate.nominal.max_mm),
      fmt::format("{:.3f} ({:.2f})", nominal_validation.mean_mm, nominal_validation.max_mm),
      "5.9 (10)");
  const char* paper[3] = {"1 (2)", "0.5 (1)", "0.27 (0.6)"};
  for (size_t k = 0; k < runs.size(); ++k) {
    const auto& e = runs[k].estimate;
    const auto v = StatsOf(runs[k].validation_residuals);
    text += fmt::format(
        "  {:<18}{:>12}{:>22}{:>26}{:>18}\n", runs[k].params_spec,
        fmt::format("{} of {}", e.identifiability.rank, e.identifiability.candidates.size()),
        fmt::format("{:.3f} ({:.2f})", e.fit.mean_mm, e.fit.max_mm),
        fmt::format("{:.3f} ({:.2f})", v.mean_mm, v.max_mm), paper[k]);
  }
  text += fmt::format("  measurement noise floor (mean 3-D error of a reduced point): {:.3f} mm\n",
                      noise_floor);
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
  say(text);
  say(fmt::format("\nDone in {:.1f} s. The database stays for inspection: {} ({})\n", seconds,
                  Printable(database.path()), Hint(database.path(), {"db", "info"})));

  {
    nlohmann::json& out = result.json;
    out["session"] = {{"id", session},
                      {"instrument", use_tracker ? "tracker" : "theodolites"},
                      {"poses", static_cast<int>(poses.size())},
                      {"observations", reduced.observations},
                      {"stations", stations},
                      {"noise_floor_mm", noise_floor},
                      {"seconds", seconds}};
    if (tracker) {
      out["session"]["beam"] = {{"predicted", captured.beam_predicted},
                                {"searches", captured.beam_searches},
                                {"operator", captured.beam_operator},
                                {"base", captured.beam_base}};
      out["session"]["software_ms_per_configuration"] = captured.mean_overhead_ms;
      out["session"]["store_ms_per_configuration"] = captured.mean_store_ms;
    }
    out["stages"] = stages;
  }
  if (!options.json_path.empty()) {
    try {
      io::WriteFileAtomically(options.json_path, JsonText(result.json, 2) + "\n");
    } catch (const OutputError& e) {
      // Everything the JSON summarises is stored by now: said, with its own exit code.
      throw StoredButOutputError(fmt::format(
          "the demo is done and stored (session {} and its parameter sets in {}); its JSON "
          "summary could not be written: {}",
          session, Printable(database.path()), e.what()));
    }
  }
  result.completed = true;
  result.seconds = seconds;
  return result;
}

}  // namespace armsig::workflows
