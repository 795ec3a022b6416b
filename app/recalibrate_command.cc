// armsig recalibrate --robot NAME [--since …] [--select N] [--params …|auto] [--report DIR] [--json
// OUT] The nightly job: fit the robot's stored measurements, validate on configurations not used in
// the fit, and store a new active parameter set only if it passes its gates.
#include <fcntl.h>
#include <fmt/format.h>
#include <sys/file.h>
#include <unistd.h>
#include <yaml-cpp/yaml.h>

#include <chrono>
#include <cmath>
#include <iostream>
#include <nlohmann/json.hpp>
#include <thread>

#include "app/calibration_report.h"
#include "app/command.h"
#include "app/report.h"
#include "app/signature.h"
#include "calibration/compensation.h"
#include "core/error.h"
#include "db/database.h"
#include "db/store.h"
#include "io/atomic_file.h"
#include "io/model_yaml.h"

namespace armsig::app {

struct RecalibrateOptions {
  std::string robot, since, params = "all", report, json;
  int select = 0;
  double max_mean_mm = NAN, max_max_mm = NAN, tolerance_mm = NAN, drift_sigma = NAN;
  int lock_wait_s = 600;
  bool force = false;
};

namespace {

// An exclusive lock beside the database file: one recalibration at a time. The OS
// releases it when the process ends, however it ends.
class FileLock {
 public:
  FileLock(const std::string& path, int wait_s) {
    fd_ = ::open(path.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644);
    if (fd_ < 0) throw std::runtime_error(path + ": cannot create the lock file");
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(wait_s);
    while (::flock(fd_, LOCK_EX | LOCK_NB) != 0) {
      if (std::chrono::steady_clock::now() >= deadline) {
        ::close(fd_);
        throw std::runtime_error("another recalibration holds " + path + "; gave up after " +
                                 std::to_string(wait_s) + " s");
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
    }
  }
  ~FileLock() {
    ::flock(fd_, LOCK_UN);
    ::close(fd_);
  }

 private:
  int fd_ = -1;
};

void Log(const std::string& robot, const std::string& message) {
  std::cerr << "armsig recalibrate: " << robot << ": " << message << "\n";
}

// Gates from the latest session's lab file (`recalibration:` block), then the options.
struct Gates {
  double max_mean_mm = 0.5, max_max_mm = 2.0, tolerance_mm = 0.02, drift_sigma = 5.0;
};

Gates LoadGates(db::Database& database, int64_t robot_id, const RecalibrateOptions& o) {
  Gates g;
  SQLite::Statement q(
      database.sql(),
      "SELECT coalesce(lab_yaml, '') FROM sessions WHERE robot_id = ? ORDER BY id DESC LIMIT 1");
  q.bind(1, robot_id);
  if (q.executeStep() && !q.getColumn(0).getString().empty()) {
    try {
      const YAML::Node r = YAML::Load(q.getColumn(0).getString())["recalibration"];
      if (r) {
        if (r["max_validation_mean_mm"]) g.max_mean_mm = r["max_validation_mean_mm"].as<double>();
        if (r["max_validation_max_mm"]) g.max_max_mm = r["max_validation_max_mm"].as<double>();
        if (r["tolerance_mm"]) g.tolerance_mm = r["tolerance_mm"].as<double>();
        if (r["drift_sigma"]) g.drift_sigma = r["drift_sigma"].as<double>();
      }
    } catch (const YAML::Exception& e) {
      Log("lab", std::string("ignoring the stored lab file's recalibration block: ") + e.what());
    }
  }
  if (std::isfinite(o.max_mean_mm)) g.max_mean_mm = o.max_mean_mm;
  if (std::isfinite(o.max_max_mm)) g.max_max_mm = o.max_max_mm;
  if (std::isfinite(o.tolerance_mm)) g.tolerance_mm = o.tolerance_mm;
  if (std::isfinite(o.drift_sigma)) g.drift_sigma = o.drift_sigma;
  return g;
}

nlohmann::json Stats(const calibration::ErrorStats& s) {
  return {{"poses", s.poses}, {"mean_mm", s.mean_mm}, {"max_mm", s.max_mm}, {"rms_mm", s.rms_mm}};
}

}  // namespace

int RunRecalibrate(const RecalibrateOptions& o, const GlobalOptions& global) {
  const std::string db_path = global.DbPath();
  db::Database database(db_path);
  const auto robot_id = db::FindRobot(database, o.robot);
  if (!robot_id)
    throw InputError({db_path, 0, 0, "--robot"}, "no robot '" + o.robot + "' in the database");
  FileLock lock(db_path + ".recalibrate.lock", o.lock_wait_s);

  const auto model =
      io::ParseRobotModel(db::RobotModelYaml(database, *robot_id), "model of robot " + o.robot);
  const Gates gates = LoadGates(database, *robot_id, o);
  int64_t newest_row = 0;
  const auto poses = db::LoadRobotPoses(database, *robot_id, o.since, &newest_row);
  const auto current = db::ActiveCalibration(database, *robot_id);

  nlohmann::json summary;
  summary["robot"] = o.robot;
  summary["poses"] = poses.size();
  summary["gates"] = nlohmann::json::array();
  // Idempotence: the active set was already fitted on exactly these inputs.
  const nlohmann::json inputs = {{"max_pose_row", newest_row},
                                 {"poses", poses.size()},
                                 {"since", o.since},
                                 {"params", o.params},
                                 {"select", o.select}};
  if (current && !o.force) {
    const auto stored =
        nlohmann::json::parse(current->inputs_json.empty() ? "{}" : current->inputs_json);
    if (stored.value("max_pose_row", -1) == newest_row &&
        stored.value("poses", -1) == static_cast<int>(poses.size()) &&
        stored.value("params", std::string()) == o.params &&
        stored.value("since", std::string()) == o.since) {
      Log(o.robot, fmt::format("up to date: version {} already uses these {} poses; nothing to do",
                               current->version, poses.size()));
      summary["decision"] = "up_to_date";
      summary["version"] = current->version;
      if (!o.json.empty()) io::WriteFileAtomically(o.json, summary.dump(2) + "\n");
      return kOk;
    }
  }
  if (poses.size() < 20) {
    throw InputError(
        {db_path, 0, 0, "--robot"},
        fmt::format("robot {} has {} measured configurations{}; a recalibration "
                    "needs at least 20 (some to fit, the rest to validate)",
                    o.robot, poses.size(), o.since.empty() ? "" : " since " + o.since));
  }
  CalibrateSettings settings;
  settings.params = o.params;
  settings.select =
      o.select > 0
          ? o.select
          : static_cast<int>(std::min<size_t>(80, std::max<size_t>(poses.size() * 6 / 10, 10)));
  Log(o.robot, fmt::format("{} configurations: fitting {} ({}), validating on the rest",
                           poses.size(), settings.select, o.params));
  const CalibrationRun run = RunCalibration(model, poses, {}, settings);
  std::vector<MeasuredPose> validation;
  {
    std::set<std::string> fit_ids(run.fit_pose_ids.begin(), run.fit_pose_ids.end());
    for (const auto& p : poses) {
      if (!fit_ids.count(p.id)) validation.push_back(p);
    }
  }
  const auto new_validation =
      calibration::Summarise(calibration::Distances(run.validation_residuals));
  summary["fit"] = Stats(run.estimate.fit);
  summary["nominal"] = Stats(run.estimate.nominal);
  summary["validation"] = Stats(new_validation);
  summary["rank"] = run.estimate.identifiability.rank;

  // The current set on the same validation data, its base re-aligned on the fit poses
  // (the measuring frame moves between set-ups; the arm signature does not).
  std::vector<std::string> gate_lines;
  bool pass = run.estimate.status == calibration::EstimationStatus::kConverged;
  auto gate = [&](const std::string& name, double value, double limit, bool ok) {
    gate_lines.push_back(fmt::format("{}: {:.4f} mm (limit {:.4f} mm) {}", name, value, limit,
                                     ok ? "passed" : "FAILED"));
    summary["gates"].push_back(
        {{"name", name}, {"value_mm", value}, {"limit_mm", limit}, {"passed", ok}});
    Log(o.robot, gate_lines.back());
    pass = pass && ok;
  };
  gate("validation mean", new_validation.mean_mm, gates.max_mean_mm,
       new_validation.mean_mm <= gates.max_mean_mm);
  gate("validation max", new_validation.max_mm, gates.max_max_mm,
       new_validation.max_mm <= gates.max_max_mm);
  std::vector<calibration::ParameterChange> changes;
  bool drift = false;
  double max_z = 0.0;
  if (current) {
    const Signature old = SignatureOf(model, *current);
    std::vector<MeasuredPose> fit;
    for (const auto& p : poses) {
      if (std::find(run.fit_pose_ids.begin(), run.fit_pose_ids.end(), p.id) !=
          run.fit_pose_ids.end())
        fit.push_back(p);
    }
    const auto base = calibration::AlignBaseWithParams(model, old.params, fit);
    if (base) {
      const auto old_on_new = calibration::Summarise(
          calibration::Distances(calibration::Residuals(model, *base, old.params, validation)));
      summary["current_on_same_data"] = Stats(old_on_new);
      summary["previous_version"] = current->version;
      gate(fmt::format("not worse than version {} on the same data (+{:.3f} mm)", current->version,
                       gates.tolerance_mm),
           new_validation.mean_mm, old_on_new.mean_mm + gates.tolerance_mm,
           new_validation.mean_mm <= old_on_new.mean_mm + gates.tolerance_mm);
      // Drift: the robot moved away from its current signature.
      if (std::isfinite(current->validation_mean_mm) &&
          old_on_new.mean_mm > 2.0 * current->validation_mean_mm + gates.tolerance_mm) {
        drift = true;
        Log(o.robot,
            fmt::format(
                "drift: version {} now misses by {:.3f} mm on average (it validated at {:.3f} mm)",
                current->version, old_on_new.mean_mm, current->validation_mean_mm));
      }
    }
    changes = calibration::CompareParameters(old.params, old.sigmas, run.estimate.params,
                                             run.estimate.sigmas);
    const auto names = model.ParameterNames();
    nlohmann::json moved = nlohmann::json::array();
    for (const auto& c : changes) {
      if (!std::isfinite(old.sigmas(c.parameter)) ||
          !std::isfinite(run.estimate.sigmas(c.parameter)))
        continue;
      max_z = std::max(max_z, std::abs(c.z));
      if (std::abs(c.z) > gates.drift_sigma) {
        drift = true;
        moved.push_back({{"name", names[c.parameter]}, {"change", c.change}, {"sigmas", c.z}});
        Log(o.robot, fmt::format("drift: {} changed by {:.1f} sigma", names[c.parameter], c.z));
      }
    }
    summary["drift"] = {{"flag", drift}, {"max_abs_sigmas", max_z}, {"parameters", moved}};
  }

  int version = 0;
  std::string decision;
  if (pass) {
    const nlohmann::json options = {{"select", settings.select},
                                    {"params", o.params},
                                    {"gates",
                                     {{"max_mean_mm", gates.max_mean_mm},
                                      {"max_max_mm", gates.max_max_mm},
                                      {"tolerance_mm", gates.tolerance_mm},
                                      {"drift_sigma", gates.drift_sigma}}}};
    const db::CalibrationRecord record =
        CalibrationRecordOf(model, run, *robot_id, inputs, options, true);
    SQLite::Transaction tx(database.sql());
    version = db::InsertCalibration(database, record).second;
    tx.commit();
    decision = fmt::format("stored as version {} (active)", version);
  } else {
    decision =
        current ? fmt::format("rejected: a gate failed; version {} stays active", current->version)
                : "rejected: a gate failed; no parameter set is active";
  }
  Log(o.robot, decision);
  summary["decision"] = pass ? "stored" : "rejected";
  summary["version"] = version > 0 ? nlohmann::json(version) : nlohmann::json(nullptr);

  if (!o.report.empty()) {
    ReportInput input;
    input.robot = o.robot;
    input.version = version;
    input.decision = decision;
    input.gates = gate_lines;
    input.model = &model;
    input.run = &run;
    input.validation = validation;
    for (const auto& h : db::CalibrationHistory(database, *robot_id)) {
      input.history.push_back({h.version, h.created_at, h.validation_mean_mm});
    }
    if (version == 0) input.history.push_back({0, "this run (rejected)", new_validation.mean_mm});
    input.changes = changes;
    input.drift = drift;
    summary["report"] = WriteReport(o.report, input);
    Log(o.robot, "report: " + summary["report"].get<std::string>());
  }
  if (!o.json.empty()) io::WriteFileAtomically(o.json, summary.dump(2) + "\n");
  std::cout << fmt::format(
      "{}: {} (validation mean {:.4f} mm, max {:.4f} mm on {} configurations{})\n", o.robot,
      decision, new_validation.mean_mm, new_validation.max_mm, new_validation.poses,
      drift ? "; DRIFT" : "");
  return pass ? kOk : kQualityGate;
}

void SetupRecalibrateCommand(CLI::App& parent, const GlobalOptions& global, Runner& run) {
  auto o = std::make_shared<RecalibrateOptions>();
  auto* sub = parent.add_subcommand("recalibrate", "The nightly recalibration job");
  sub->add_option("--robot", o->robot, "Robot name")->required();
  sub->add_option("--since", o->since, "Only sessions started at or after this ISO date/time");
  sub->add_option("--select", o->select, "Configurations to fit (default: 60 %, at most 80)");
  sub->add_option("--params", o->params, "geometric | all | auto | list")->capture_default_str();
  sub->add_option("--max-validation-mean-mm", o->max_mean_mm, "Gate (default: lab file, else 0.5)");
  sub->add_option("--max-validation-max-mm", o->max_max_mm, "Gate (default: lab file, else 2.0)");
  sub->add_option("--tolerance-mm", o->tolerance_mm,
                  "Allowed worsening against the active set (default 0.02)");
  sub->add_option("--drift-sigma", o->drift_sigma, "Parameter change flagged as drift (default 5)");
  sub->add_option("--report", o->report, "Write an HTML report into this directory");
  sub->add_option("--json", o->json, "Write a JSON summary for monitoring");
  sub->add_option("--lock-wait", o->lock_wait_s,
                  "Seconds to wait for another running recalibration")
      ->capture_default_str();
  sub->add_flag("--force", o->force,
                "Refit even if the active set already uses these measurements");
  sub->callback([&run, &global, o] { run = [&global, o] { return RunRecalibrate(*o, global); }; });
}

}  // namespace armsig::app
