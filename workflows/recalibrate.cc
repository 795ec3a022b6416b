#include "workflows/recalibrate.h"

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <regex>
#include <set>

#include "acquisition/lab.h"
#include "calibration/compensation.h"
#include "calibration/drift.h"
#include "calibration/identifiability.h"
#include "core/error.h"
#include "core/text.h"
#include "db/database.h"
#include "db/store.h"
#include "io/atomic_file.h"
#include "io/file_lock.h"
#include "io/model_yaml.h"
#include "workflows/calibration_run.h"
#include "workflows/report.h"
#include "workflows/signature.h"

namespace armsig::workflows {

namespace {

struct Gates {
  double max_mean_mm = 0.5, max_max_mm = 2.0, tolerance_mm = 0.02, drift_sigma = 5.0,
         drift_mm = 0.05;
};

constexpr int kDriftConfigurations = 50;     // spread over the work volume, the same every night
constexpr double kDriftSignificance = 1e-3;  // p-value below which two sets differ

// `--since` as the database compares it (the sessions' started_at is
// YYYY-MM-DDTHH:MM:SS.sssZ): an ISO date, or date and time (T or one space between).
std::string CheckedSince(const std::string& text) {
  static const std::regex iso(
      R"(^(\d{4})-(\d{2})-(\d{2})(?:[T ](\d{2}):(\d{2})(?::(\d{2})(?:\.\d+)?)?Z?)?$)");
  std::smatch m;
  auto number = [&](int group) { return m[group].matched ? std::stoi(m[group].str()) : 0; };
  if (!std::regex_match(text, m, iso) || number(2) < 1 || number(2) > 12 || number(3) < 1 ||
      number(3) > 31 || number(4) > 23 || number(5) > 59 || number(6) > 60) {
    throw InputError({"--since", 0, 0, ""},
                     Quoted(text) +
                         ": expected an ISO date or date/time, e.g. 2026-11-01 or "
                         "2026-11-01T02:30:00Z");
  }
  std::string normalised = text;
  if (normalised.size() > 10) normalised[10] = 'T';
  if (!normalised.empty() && normalised.back() == 'Z') normalised.pop_back();
  return normalised;
}

// What the measurements are, not how they were asked for: every pose's id, joints and
// target, in order, with the options that shape the fit. Equal digests = same inputs.
std::string InputDigest(const std::vector<MeasuredPose>& poses, const std::string& params,
                        int select) {
  std::string text = params + "|" + std::to_string(select);
  for (const auto& p : poses) {
    text += fmt::format("|{}", p.id);
    for (int i = 0; i < p.joints_rad.size(); ++i) text += fmt::format(",{:.17g}", p.joints_rad(i));
    for (int i = 0; i < 3; ++i) text += fmt::format(",{:.17g}", p.target_in_world(i));
  }
  return fmt::format("{:016x}", std::hash<std::string>{}(text));
}

// A stored set as CompareModels wants it: its identified parameters and their covariance.
calibration::FittedSet FittedSetOf(const calibration::RobotModel& model, const Signature& sig,
                                   const db::StoredCalibration& stored) {
  calibration::FittedSet set;
  set.params = sig.params;
  for (const auto& name : stored.covariance_parameters)
    set.identified.push_back(model.IndexOf(name));
  set.covariance = stored.covariance;
  return set;
}

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
      g.drift_mm = r->drift_mm.value_or(g.drift_mm);
    }
  }
  g.drift_mm = o.drift_mm.value_or(g.drift_mm);
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
      return previous_version ? fmt::format("rejected: a gate failed; version {} stays active",
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
    j["gates"].push_back({{"name", g.name},
                          {"value_mm", g.value_mm},
                          {"limit_mm", g.limit_mm},
                          {"passed", g.passed}});
  }
  if (previous_version) {
    nlohmann::json moved = nlohmann::json::array();
    for (const auto& p : drifted)
      moved.push_back({{"name", p.name}, {"change", p.change}, {"sigmas", p.sigmas}});
    j["drift"] = {{"flag", drift}, {"max_abs_sigmas", max_abs_sigmas}, {"parameters", moved}};
    if (model_drift) {
      const auto& m = *model_drift;
      j["drift"]["positions"] = {{"configurations", m.configurations},
                                 {"max_mm", m.max_mm},
                                 {"mean_mm", m.mean_mm},
                                 {"rms_mm", m.rms_mm},
                                 {"chi2", m.chi2},
                                 {"dof", m.dof},
                                 {"p_value", m.p_value},
                                 {"significant", m.significant},
                                 {"tolerance_mm", m.tolerance_mm},
                                 {"previous_covariance_stored", m.previous_covariance},
                                 {"same_subset", m.same_subset}};
    }
  }
  if (!report_path.empty()) j["report"] = report_path;
  return j;
}

RecalibrationDecision Recalibrate(const RecalibrateOptions& o) {
  // Everything the run will write is checked before anything is stored.
  const std::string since = o.since.empty() ? std::string() : CheckedSince(o.since);
  if (!o.json_path.empty()) io::CheckOutputFile(o.json_path, "--json");
  if (!o.report_dir.empty()) io::CheckOutputDirectory(o.report_dir, "--report");
  db::Database database(o.db_path, db::OpenMode::kMustExist);
  const auto robot_id = db::FindRobot(database, o.robot);
  if (!robot_id)
    throw InputError({o.db_path, 0, 0, "--robot"},
                     "no robot " + Quoted(o.robot) + " in the database");
  io::FileLock lock(o.db_path + ".recalibrate.lock", o.lock_wait_s);
  auto log = [&](const std::string& message) {
    spdlog::info("recalibrate: {}: {}", o.robot, message);
  };

  const auto model =
      io::ParseRobotModel(db::RobotModelYaml(database, *robot_id), "model of robot " + o.robot);
  const Gates gates = LoadGates(database, *robot_id, o);
  const auto poses = db::LoadRobotPoses(database, *robot_id, since);
  const auto current = db::ActiveCalibration(database, *robot_id);

  RecalibrationDecision d;
  d.robot = o.robot;
  d.poses = static_cast<int>(poses.size());
  if (current) d.previous_version = current->version;
  // Idempotence on content: the active set was already fitted on exactly these
  // measurements with these options, however they were asked for.
  const std::string digest = InputDigest(poses, o.params, o.select);
  std::set<std::string> sessions;
  for (const auto& p : poses) sessions.insert(p.id.substr(0, p.id.find(':')));
  const nlohmann::json inputs = {{"digest", digest},     {"poses", poses.size()},
                                 {"sessions", sessions}, {"since", since},
                                 {"params", o.params},   {"select", o.select}};
  if (current && !o.force) {
    const auto stored = nlohmann::json::parse(
        current->inputs_json.empty() ? "{}" : current->inputs_json, nullptr, false);
    if (stored.is_object() && stored.value("digest", std::string()) == digest) {
      d.outcome = RecalibrationDecision::Outcome::kUpToDate;
      d.version = current->version;
      log(d.Describe());
      return d;
    }
  }
  if (poses.size() < 20) {
    throw InputError({o.db_path, 0, 0, "--robot"},
                     fmt::format("robot {} has {} measured configurations{}; a recalibration "
                                 "needs at least 20 (some to fit, the rest to validate)",
                                 o.robot, poses.size(), since.empty() ? "" : " since " + since));
  }
  CalibrateSettings settings;
  settings.params = o.params;
  settings.model_subset = true;
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

  bool pass = run.estimate.status.ok();
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
      d.previous_on_same_data =
          StatsOf(calibration::Residuals(model, *base, old.params, validation));
      gate(fmt::format("not worse than version {} on the same data (+{:.3f} mm)", current->version,
                       gates.tolerance_mm),
           d.validation.mean_mm, d.previous_on_same_data->mean_mm + gates.tolerance_mm);
    }
    // Drift: do the two models put the arm in different places, beyond what both fits'
    // uncertainty explains and by more than the tolerance?
    const calibration::FittedSet now{run.estimate.params, run.estimate.identifiability.identified,
                                     run.estimate.covariance};
    calibration::FittedSet before = FittedSetOf(model, old, *current);
    ModelDrift m;
    m.previous_covariance = !before.identified.empty();
    if (!m.previous_covariance) {
      // Stored before covariances were: take this fit's (same lab, same procedure).
      before.identified = now.identified;
      before.covariance = now.covariance;
    }
    const auto c = calibration::CompareModels(
        model, before, now, calibration::SpreadConfigurations(model, kDriftConfigurations));
    m.configurations = c.configurations;
    m.max_mm = c.max_mm;
    m.mean_mm = c.mean_mm;
    m.rms_mm = c.rms_mm;
    m.chi2 = c.chi2;
    m.dof = c.dof;
    m.p_value = c.p_value;
    m.same_subset = c.shared_shape_space;
    m.significant = c.p_value < kDriftSignificance;
    m.tolerance_mm = gates.drift_mm;
    d.drift = m.significant && m.max_mm > m.tolerance_mm;
    d.model_drift = m;
    log(fmt::format(
        "{}: against version {} the predicted positions differ by up to {:.3f} mm (mean {:.3f} "
        "mm) over {} configurations spread over the work volume; chi2 {:.1f} on {} dof (p = "
        "{:.2g}), tolerance {:.3f} mm{}",
        d.drift ? "DRIFT" : "no drift", current->version, m.max_mm, m.mean_mm, m.configurations,
        m.chi2, m.dof, m.p_value, m.tolerance_mm,
        m.same_subset ? ""
                      : fmt::format("; the two sets estimate different parameters: chi2 only "
                                    "on the shape changes both can make (version {}: {})",
                                    current->version, current->params_spec)));
    // Per parameter: on the parameters both sets identified, in one gauge (the rigid
    // part the two base alignments put into the parameters taken out).
    const auto names = model.ParameterNames();
    for (const auto& p : c.parameters) {
      changes.push_back({p.parameter, p.change, p.z});
      d.max_abs_sigmas = std::max(d.max_abs_sigmas, std::abs(p.z));
      if (d.drift && std::abs(p.z) > gates.drift_sigma) {
        d.drifted.push_back({names[p.parameter], p.change, p.z});
        const bool angle = model.UnitOf(p.parameter) == calibration::ParameterUnit::kRad;
        log(fmt::format("drift: {} changed by {:+.4f} {} ({:.1f} sigma)", names[p.parameter],
                        angle ? p.change * 1e3 : p.change, angle ? "mrad" : "mm", p.z));
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
                                      {"drift_sigma", gates.drift_sigma},
                                      {"drift_mm", gates.drift_mm}}}};
    db::WriteTransaction tx(database);
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
    input.armsig_version = ARMSIG_VERSION;
    input.sources = LoadReportSources(database, run);
    for (const auto& h : db::CalibrationHistory(database, *robot_id)) {
      input.history.push_back(
          {h.version, h.created_at, h.validation_mean_mm, h.params_spec, h.active});
    }
    if (d.version == 0) {
      input.history.push_back(
          {0, "this run (rejected)", d.validation.mean_mm, run.params_spec, false});
    }
    if (current) {
      input.previous_version = current->version;
      input.previous_params_spec = current->params_spec;
    }
    input.changes = changes;
    input.drift = d.drift;
    if (d.model_drift) {
      const auto& m = *d.model_drift;
      input.changes_note = fmt::format(
          "{}: against version {}, the positions the two models predict over {} configurations "
          "spread over the work volume differ by up to {:.3f} mm (mean {:.3f} mm) after aligning "
          "bases; chi2 {:.1f} on {} degrees of freedom (p = {:.2g}); drift needs p < 0.001 and "
          "more than {:.3f} mm. Parameter changes are shown in one gauge (the rigid part of the "
          "two base alignments removed).",
          d.drift ? "DRIFT" : "No drift", *d.previous_version, m.configurations, m.max_mm,
          m.mean_mm, m.chi2, m.dof, m.p_value, m.tolerance_mm);
    }
    d.report_path = WriteReport(o.report_dir, input);
    log("report: " + d.report_path);
  }
  return d;
}

}  // namespace armsig::workflows
