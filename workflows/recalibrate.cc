#include "workflows/recalibrate.h"

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <cmath>
#include <set>

#include "acquisition/lab.h"
#include "calibration/compensation.h"
#include "core/error.h"
#include "db/database.h"
#include "db/store.h"
#include "io/file_lock.h"
#include "io/model_yaml.h"
#include "workflows/calibration_run.h"
#include "workflows/report.h"
#include "workflows/signature.h"

namespace armsig::workflows {

namespace {

struct Gates {
  double max_mean_mm = 0.5, max_max_mm = 2.0, tolerance_mm = 0.02, drift_sigma = 5.0;
};

// Gates from the latest session's lab file (`recalibration:` block), then the options.
Gates LoadGates(db::Database& database, int64_t robot_id, const RecalibrateOptions& o) {
  Gates g;
  // A malformed block is an input error (never a silent fall-back to the defaults).
  const std::string lab = db::LatestLabYaml(database, robot_id);
  if (!lab.empty()) {
    const auto settings =
        acquisition::ParseLabSettings(lab, "lab file stored with robot " + o.robot + "'s sessions");
    if (const auto& r = settings.recalibration) {
      g.max_mean_mm = r->max_validation_mean_mm.value_or(g.max_mean_mm);
      g.max_max_mm = r->max_validation_max_mm.value_or(g.max_max_mm);
      g.tolerance_mm = r->tolerance_mm.value_or(g.tolerance_mm);
      g.drift_sigma = r->drift_sigma.value_or(g.drift_sigma);
    }
  }
  g.max_mean_mm = o.max_validation_mean_mm.value_or(g.max_mean_mm);
  g.max_max_mm = o.max_validation_max_mm.value_or(g.max_max_mm);
  g.tolerance_mm = o.tolerance_mm.value_or(g.tolerance_mm);
  g.drift_sigma = o.drift_sigma.value_or(g.drift_sigma);
  return g;
}

nlohmann::json Stats(const calibration::ErrorStats& s) {
  return {{"poses", s.poses}, {"mean_mm", s.mean_mm}, {"max_mm", s.max_mm}, {"rms_mm", s.rms_mm}};
}

}  // namespace

std::string RecalibrationDecision::Describe() const {
  switch (outcome) {
    case Outcome::kUpToDate:
      return fmt::format("up to date: version {} already uses these {} poses; nothing to do",
                         version, poses);
    case Outcome::kStored:
      return fmt::format("stored as version {} (active)", version);
    case Outcome::kRejected:
      return previous_version
                 ? fmt::format("rejected: a gate failed; version {} stays active",
                               *previous_version)
                 : std::string("rejected: a gate failed; no parameter set is active");
  }
  return "";
}

nlohmann::json RecalibrationDecision::ToJson() const {
  nlohmann::json j;
  j["robot"] = robot;
  j["poses"] = poses;
  if (outcome == Outcome::kUpToDate) {
    j["decision"] = "up_to_date";
    j["version"] = version;
    return j;
  }
  j["decision"] = outcome == Outcome::kStored ? "stored" : "rejected";
  j["version"] = version > 0 ? nlohmann::json(version) : nlohmann::json(nullptr);
  if (previous_version) j["previous_version"] = *previous_version;
  j["rank"] = rank;
  j["fit"] = Stats(fit);
  j["nominal"] = Stats(nominal);
  j["validation"] = Stats(validation);
  if (previous_on_same_data) j["current_on_same_data"] = Stats(*previous_on_same_data);
  j["gates"] = nlohmann::json::array();
  for (const auto& g : gates) {
    j["gates"].push_back(
        {{"name", g.name}, {"value_mm", g.value_mm}, {"limit_mm", g.limit_mm}, {"passed", g.passed}});
  }
  if (previous_version) {
    nlohmann::json moved = nlohmann::json::array();
    for (const auto& d : drifted)
      moved.push_back({{"name", d.name}, {"change", d.change}, {"sigmas", d.sigmas}});
    j["drift"] = {{"flag", drift}, {"max_abs_sigmas", max_abs_sigmas}, {"parameters", moved}};
  }
  if (!report_path.empty()) j["report"] = report_path;
  return j;
}

RecalibrationDecision Recalibrate(const RecalibrateOptions& o) {
  db::Database database(o.db_path);
  const auto robot_id = db::FindRobot(database, o.robot);
  if (!robot_id)
    throw InputError({o.db_path, 0, 0, "--robot"}, "no robot '" + o.robot + "' in the database");
  io::FileLock lock(o.db_path + ".recalibrate.lock", o.lock_wait_s);
  auto log = [&](const std::string& message) { spdlog::info("recalibrate: {}: {}", o.robot, message); };

  const auto model =
      io::ParseRobotModel(db::RobotModelYaml(database, *robot_id), "model of robot " + o.robot);
  const Gates gates = LoadGates(database, *robot_id, o);
  int64_t newest_row = 0;
  const auto poses = db::LoadRobotPoses(database, *robot_id, o.since, &newest_row);
  const auto current = db::ActiveCalibration(database, *robot_id);

  RecalibrationDecision d;
  d.robot = o.robot;
  d.poses = static_cast<int>(poses.size());
  if (current) d.previous_version = current->version;
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
      d.outcome = RecalibrationDecision::Outcome::kUpToDate;
      d.version = current->version;
      log(d.Describe());
      return d;
    }
  }
  if (poses.size() < 20) {
    throw InputError(
        {o.db_path, 0, 0, "--robot"},
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
  log(fmt::format("{} configurations: fitting {} ({}), validating on the rest", poses.size(),
                  settings.select, o.params));
  const CalibrationRun run = RunCalibration(model, poses, {}, settings);
  std::vector<MeasuredPose> fit, validation;
  {
    const std::set<std::string> fit_ids(run.fit_pose_ids.begin(), run.fit_pose_ids.end());
    for (const auto& p : poses) (fit_ids.count(p.id) ? fit : validation).push_back(p);
  }
  d.validation = StatsOf(run.validation_residuals);
  d.fit = run.estimate.fit;
  d.nominal = run.estimate.nominal;
  d.rank = run.estimate.identifiability.rank;

  bool pass = run.estimate.status == calibration::EstimationStatus::kConverged;
  auto gate = [&](const std::string& name, double value, double limit) {
    const bool ok = value <= limit;
    d.gates.push_back({name, value, limit, ok});
    log(fmt::format("{}: {:.4f} mm (limit {:.4f} mm) {}", name, value, limit,
                    ok ? "passed" : "FAILED"));
    pass = pass && ok;
  };
  gate("validation mean", d.validation.mean_mm, gates.max_mean_mm);
  gate("validation max", d.validation.max_mm, gates.max_max_mm);
  std::vector<calibration::ParameterChange> changes;
  if (current) {
    // The current set on the same validation data, its base re-aligned on the fit poses
    // (the measuring frame moves between set-ups; the arm signature does not).
    const Signature old = SignatureOf(model, *current);
    if (const auto base = calibration::AlignBaseWithParams(model, old.params, fit)) {
      d.previous_on_same_data = StatsOf(calibration::Residuals(model, *base, old.params, validation));
      gate(fmt::format("not worse than version {} on the same data (+{:.3f} mm)", current->version,
                       gates.tolerance_mm),
           d.validation.mean_mm, d.previous_on_same_data->mean_mm + gates.tolerance_mm);
      // Drift: the robot moved away from its current signature.
      if (std::isfinite(current->validation_mean_mm) &&
          d.previous_on_same_data->mean_mm >
              2.0 * current->validation_mean_mm + gates.tolerance_mm) {
        d.drift = true;
        log(fmt::format(
            "drift: version {} now misses by {:.3f} mm on average (it validated at {:.3f} mm)",
            current->version, d.previous_on_same_data->mean_mm, current->validation_mean_mm));
      }
    }
    changes = calibration::CompareParameters(old.params, old.sigmas, run.estimate.params,
                                             run.estimate.sigmas);
    const auto names = model.ParameterNames();
    for (const auto& c : changes) {
      if (!std::isfinite(old.sigmas(c.parameter)) ||
          !std::isfinite(run.estimate.sigmas(c.parameter)))
        continue;
      d.max_abs_sigmas = std::max(d.max_abs_sigmas, std::abs(c.z));
      if (std::abs(c.z) > gates.drift_sigma) {
        d.drift = true;
        d.drifted.push_back({names[c.parameter], c.change, c.z});
        log(fmt::format("drift: {} changed by {:.1f} sigma", names[c.parameter], c.z));
      }
    }
  }

  if (pass) {
    const nlohmann::json options = {{"select", settings.select},
                                    {"params", o.params},
                                    {"gates",
                                     {{"max_mean_mm", gates.max_mean_mm},
                                      {"max_max_mm", gates.max_max_mm},
                                      {"tolerance_mm", gates.tolerance_mm},
                                      {"drift_sigma", gates.drift_sigma}}}};
    SQLite::Transaction tx(database.sql());
    d.version = db::InsertCalibration(
                    database, CalibrationRecordOf(model, run, *robot_id, inputs, options, true))
                    .second;
    tx.commit();
    d.outcome = RecalibrationDecision::Outcome::kStored;
  } else {
    d.outcome = RecalibrationDecision::Outcome::kRejected;
  }
  log(d.Describe());

  if (!o.report_dir.empty()) {
    ReportInput input;
    input.robot = o.robot;
    input.version = d.version;
    input.decision = d.Describe();
    for (const auto& g : d.gates) {
      input.gates.push_back(fmt::format("{}: {:.4f} mm (limit {:.4f} mm) {}", g.name, g.value_mm,
                                        g.limit_mm, g.passed ? "passed" : "FAILED"));
    }
    input.model = &model;
    input.run = &run;
    input.validation = validation;
    for (const auto& h : db::CalibrationHistory(database, *robot_id)) {
      input.history.push_back({h.version, h.created_at, h.validation_mean_mm});
    }
    if (d.version == 0) input.history.push_back({0, "this run (rejected)", d.validation.mean_mm});
    input.changes = changes;
    input.drift = d.drift;
    d.report_path = WriteReport(o.report_dir, input);
    log("report: " + d.report_path);
  }
  return d;
}

}  // namespace armsig::workflows
