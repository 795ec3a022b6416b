#include "demo/demo.h"

#include <fmt/format.h>
#include <signal.h>
#include <spdlog/spdlog.h>
#include <stdlib.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <optional>
#include <random>
#include <regex>
#include <thread>

#include "acquisition/lab.h"
#include "acquisition/on_the_move.h"
#include "acquisition/session_owner.h"
#include "calibration/identifiability.h"
#include "calibration/selection.h"
#include "calibration/synthetic.h"
#include "core/error.h"
#include "core/text.h"
#include "core/text_layout.h"
#include "core/units.h"
#include "core/wording.h"
#include "db/database.h"
#include "db/postgres_connection.h"
#include "db/store.h"
#include "demo/demo_lab.h"
#include "demo/demo_paths.h"
#include "io/atomic_file.h"
#include "io/builtin_models.h"
#include "io/gsi_import.h"
#include "io/model_yaml.h"
#include "reduction/observation.h"
#include "simulation/ur_simulator.h"
#include "workflows/calibration_run.h"
#include "workflows/calibration_text.h"
#include "workflows/capture.h"
#include "workflows/hint.h"
#include "workflows/orient_triangulate.h"
#include "workflows/reduce.h"

namespace armsig::demo {

namespace {

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
    // A number a double holds, read without exceptions (1e-400 underflows, 1e400 overflows).
    std::string digits = m[2].str();
    if (digits.front() == '+') digits.erase(0, 1);
    double number = 0.0;
    const auto [end, ec] = std::from_chars(digits.data(), digits.data() + digits.size(), number);
    if (ec != std::errc() || end != digits.data() + digits.size() || !std::isfinite(number)) {
      throw InputError({"--change", 0, 0, ""},
                       Quoted(text) + ": " + m[2].str() +
                           " is not a number a double holds (expected a size such as 0.02deg "
                           "or -50um)");
    }
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
    // A joint or link number past any robot's (more digits than an int holds) is out of range.
    const auto index_of = [&](const std::string& digits_text) {
      int index = 0;
      const auto [at, error] = std::from_chars(
          digits_text.data(), digits_text.data() + digits_text.size(), index);
      return error == std::errc() && at == digits_text.data() + digits_text.size() ? index : -1;
    };
    if (std::regex_match(name, alias, zero)) {
      const int joint = index_of(alias[1].str());
      if (joint < 1 || joint > model.num_joints()) {
        throw InputError({"--change", 0, 0, ""},
                         fmt::format("{}: the robot has joints 1 to {}", Quoted(text),
                                     model.num_joints()));
      }
      direction(6 * (joint - 1) + 5) = 1.0;
    } else if (std::regex_match(name, alias, link)) {
      const int number_of_link = index_of(alias[1].str());
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

// `joints` in the order a greedy tour from `start` visits them: each next the one whose
// largest joint turn from the last is smallest (what a movej's time goes with).
std::vector<Eigen::VectorXd> NearestFirst(std::vector<Eigen::VectorXd> joints,
                                          const Eigen::VectorXd& start) {
  std::vector<Eigen::VectorXd> ordered;
  Eigen::VectorXd at = start;
  while (!joints.empty()) {
    size_t best = 0;
    double best_turn = std::numeric_limits<double>::infinity();
    for (size_t k = 0; k < joints.size(); ++k) {
      const double turn = at.size() == joints[k].size() ? (joints[k] - at).cwiseAbs().maxCoeff()
                                                          : 0.0;
      if (turn < best_turn) {
        best_turn = turn;
        best = k;
      }
    }
    at = joints[best];
    ordered.push_back(std::move(joints[best]));
    joints.erase(joints.begin() + static_cast<std::ptrdiff_t>(best));
  }
  return ordered;
}

// Demo sessions already stored (0 when there is no database yet: nothing is created
// here); resuming, those before the resumed one, so it keeps the seed it was begun with.
unsigned StoredDemoSessions(const std::string& db_path, const std::string& db_robot,
                            int64_t resumed) {
  try {
    db::Database database(db_path, db::OpenMode::kReadOnly);
    const auto robot = db::FindRobot(database, db_robot);
    if (!robot) return 0;
    unsigned count = 0;
    for (const auto& s : db::ListSessions(database, *robot)) count += resumed == 0 || s.id < resumed;
    return count;
  } catch (const InputError&) {
    return 0;  // no store there yet
  }
}

}  // namespace

std::string DemoProgressionText(const std::vector<workflows::CalibrationRun>& runs, double noise_floor_mm,
                                bool paper) {
  if (runs.empty()) return "";
  static const char* kPaper[] = {"1 (2)", "0.5 (1)", "0.27 (0.6)"};
  std::vector<std::string> header = {"params", "identified", "fit mean (max) mm",
                                     "validation mean (max) mm"};
  if (paper) header.push_back("paper (fit)");
  TextTable table(header);
  auto mean_max = [](const calibration::ErrorStats& s) {
    return fmt::format("{:.3f} ({:.2f})", s.mean_mm, s.max_mm);
  };
  std::vector<std::string> nominal = {
      "nominal", "-", mean_max(runs[0].estimate.nominal),
      mean_max(calibration::Summarise(calibration::Distances(runs[0].validation_nominal_residuals)))};
  if (paper) nominal.push_back("5.9 (10)");
  table.AddRow(nominal);
  for (size_t k = 0; k < runs.size(); ++k) {
    const auto& e = runs[k].estimate;
    std::vector<std::string> row = {
        runs[k].params_spec,
        fmt::format("{} of {}", e.identifiability.rank, e.identifiability.candidates.size()),
        mean_max(e.fit), mean_max(workflows::StatsOf(runs[k].validation_residuals))};
    if (paper) row.push_back(k < 3 ? kPaper[k] : "");
    table.AddRow(row);
  }
  const int fit = static_cast<int>(runs[0].fit_pose_ids.size()),
            validated = static_cast<int>(runs[0].validation_pose_ids.size());
  return fmt::format("{}, from this session's own data ({} fitted, {} validated):\n",
                     paper ? "The paper's progression" : "The calibration's progression", fit,
                     validated) +
         table.Render(workflows::kTextWidth, 2) +
         fmt::format("  measurement noise floor (mean 3-D error of a reduced point): {:.3f} mm\n",
                     noise_floor_mm);
}

std::string DemoOrientationText(const reduction::OrientationProblem& setup,
                                const reduction::OrientationResult& oriented) {
  std::string removed;
  for (const auto& m : oriented.removed)
    removed +=
        fmt::format("{}{} {}", removed.empty() ? "" : ", ", reduction::KindName(m.kind), m.label);
  std::string text = fmt::format(
      "1. stations oriented from {} (mutual pointings, 3 bar set-ups): sigma0 {:.3f}, {}, {}\n",
      Count(static_cast<int64_t>(setup.observations.size()), "reading"), oriented.sigma0,
      Count(oriented.dof, "degree of freedom", "degrees of freedom"),
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
  return text;
}

std::string DemoCaptureText(const acquisition::CaptureSummary& captured, bool tracker) {
  std::string text;
  if (captured.failed + captured.flagged > 0) {
    std::string names;
    for (const auto* list : {&captured.failed_configurations, &captured.flagged_configurations})
      for (const auto& v : *list)
        names += (names.empty() ? "" : ", ") + v.label + " (" + v.why + ")";
    text += fmt::format("   {} left out ({} failed, {} flagged): {}\n",
                        Count(captured.failed + captured.flagged, "configuration"), captured.failed,
                        captured.flagged, names);
  }
  text += fmt::format(
      "2. session {}: {} captured in {:.1f} s ({:.1f} ms each, {:.2f} ms of it software, {:.2f} "
      "ms storing){}\n",
      captured.session, Count(captured.measured + captured.already, "configuration"),
      captured.seconds, captured.mean_cycle_ms, captured.mean_overhead_ms, captured.mean_store_ms,
      !tracker && captured.mean_miss_mm
          ? fmt::format("; miss distance mean {:.4f} mm, max {:.4f} mm", *captured.mean_miss_mm,
                        *captured.max_miss_mm)
          : std::string());
  if (tracker) {
    text += fmt::format(
        "   beam: {} pointed at the predicted target, {} around the beam, {} pointed by the "
        "operator;\n   {}\n",
        Count(captured.beam_predicted, "time"), Count(captured.beam_searches, "search", "searches"),
        Count(captured.beam_operator, "time"), captured.beam_base);
  }
  return text;
}

namespace {

// The demo's own folder: a fresh private one under $TMPDIR holding its owner's pid,
// removed on every way out but a hard kill; or the --serve folder, which stays.
class DemoFolder {
 public:
  explicit DemoFolder(const std::string& serve_dir) {
    if (!serve_dir.empty()) {
      std::error_code ec;
      std::filesystem::create_directories(serve_dir, ec);
      if (ec || !std::filesystem::is_directory(serve_dir)) {
        throw InputError({"--serve", 0, 0, ""},
                         "cannot make the folder " + serve_dir + " (" + ec.message() + ")");
      }
      path_ = std::filesystem::absolute(serve_dir);
      return;
    }
    // mkdtemp: mode 0700, a name nobody could plant in advance.
    std::string work_template =
        (std::filesystem::temp_directory_path() / "armsig-demo-XXXXXX").string();
    if (!::mkdtemp(work_template.data()))
      throw std::runtime_error("demo: cannot create a temporary directory in " +
                               std::filesystem::temp_directory_path().string());
    path_ = work_template;
    remove_ = true;
    io::WriteFileAtomically((path_ / kOwnerFile).string(), std::to_string(::getpid()) + "\n");
  }
  ~DemoFolder() {
    std::error_code ignored;
    if (remove_) std::filesystem::remove_all(path_, ignored);
  }
  DemoFolder(const DemoFolder&) = delete;
  DemoFolder& operator=(const DemoFolder&) = delete;
  const std::filesystem::path& path() const { return path_; }

 private:
  std::filesystem::path path_;
  bool remove_ = false;
};

// The demo's chain, one method per step, in the order Run calls them; the state one step
// leaves for the next in members. Members are declared so that the virtual lab's devices
// stop before its folder is removed and the database closes last.
class DemoRun {
 public:
  DemoRun(const DemoOptions& options, const DemoObserver& observer)
      : options_(options),
        observer_(observer),
        started_(std::chrono::steady_clock::now()),
        robot_(&FindDemoRobot(options.robot.empty() ? "puma" : options.robot)),
        serving_(!options.serve_dir.empty()) {}

  DemoResult Run() {
    CheckOptions();
    RemoveAbandonedScratch();
    folder_.emplace(options_.serve_dir);
    BuildLab();
    if (serving_) return Serve();
    if (Stopped(options_) && options_.resume_session == 0) {
      Say("stopped before the capture began: nothing stored\n");
      return result_;
    }
    if (!Capture()) return result_;
    Reduce();
    SelectConfigurations();
    if (!Calibrate()) return result_;
    StoreSets();
    if (on_the_move_) Iso9283Paths();
    Summarise();
    WriteJson();
    result_.completed = true;
    return result_;
  }

 private:
  // The narrative, each line at most 100 columns; a step's continuation lines under its
  // text ("1. …").
  void Say(const std::string& text, int hanging = 3) const {
    if (observer_.say) observer_.say(WrapLines(text, workflows::kTextWidth, hanging));
  }

  void CheckOptions();
  void OpenResumedSession();
  void BuildLab();
  void Introduce();
  DemoResult Serve();
  bool Capture();
  void Reduce();
  void SelectConfigurations();
  bool Calibrate();
  void StoreSets();
  void Iso9283Paths();
  void Summarise();
  void WriteJson();

  const DemoOptions& options_;
  const DemoObserver& observer_;
  const std::chrono::steady_clock::time_point started_;
  const DemoRobot* robot_;  // --robot, or a resumed session's
  calibration::RobotModel model_;
  const bool serving_;
  double time_scale_ = 0.25;
  // From the options (CheckOptions).
  unsigned seed_ = kFirstSeed;
  DemoLimits limits_;
  bool use_tracker_ = false;
  int select_count_ = 0;
  std::optional<db::Database> database_;  // opened at once when resuming
  acquisition::Plan stored_plan_;         // a resumed session's
  std::string stored_lab_yaml_;
  // The lab (BuildLab).
  std::optional<DemoFolder> folder_;
  std::unique_ptr<DemoLab> lab_;
  int stations_ = 0;
  io::LabConfig lab_config_;
  // The session and its results.
  acquisition::Plan plan_;
  int64_t session_ = 0;
  acquisition::CaptureSummary captured_;
  workflows::ReduceSummary reduced_;
  std::vector<MeasuredPose> poses_, fit_, validation_;
  double noise_floor_mm_ = 0.0;
  nlohmann::json stages_ = nlohmann::json::array();
  std::vector<workflows::CalibrationRun> runs_;
  double seconds_ = 0.0;
  DemoResult result_;
  // Measuring on the move: how the session is captured, the virtual tracker's planted clock.
  bool on_the_move_ = false;
  double planted_offset_ms_ = 0.0, planted_drift_ppm_ = 0.0;
  nlohmann::json iso9283_paths_;  // Iso9283Paths' figures
  double capture_robot_time_s_ = 0.0;  // the arm's moving time when the capture ended
};

// Everything the options decide is checked before anything is created.
void DemoRun::CheckOptions() {
  // A --db that can never open fails now, not after the virtual lab was built and oriented.
  db::CheckStoreAddress(options_.db_path);
  if (serving_ && options_.resume_session > 0) {
    throw InputError({"--serve", 0, 0, ""}, "a served lab captures nothing: no --resume with it");
  }
  if (options_.resume_session > 0) OpenResumedSession();
  model_ = io::ParseRobotModel(robot_->model_yaml, "built-in " + robot_->model_file);
  time_scale_ = options_.time_scale.value_or(robot_->time_scale);
  // On the move the joint stream must keep up: RTDE sends at most a package per 0.2 ms of wall
  // time, so a sweep runs at most 20 times faster than the real arm (250 Hz of physical time).
  if ((options_.on_the_move || (serving_ && robot_->controller == io::ControllerProtocol::kUr)) &&
      !options_.time_scale) {
    time_scale_ = std::max(time_scale_, 0.05);  // a served UR is measured on the move too
  }
  if (options_.on_the_move && time_scale_ < 0.05) {
    throw InputError({"--time-scale", 0, 0, ""},
                     fmt::format("{:g} is too fast to measure on the move: the virtual UR sends at "
                                 "most one RTDE package per 0.2 ms of wall time, so the joint "
                                 "stream keeps up only from 0.05 on",
                                 time_scale_));
  }
  seed_ = options_.seed ? *options_.seed
          : serving_    ? kFirstSeed
                     : kFirstSeed + StoredDemoSessions(options_.db_path, robot_->db_robot,
                                                       options_.resume_session);
  limits_ = DemoLimitsOf(model_, seed_);
  if (!options_.instrument.empty() && options_.instrument != "theodolites" &&
      options_.instrument != "tracker") {
    throw InputError({"--instrument", 0, 0, ""},
                     "expected theodolites or tracker, got '" + options_.instrument + "'");
  }
  use_tracker_ = options_.instrument == "tracker";
  if (options_.on_the_move && robot_->controller != io::ControllerProtocol::kUr) {
    throw InputError({"--on-the-move", 0, 0, ""},
                     "measuring on the move needs a controller that streams its joints: "
                     "--robot ur10");
  }
  if (options_.on_the_move && options_.waypoints < 3) {
    throw InputError({"--waypoints", 0, 0, ""}, "a sweep needs at least 3 waypoints");
  }
  if (robot_->tracker_only) {
    if (options_.instrument == "theodolites") {
      throw InputError({"--instrument", 0, 0, ""},
                       "--robot " + robot_->name + " is measured by the laser tracker: no "
                       "--instrument theodolites with it");
    }
    use_tracker_ = true;
  }
  if (options_.resume_session > 0) {
    // The session keeps the instruments it was captured with.
    const bool stored_tracker = stored_lab_yaml_.find("emscon") != std::string::npos;
    if (!options_.instrument.empty() && stored_tracker != use_tracker_) {
      throw InputError(
          {"--instrument", 0, 0, ""},
          fmt::format("demo session {} was captured with {}; resume it without "
                      "--instrument or with --instrument {}",
                      options_.resume_session, stored_tracker ? "a laser tracker" : "theodolites",
                      stored_tracker ? "tracker" : "theodolites"));
    }
    use_tracker_ = stored_tracker;
  }
  on_the_move_ = options_.on_the_move;
  if (options_.resume_session > 0) {
    on_the_move_ = acquisition::IsOnTheMoveSession(*database_, options_.resume_session);
  }
  const int configurations =
      options_.resume_session > 0 ? static_cast<int>(stored_plan_.size()) : options_.configurations;
  select_count_ = on_the_move_ ? 0 : DemoSelectCount(configurations, options_.select, limits_);
}

// The stored session to resume: its plan and lab file, claimed unless it is complete.
void DemoRun::OpenResumedSession() {
  database_.emplace(options_.db_path, db::OpenMode::kMustExist);
  const auto row = db::LoadSession(*database_, options_.resume_session);
  const DemoRobot* stored = row ? DemoRobotOfStored(row->robot) : nullptr;
  if (!stored) {
    throw InputError({database_->path(), 0, 0, ""},
                     fmt::format("no demo session {} to resume (a demo robot's: {})",
                                 options_.resume_session, robot_->db_robot));
  }
  if (!options_.robot.empty() && stored != robot_) {
    throw InputError({"--robot", 0, 0, ""},
                     fmt::format("demo session {} is of --robot {}; resume it without --robot or "
                                 "with --robot {}",
                                 options_.resume_session, stored->name, stored->name));
  }
  robot_ = stored;  // a session keeps its robot
  stored_plan_ = acquisition::PlanFromJson(
      row->plan_json, {database_->path(), "sessions", options_.resume_session, "plan_json"});
  stored_lab_yaml_ = row->lab_yaml;
  if (row->state != db::SessionState::kCompleted) {
    // Refused while another live process runs it (exit 2, naming the pid).
    acquisition::ClaimSession(*database_, options_.resume_session);
  }
}

// The virtual lab: the robot's hidden truth, its controller and the instruments, the
// stations oriented (theodolites), and the lab files a technician would write.
void DemoRun::BuildLab() {
  DemoLabOptions o;
  o.robot = robot_->name;
  o.tracker = use_tracker_;
  o.seed = seed_;
  o.time_scale = time_scale_;
  o.repeatability_mm = options_.repeatability_mm;
  o.setup = options_.setup;
  o.planted = ParsePlantedChanges(model_, options_.changes);
  o.folder = folder_->path();
  // A UR and a tracker can always be measured on the move (a served lab too: `capture
  // --on-the-move` by hand); the tracker's clock is off the controller's either way.
  o.on_the_move = use_tracker_ && robot_->controller == io::ControllerProtocol::kUr;
  if (o.on_the_move) {
    // The tracker's clock: an offset of up to a quarter second and a drift of tens of ppm,
    // drawn from the seed unless given (what a lab never knows beforehand).
    std::mt19937 rng(seed_ + 101);
    std::uniform_real_distribution<double> offset(-250.0, 250.0), drift(-30.0, 30.0);
    planted_offset_ms_ = options_.clock_offset_ms.value_or(offset(rng));
    planted_drift_ppm_ = options_.clock_drift_ppm.value_or(drift(rng));
    o.tracker_clock_offset_s = planted_offset_ms_ * 1e-3;
    o.tracker_clock_drift_ppm = planted_drift_ppm_;
  }
  lab_ = std::make_unique<DemoLab>(model_, o);
  if (!options_.changes.empty()) {
    std::string list;
    for (const auto& c : options_.changes) list += (list.empty() ? "" : ", ") + c;
    Say(fmt::format("The virtual robot is changed: {} (planted in its hidden errors).\n", list));
  }
  Introduce();
  std::vector<reduction::Station> stations;
  if (use_tracker_) {
    stations = lab_->TrackerStations();
  } else {
    // Station set-up: mutual pointings and a 1 m scale bar at three places, read through
    // the real GeoCOM drivers.
    const DemoOrientation oriented = lab_->OrientTheodolites();
    // A served lab keeps the readings it was oriented from, so a technician can orient it
    // again by hand (armsig orient --observations orientation.csv --scale-bar BAR1a:BAR1b=1000 …).
    if (serving_) {
      io::WriteFileAtomically((lab_->folder() / "orientation.csv").string(),
                              io::FormatObservationsCsv(oriented.setup.observations));
    }
    Say(DemoOrientationText(oriented.setup, oriented.result));
    // With the orientation's σ0, dof and method, which the session's set-ups then keep.
    stations = workflows::OrientedStations(oriented.setup, oriented.result);
  }
  stations_ = static_cast<int>(stations.size());
  lab_config_ = lab_->WriteLabFiles(stations, serving_);
}

void DemoRun::Introduce() {
  const std::string setup = options_.setup > 0 ? fmt::format(" --setup {}", options_.setup) : "";
  const std::string seed = fmt::format(
      "\n(seed {}: --seed {}{} repeats this run's noise and plan)\n\n", seed_, seed_, setup);
  const std::string folder = lab_->folder().string();
  if (!use_tracker_) {
    Say("armsig demo: virtual lab with " + robot_->description +
            ", three GeoCOM theodolites and a robot controller on pseudo-terminals in " + folder +
            seed,
        0);
    return;
  }
  const std::string controller =
      robot_->controller == io::ControllerProtocol::kUr || robot_->controller == io::ControllerProtocol::kKuka
          ? robot_->controller_text + " at " + lab_->controller_address()
          : robot_->controller_text;
  Say("armsig demo: virtual lab with " + robot_->description +
          ", a laser tracker speaking Leica emScon on " + lab_->tracker_address() + " and " +
          controller + ", in " + folder + seed,
      0);
  if (serving_) return;
  if (on_the_move_) {
    Say(fmt::format(
        "1. station LT1, a laser tracker, measuring on the move: the arm sweeps {} well-spread "
        "waypoints without stopping while the tracker measures continuously (a point every 50 ms "
        "of its own clock) and the controller streams its joints over RTDE (stamped with its "
        "clock). The two clocks differ (here by a planted {:.3f} ms and {:.2f} ppm, which armsig "
        "is not told): the offset and drift are estimated from the data themselves, each tracker "
        "point is paired with the joints at its own instant, and points taken while the arm "
        "accelerates are left out.\n",
        options_.resume_session > 0 ? stored_plan_.size() : static_cast<size_t>(options_.waypoints),
        planted_offset_ms_, planted_drift_ppm_));
    return;
  }
  Say("1. station LT1, a laser tracker: it measures direction and distance, so one station "
      "gives each point, and a tracker-only lab needs no orientation by mutual pointings: the "
      "tracker's own frame is the lab frame (LT1 at the origin, azimuth 0). Where the robot "
      "stands in it is not known yet: the first configurations are measured where the tracker "
      "finds its reflector (here a virtual operator points the beam at it, as a technician does "
      "with the tracker's camera); from three measured points on, armsig fits the robot's base "
      "to them and points the beam at every next target before measuring (stationary mode, "
      "200 ms; each reading's own sigmas weight it).\n");
}

// --serve: the lab stays up for a capture by hand until the time is up or Ctrl-C.
DemoResult DemoRun::Serve() {
  using namespace std::chrono_literals;
  const std::string folder = lab_->folder().string();
  Say(fmt::format(
      "virtual lab ready in {0}: lab.yaml, stations.yaml and {3} beside its devices.\n"
      "In another terminal:\n  armsig --db lab.db capture --lab {1} --plan auto:30 --robot "
      "{4}\n{2}\n",
      folder, (lab_->folder() / "lab.yaml").string(),
      options_.serve_seconds > 0
          ? fmt::format("Serving for {:g} s (Ctrl-C ends it sooner).", options_.serve_seconds)
          : std::string("Ctrl-C ends it."),
      robot_->model_file, robot_->name));
  if (robot_->controller == io::ControllerProtocol::kUr && use_tracker_) {
    Say(fmt::format("or on the move (the tracker measures continuously while the arm sweeps):\n"
                    "  armsig --db lab.db capture --lab {} --plan auto:30 --robot {} --on-the-move\n",
                    (lab_->folder() / "lab.yaml").string(), robot_->name));
  }
  const auto until =
      std::chrono::steady_clock::now() + std::chrono::duration<double>(options_.serve_seconds);
  while (!Stopped(options_) &&
         (options_.serve_seconds <= 0 || std::chrono::steady_clock::now() < until)) {
    std::this_thread::sleep_for(50ms);
  }
  DemoResult served;
  served.completed = !Stopped(options_);  // Ctrl-C: stopped, as every command it stops
  return served;
}

// The plan (the paper's ~200 configurations: single-joint rotation tests, line and circle
// tests, 192 for six joints, the rest random; fewer than those tests: random ones spread
// over the joint limits), the session, and the capture through the real drivers. False
// when stopped (the session is paused).
bool DemoRun::Capture() {
  plan_ = stored_plan_;
  if (options_.resume_session == 0) {
    std::mt19937 rng(seed_);
    std::vector<Eigen::VectorXd> joints;
    if (robot_->paper) {
      joints = calibration::LabTestConfigurations(model_, rng);
      if (static_cast<int>(joints.size()) > options_.configurations) joints.clear();
    }
    const int count = on_the_move_ ? options_.waypoints : options_.configurations;
    for (const auto& q : calibration::RandomConfigurations(
             model_, count - static_cast<int>(joints.size()), rng)) {
      joints.push_back(q);
    }
    // An arm whose moves take their real time: each next configuration the one nearest the
    // last (the smallest largest joint turn), from where the arm stands.
    if (!robot_->paper) joints = NearestFirst(std::move(joints), lab_->home());
    for (const auto& q : joints) plan_.push_back({"C" + std::to_string(plan_.size() + 1), q});
  }
  if (!database_) database_.emplace(options_.db_path);
  db::Database& database = *database_;
  session_ = options_.resume_session > 0
                 ? options_.resume_session
                 : acquisition::CreateSession(database, lab_config_, robot_->db_robot, plan_);
  if (on_the_move_ && options_.resume_session == 0) acquisition::MarkOnTheMove(database, session_);
  result_.session = session_;
  {
    std::vector<std::string> words = {"demo", "--resume", std::to_string(session_), "--time-scale",
                                      fmt::format("{}", time_scale_)};
    if (options_.select > 0)
      words.insert(words.end(), {"--select", std::to_string(options_.select)});
    if (!options_.json_path.empty())
      words.insert(words.end(), {"--json", workflows::AbsolutePath(options_.json_path)});
    result_.resume_hint = workflows::Hint(database.path(), words);
  }
  acquisition::CaptureOptions capture;
  capture.progress = observer_.progress;
  capture.stop = options_.stop;
  if (auto* tracker = lab_->tracker()) {
    // The virtual operator: points the beam at the reflector when the tracker cannot find it.
    capture.prompt_reflector = [tracker](const std::string&,
                                         const acquisition::PlannedConfiguration&) {
      tracker->GuideBeamToReflector();
    };
  }
  try {
    captured_ = workflows::CaptureInto(database, lab_config_, session_, capture);
  } catch (const std::exception& e) {
    // Ctrl-C while the devices were asked who they are cuts the call short: stopped, the
    // session paused (CaptureInto), as a stop between configurations.
    if (!Stopped(options_)) throw;
    spdlog::debug("demo: stopped while the devices were asked: {}", e.what());
    Say(fmt::format("stopped: session {} is paused before its devices measured\n", session_));
    return false;
  }
  if (captured_.stopped) {
    Say(fmt::format("stopped: session {} is paused after {} of {} configurations\n", session_,
                    captured_.measured + captured_.skipped + captured_.already, captured_.total));
    return false;
  }
  if (!captured_.completed)
    throw std::runtime_error("demo: capture did not complete: " + captured_.pause_reason);
  captured_.session = session_;
  if (captured_.sweep) {
    Say("2. " + workflows::FormatCaptureSummary(captured_));
  } else {
    Say(DemoCaptureText(captured_, use_tracker_));
  }
  if (auto* ur = lab_->ur()) {
    capture_robot_time_s_ = ur->arm().moving_s();
    const int thinning = simulation::UrSimulator::Thinning(ur->frequency_hz(), time_scale_);
    Say(fmt::format("   the arm moved for {:.1f} min of its own time (movej, {:.2f} rad/s; {:.1f} s of "
                    "wall time at time scale {:g}); joints from RTDE's {:g} Hz recipe{}, each "
                    "stamped with the controller's clock; the controller: {}\n",
                    ur->arm().moving_s() / 60.0,
                    captured_.sweep ? captured_.sweep->speed_rad_s : 1.05,
                    ur->arm().moving_s() * time_scale_, time_scale_,
                    ur->frequency_hz(),
                    thinning > 1 ? fmt::format(" (one package in {} sent at this time scale)", thinning)
                                 : std::string(),
                    captured_.controller));
  }
  return true;
}

// Reduction in the database, then the poses for calibration and their precision.
void DemoRun::Reduce() {
  reduced_ = workflows::ReduceSession(*database_, session_, reduction::PointOptions{});
  std::vector<Eigen::Matrix3d> covariances;
  poses_ = db::LoadSessionPoses(*database_, session_, &covariances);
  // Mean length of a 3-D normal error with these covariances ≈ 0.921·√trace (isotropic).
  for (const auto& c : covariances)
    noise_floor_mm_ += 0.921 * std::sqrt(c.trace()) / covariances.size();
  Say(fmt::format(
      "3. reduced {} into {} ({} rejected); point precision: mean 3-D error {:.4f} mm\n",
      Count(reduced_.observations, "observation"), Count(reduced_.reduced, "point"),
      Count(reduced_.rejected_rays, "ray"), noise_floor_mm_));
}

// The best-spread configurations (D-optimal on all 43 parameters) to fit, the rest to
// validate.
void DemoRun::SelectConfigurations() {
  std::vector<MeasuredPose> pool = poses_;
  std::vector<MeasuredPose> held_out;
  if (on_the_move_) {
    // The swept stream's neighbours are alike: the validation holds out whole stretches of
    // the sweep (every third of nine, in time order), and the fit selects from the rest.
    pool.clear();
    const size_t n = poses_.size();
    for (size_t i = 0; i < n; ++i) (((9 * i) / std::max<size_t>(n, 1)) % 3 == 1 ? held_out : pool).push_back(poses_[i]);
  }
  std::vector<Eigen::VectorXd> joints;
  for (const auto& p : pool) joints.push_back(p.joints_rad);
  std::vector<int> all(model_.num_parameters());
  for (int i = 0; i < model_.num_parameters(); ++i) all[i] = i;
  const auto id = calibration::AnalyseJacobian(
      calibration::StackedJacobian(model_, Eigen::Isometry3d::Identity(),
                                   Eigen::VectorXd::Zero(model_.num_parameters()), joints),
      all);
  calibration::SelectionOptions selection;
  if (on_the_move_) {
    selection.count = std::min<int>(options_.select > 0 ? options_.select : 300,
                                    static_cast<int>(pool.size()));
  } else {
    selection.count =
        std::min<int>(select_count_, static_cast<int>(poses_.size()) - limits_.min_validation);
  }
  if (selection.count < limits_.min_fit) {
    throw std::runtime_error(fmt::format(
        "demo: {} usable points of {} configurations: too few to fit and validate (need {})",
        poses_.size(), plan_.size(), limits_.min_configurations));
  }
  const auto selected = calibration::SelectConfigurations(model_, joints, id.identified, selection);
  std::vector<char> chosen(pool.size(), 0);
  for (int i : selected.selected) chosen[i] = 1;
  for (size_t i = 0; i < pool.size(); ++i) {
    if (chosen[i]) {
      fit_.push_back(pool[i]);
    } else if (!on_the_move_) {
      validation_.push_back(pool[i]);
    }
  }
  if (on_the_move_) validation_ = held_out;
  Say(fmt::format(
      "4. selected {} of {} configurations (D-optimal{}, condition number {:.1f}); validating on "
      "{} {}\n\n",
      fit_.size(), pool.size(), on_the_move_ ? " on the swept stream" : "",
      selected.condition_number, validation_.size(),
      on_the_move_ ? "points of the held-out stretches of the sweep" : "others"));
}

// The paper's three parameter sets fitted on the selection, validated on the rest. False
// when stopped (nothing of the calibration stored).
bool DemoRun::Calibrate() {
  for (const std::string& spec : robot_->stages) {
    if (Stopped(options_)) {
      Say(fmt::format("stopped: session {} is captured; nothing of its calibration stored\n",
                      session_));
      return false;
    }
    workflows::CalibrateSettings settings;
    settings.params = spec;
    settings.model_subset = true;  // the robot's subset, as every later recalibration uses
    // The paper's stages are parametric models: their progression is compared with its
    // table without a residual map (which would hide what the missing terms cost). The last
    // stage, the set that becomes active, is fitted as `recalibrate` fits (map by CV).
    settings.residual_model = spec == "all" ? "auto" : "off";
    workflows::CalibrationRun run = RunCalibration(model_, fit_, validation_, settings);
    Say("--- params: " + spec + "\n" + FormatCalibrationReport(model_, run) + "\n");
    nlohmann::json stage = CalibrationJson(model_, run);
    stage["params"] = spec;
    stages_.push_back(stage);
    runs_.push_back(std::move(run));
  }
  return true;
}

// The three sets and the full model as the robot's active arm signature, in one
// transaction: a demo stopped before this point stores none of them.
void DemoRun::StoreSets() {
  db::Database& database = *database_;
  const int64_t robot_id = *db::FindRobot(database, robot_->db_robot);
  db::WriteTransaction tx(database);
  for (const auto& run : runs_) {
    db::InsertCalibration(
        database,
        CalibrationRecordOf(model_, run, robot_id,
                            {{"sessions", {std::to_string(session_)}}, {"poses", poses_.size()}},
                            {{"params", run.params_spec}, {"selection", "D-optimal"}}, false));
  }
  const auto before = db::ActiveCalibration(database, robot_id);
  const int newest = db::CalibrationHistory(database, robot_id).back().version;
  db::SetActiveVersion(database, robot_id, newest);
  db::RecordActivation(database, robot_id,
                       {newest, before ? std::optional<int>(before->version) : std::nullopt, "",
                        "demo", fmt::format("armsig demo, session {}, params all", session_)});
  tx.commit();
}

// ISO 9283 path characteristics on the virtual UR10 (on the move, demo/demo_paths.h), after
// the calibration: a failure is said, never the demo's.
void DemoRun::Iso9283Paths() {
  if (!lab_->ur() || !lab_->tracker() || runs_.empty() || lab_config_.stations.empty()) return;
  try {
    const DemoPathFigures f =
        MeasureIso9283Paths(*lab_, model_, runs_.back().estimate, lab_config_, options_.stop);
    if (f.stopped) return;
    iso9283_paths_ = f.json;
    Say("5. ISO 9283 path characteristics (clause 8), the standard's paths in a 300 mm cube, movel "
        "at 250 mm/s on the controller's own kinematics, measured on the move (the attained paths "
        "in the robot frame of the set just fitted):\n"
        "  path       program        AT mm  mean AT   RT mm     AV %    RV %  FV mm/s\n" + f.table,
        0);
  } catch (const std::exception& e) {
    if (Stopped(options_)) return;
    Say(fmt::format("5. ISO 9283 path characteristics not measured: {}\n", e.what()));
  }
}

void DemoRun::Summarise() {
  seconds_ = std::chrono::duration<double>(std::chrono::steady_clock::now() - started_).count();
  Say(DemoProgressionText(runs_, noise_floor_mm_, robot_->paper));
  Say(fmt::format("\nDone in {:.1f} s. The database stays for inspection: {} ({})\n", seconds_,
                  Printable(database_->path()), workflows::Hint(database_->path(), {"db", "info"})));
}

// The --json document: the session's figures and the three stages as `calibrate` writes
// them.
void DemoRun::WriteJson() {
  nlohmann::json& out = result_.json;
  out["session"] = {{"id", session_},
                    {"robot", robot_->name},
                    {"instrument", use_tracker_ ? "tracker" : "theodolites"},
                    {"poses", static_cast<int>(poses_.size())},
                    {"observations", reduced_.observations},
                    {"stations", stations_},
                    {"noise_floor_mm", noise_floor_mm_},
                    {"seconds", seconds_}};
  if (on_the_move_ && captured_.sweep) {
    const acquisition::SweepSummary& w = *captured_.sweep;
    out["robot_time_s"] = capture_robot_time_s_ > 0.0 ? capture_robot_time_s_ : w.robot_time_s;
    if (w.clock) {
      out["sync"] = {{"offset_ms", w.clock->offset_ms},
                     {"drift_ppm", w.clock->drift_ppm},
                     {"sigma_ms", w.clock->sigma_ms}};
    }
    if (!iso9283_paths_.is_null()) out["iso9283_path"] = iso9283_paths_;
    out["session"]["on_the_move"] = {{"waypoints", static_cast<int>(plan_.size())},
                                     {"segments", w.segments},
                                     {"joint_packages", w.joint_packages},
                                     {"tracker_points", w.tracker_records},
                                     {"paired", w.paired},
                                     {"left_accelerating", w.left_accelerating},
                                     {"left_gaps", w.left_gaps},
                                     {"left_outside", w.left_outside},
                                     {"left_uncertain", w.left_uncertain},
                                     {"speed_rad_s", w.speed_rad_s},
                                     {"mean_sync_sigma_mm", w.mean_sync_sigma_mm},
                                     {"planted_offset_ms", planted_offset_ms_},
                                     {"planted_drift_ppm", planted_drift_ppm_}};
  }
  if (auto* ur = lab_->ur()) {
    out["session"]["controller"] = {{"description", captured_.controller},
                                    {"rtde_hz", ur->frequency_hz()},
                                    {"arm_moving_s", ur->arm().moving_s()}};
  }
  if (use_tracker_) {
    out["session"]["beam"] = {{"predicted", captured_.beam_predicted},
                              {"searches", captured_.beam_searches},
                              {"operator", captured_.beam_operator},
                              {"base", captured_.beam_base}};
    out["session"]["software_ms_per_configuration"] = captured_.mean_overhead_ms;
    out["session"]["store_ms_per_configuration"] = captured_.mean_store_ms;
  }
  out["stages"] = stages_;
  result_.seconds = seconds_;
  if (options_.json_path.empty()) return;
  try {
    io::WriteFileAtomically(options_.json_path, JsonText(result_.json, 2) + "\n");
  } catch (const OutputError& e) {
    // Everything the JSON summarises is stored by now: said, with its own exit code.
    throw StoredButOutputError(fmt::format(
        "the demo is done and stored (session {} and its parameter sets in {}); its JSON "
        "summary could not be written: {}",
        session_, Printable(database_->path()), e.what()));
  }
}

}  // namespace

DemoResult RunDemo(const DemoOptions& options, const DemoObserver& observer) {
  return DemoRun(options, observer).Run();
}

}  // namespace armsig::demo
