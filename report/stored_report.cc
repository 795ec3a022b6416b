#include "report/stored_report.h"

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <charconv>
#include <cmath>
#include <filesystem>
#include <map>
#include <nlohmann/json.hpp>
#include <set>

#include "calibration/drift.h"
#include "calibration/estimation.h"
#include "calibration/identifiability.h"
#include "calibration/residual_map.h"
#include "core/error.h"
#include "core/text.h"
#include "db/calibrations.h"
#include "db/report_queries.h"
#include "db/robots.h"
#include "db/sessions.h"
#include "db/store.h"
#include "db/stored_json.h"
#include "io/atomic_file.h"
#include "io/model_yaml.h"
#include "io/residual_map_json.h"
#include "workflows/calibration_run.h"
#include "workflows/hint.h"
#include "report/report.h"
#include "workflows/signature.h"

namespace armsig::report {

namespace {


calibration::ErrorStats StatsOfDistances(const std::vector<double>& distances) {
  return calibration::Summarise(distances);
}

// The residual map as the run held it: its decision and cross-validation from the stored
// calibrate JSON, the map itself from the stored map.
// Stored JSON is input (db/stored_json.h): a value of another type is refused naming its cell.
std::optional<calibration::ResidualMapFit> StoredMapFit(const db::StoredCalibration& set,
                                                        const std::string& source) {
  return db::ReadStoredJson(
      set.report_json, {source, "calibrations", set.id, "report_json"},
      [&](const nlohmann::json& report) -> std::optional<calibration::ResidualMapFit> {
        if (!report.is_object() || !report.contains("residual_model") ||
            !report["residual_model"].is_object())
          return std::nullopt;
        const auto& j = report["residual_model"];
        calibration::ResidualMapFit fit;
        fit.used = j.value("used", false);
        fit.decision = j.value("decision", std::string());
        auto number = [&](const char* key) {
          return j.contains(key) && j[key].is_number() ? j[key].get<double>() : NAN;
        };
        fit.cv_mean_mm_parametric = number("cv_mean_mm_parametric");
        fit.cv_mean_mm_with_map = number("cv_mean_mm_with_map");
        if (j.contains("grid") && j["grid"].is_array()) {
          for (const auto& g : j["grid"]) {
            if (!g.is_object()) continue;
            fit.grid.push_back({g.value("length_scale", 0.0), g.value("regularisation", 0.0),
                                g.value("cv_mean_mm", 0.0)});
          }
        }
        if (!set.residual_map_json.empty()) {
          fit.map = io::ResidualMapFromJson(
              db::ParseStoredJson(set.residual_map_json,
                                  {source, "calibrations", set.id, "residual_map_json"}),
              source);
        }
        return fit;
      });
}

// The gates as the run judged them, from the options it stored and the set's figures.
std::vector<std::string> StoredGates(const db::StoredCalibration& set) {
  std::vector<std::string> out;
  const auto options = db::ParseStoredJson(
      set.options_json, {"the database", "calibrations", set.id, "options_json"});
  if (!options.is_object() || !options.contains("gates") || !options["gates"].is_object())
    return out;
  const auto& g = options["gates"];
  auto line = [&](const char* name, double value, const char* key) {
    if (!g.contains(key) || !g[key].is_number() || !std::isfinite(value)) return;
    const double limit = g[key].get<double>();
    out.push_back(fmt::format("{}: {:.4f} mm (limit {:.4f} mm) {}", name, value, limit,
                              value <= limit ? "passed" : "FAILED"));
  };
  line("validation mean", set.validation_mean_mm, "max_mean_mm");
  line("validation max", set.validation_max_mm, "max_max_mm");
  return out;
}

// The drift gate (mm) the run stored with its options; the nightly job's default when the
// set stored none (a demo's, an import's).
double StoredDriftTolerance(const db::StoredCalibration& set) {
  const auto options = db::ParseStoredJson(
      set.options_json, {"the database", "calibrations", set.id, "options_json"});
  if (options.is_object() && options.contains("gates") && options["gates"].is_object() &&
      options["gates"].contains("drift_mm") && options["gates"]["drift_mm"].is_number())
    return options["gates"]["drift_mm"].get<double>();
  return calibration::kDefaultDriftMm;
}

}  // namespace

bool HasReportOf(const std::string& dir, const std::string& robot, int version) {
  std::error_code error;
  const std::string index = dir + "/index.html";
  if (!std::filesystem::is_regular_file(index, error)) return false;
  try {
    return io::ReadWholeFile(index, {std::size_t{64} << 20, "a report"})
               .find(ReportSetMarker(robot, version)) != std::string::npos;
  } catch (const std::exception&) {
    return false;
  }
}

namespace {

// The run as its stored residuals tell it: the configurations behind them (as the run
// named them, "<session>:<label>"), their residuals and distances; `missing_poses` counts
// validation configurations no longer stored.
struct StoredRun {
  workflows::CalibrationRun run;
  std::vector<MeasuredPose> fit, validation;
  std::vector<double> fit_distances, fit_nominal, validation_nominal;
  int missing_poses = 0;
  std::set<int64_t> missing_sessions;  // the sessions their labels name
};

StoredRun StoredRunOf(db::Database& database, int64_t robot_id, const db::StoredCalibration& set,
                      const std::vector<db::StoredResidual>& rows) {
  StoredRun out;
  out.run.params_spec = set.params_spec;
  // The configurations behind the residuals, as the run named them ("<session>:<label>").
  std::map<std::string, MeasuredPose> by_id;
  for (auto& p : db::LoadRobotPoses(database, robot_id, "")) by_id.emplace(p.id, std::move(p));
  // A run on one session's poses (the demo's) named them by their bare label: found in the
  // sessions the set's inputs name.
  std::vector<std::string> input_sessions;
  {
    const auto inputs = db::ParseStoredJson(
        set.inputs_json, {"the database", "calibrations", set.id, "inputs_json"});
    if (inputs.is_object() && inputs.contains("sessions") && inputs["sessions"].is_array()) {
      for (const auto& s : inputs["sessions"]) {
        if (s.is_string()) input_sessions.push_back(s.get<std::string>());
        if (s.is_number_integer()) input_sessions.push_back(std::to_string(s.get<int64_t>()));
      }
    }
  }
  auto find_pose = [&](const std::string& label) {
    auto it = by_id.find(label);
    if (it != by_id.end() || label.find(':') != std::string::npos) return it;
    for (const auto& session : input_sessions) {
      it = by_id.find(session + ":" + label);
      if (it != by_id.end()) return it;
    }
    return by_id.end();
  };
  for (const auto& r : rows) {
    const auto pose = find_pose(r.pose_label);
    if (r.role == "fit") {
      out.run.fit_pose_ids.push_back(pose != by_id.end() ? pose->first : r.pose_label);
      out.fit_distances.push_back(r.distance_mm);
      if (std::isfinite(r.nominal_distance_mm)) out.fit_nominal.push_back(r.nominal_distance_mm);
      if (pose != by_id.end()) out.fit.push_back(pose->second);
      continue;
    }
    if (pose == by_id.end()) {
      ++out.missing_poses;
      // Its session: named by the label ("<session>:<label>"), else the run's input sessions
      // (a run on one session's poses named them by their bare labels).
      const size_t colon = r.pose_label.find(':');
      std::vector<std::string> sessions = input_sessions;
      if (colon != std::string::npos) sessions = {r.pose_label.substr(0, colon)};
      for (const auto& session : sessions) {
        int64_t id = 0;
        const auto [end, error] = std::from_chars(session.data(), session.data() + session.size(), id);
        if (error == std::errc() && end == session.data() + session.size()) out.missing_sessions.insert(id);
      }
      continue;
    }
    // "<session>:<label>", as the sources read them.
    out.run.validation_pose_ids.push_back(pose->first);
    out.run.validation_residuals.emplace_back(r.dx_mm, r.dy_mm, r.dz_mm);
    out.validation_nominal.push_back(r.nominal_distance_mm);
    out.validation.push_back(pose->second);
  }
  if (out.missing_poses > 0) {
    // Discarded sessions keep their rows (kept out of every fit, not deleted): say which.
    std::vector<std::string> discarded;
    const std::vector<int64_t> ids(out.missing_sessions.begin(), out.missing_sessions.end());
    for (const auto& s : db::LoadReportSessions(database, ids)) {
      if (s.state == db::SessionState::kAborted) discarded.push_back(std::to_string(s.id));
    }
    std::string where = "no longer in the store";
    if (!discarded.empty()) {
      where = fmt::format("in session{} {} (discarded since: stored, kept out of use)",
                          discarded.size() == 1 ? "" : "s", fmt::join(discarded, ", "));
      if (discarded.size() < out.missing_sessions.size()) where += " or no longer in the store";
    }
    spdlog::warn("report: {} validation configuration{} of version {} {} {}: left out of this page",
                 out.missing_poses, out.missing_poses == 1 ? "" : "s", set.version,
                 out.missing_poses == 1 ? "is" : "are", where);
  }

  return out;
}

// The estimate as stored: parameters, sigmas, what was identified, the fit's figures.
void RestoreEstimate(const calibration::RobotModel& model, const workflows::Signature& sig,
                     const db::StoredCalibration& set, StoredRun& out) {
  calibration::EstimationResult& estimate = out.run.estimate;
  estimate.params = sig.params;
  estimate.sigmas = sig.sigmas;
  estimate.fit = StatsOfDistances(out.fit_distances);
  estimate.nominal = StatsOfDistances(out.fit_nominal);
  auto& id = estimate.identifiability;
  try {
    id.candidates = calibration::ParseParameterSpec(model, set.params_spec);
  } catch (const std::invalid_argument&) {
    for (int k = 0; k < model.num_parameters(); ++k) id.candidates.push_back(k);
  }
  for (int k = 0; k < model.num_parameters(); ++k) {
    const bool identified =
        k < static_cast<int>(set.parameters.size()) && set.parameters[k].identified;
    if (identified) id.identified.push_back(k);
  }
  for (int k : id.candidates) {
    if (std::find(id.identified.begin(), id.identified.end(), k) == id.identified.end())
      id.unidentified.push_back(k);
  }
  id.rank = set.rank;
}

// The frames placed with the stored parameters, the condition number, the nominal model's
// validation errors and the residual map's, as the run had them.
void RestoreValidation(const calibration::RobotModel& model, const workflows::Signature& sig,
                       const db::StoredCalibration& set, const std::string& robot, StoredRun& out) {
  auto& id = out.run.estimate.identifiability;
  // Each frame placed on its fitted configurations with the stored parameters (the fit
  // estimated them with the parameters; they are not stored).
  calibration::FrameBases bases = calibration::AlignFrameBases(model, sig.params, out.fit);
  {
    std::vector<MeasuredPose> unplaced;
    for (const auto& p : out.validation) {
      if (!bases.count(p.frame)) unplaced.push_back(p);
    }
    for (const auto& [frame, base] : calibration::AlignFrameBases(model, sig.params, unplaced))
      bases[frame] = base;
  }
  if (!out.fit.empty() && !id.identified.empty()) {
    std::vector<Eigen::VectorXd> joints;
    for (const auto& p : out.fit) joints.push_back(p.joints_rad);
    const auto first = bases.count(out.fit.front().frame) ? bases.at(out.fit.front().frame)
                                                          : Eigen::Isometry3d::Identity();
    const auto analysis = calibration::AnalyseJacobian(
        calibration::StackedJacobian(model, first, sig.params, joints), id.identified);
    id.condition_number = analysis.condition_number;
  }
  // The nominal model's validation errors: their stored distances, in the directions the
  // nominal model errs with the frames placed as above.
  {
    std::vector<MeasuredPose> placed;
    for (const auto& p : out.validation) {
      if (bases.count(p.frame)) placed.push_back(p);
    }
    const auto nominal =
        placed.size() == out.validation.size()
            ? calibration::Residuals(model, bases, Eigen::VectorXd::Zero(model.num_parameters()),
                                     out.validation)
            : std::vector<Eigen::Vector3d>(out.validation.size(), Eigen::Vector3d::UnitX());
    for (size_t i = 0; i < out.validation.size(); ++i) {
      const double norm = nominal[i].norm();
      const Eigen::Vector3d direction = norm > 0 ? Eigen::Vector3d(nominal[i] / norm)
                                                 : Eigen::Vector3d::UnitX();
      out.run.validation_nominal_residuals.push_back(
          direction *
          (std::isfinite(out.validation_nominal[i]) ? out.validation_nominal[i] : norm));
    }
  }
  out.run.residual_map = StoredMapFit(set, fmt::format("robot {} version {}", robot, set.version));
  if (!sig.validity.empty()) out.run.validity = sig.validity;
  if (out.run.map_used() && sig.map &&
      out.validation.size() == out.run.validation_residuals.size()) {
    bool placed = true;
    for (const auto& p : out.validation) placed = placed && bases.count(p.frame);
    if (placed) {
      out.run.validation_parametric_residuals =
          calibration::Residuals(model, bases, sig.params, out.validation);
      workflows::MappedResiduals(model, bases, sig.params, sig.map.get(), out.validation,
                      &out.run.validation_map_extrapolated);
      for (const auto& p : out.validation) {
        const double latent = sig.map->CorrectionSigmaMm(p.joints_rad.data());
        const double noise = out.run.residual_map->map.noise_sigma_mm;
        out.run.validation_map_sigma_mm.push_back(std::sqrt(latent * latent + noise * noise));
      }
    }
  }
}

// The change against the set active before this one was stored, and the drift decision as
// stored (its causes, drift line and window).
void AddStoredDecision(const calibration::RobotModel& model, const workflows::Signature& sig,
                       const db::StoredCalibration& set,
                       const std::vector<db::StoredCalibration>& history, ReportInput& input) {
  // The change against the set active before this one was stored.
  const auto drift =
      nlohmann::json::parse(set.drift_json.empty() ? "null" : set.drift_json, nullptr, false);
  std::optional<int> previous;
  if (drift.is_object() && drift.contains("against") && drift["against"].is_number_integer())
    previous = drift["against"].get<int>();
  for (const auto& c : history) {
    if (!previous || c.version != *previous) continue;
    input.previous_version = c.version;
    input.previous_params_spec = c.params_spec;
    const workflows::Signature before = workflows::SignatureOf(model, c);
    const auto comparison = calibration::CompareModels(
        model, FittedSetOf(model, before, c), FittedSetOf(model, sig, set),
        calibration::SpreadConfigurations(model, kReportDriftConfigurations));
    for (const auto& p : comparison.parameters)
      input.changes.push_back({p.parameter, p.change, p.z});
  }
  if (drift.is_object()) {
    input.drift = drift.value("flag", false);
    if (drift.contains("causes") && drift["causes"].is_array()) {
      for (const auto& c : drift["causes"]) {
        if (c.is_object() && c.contains("text") && c["text"].is_string())
          input.causes.push_back(c["text"].get<std::string>());
      }
    }
    if (drift.contains("change") && drift["change"].is_object()) {
      const auto& change = drift["change"];
      if (change.contains("causes") && change["causes"].is_array()) {
        input.causes.clear();
        for (const auto& c : change["causes"]) {
          if (c.is_object() && c.contains("text") && c["text"].is_string())
            input.causes.push_back(c["text"].get<std::string>());
        }
      }
    }
    if (drift.contains("drift_line") && drift["drift_line"].is_string())
      input.drift_line = drift["drift_line"].get<std::string>();
    if (drift.contains("tested") && drift["tested"].is_array()) {
      for (const auto& t : drift["tested"]) {
        if (!t.is_object()) continue;
        ReportInput::WindowTest w;
        w.session = t.value("session", int64_t{0});
        w.started_at = t.value("started_at", std::string());
        w.poses = t.value("poses", 0);
        w.mean_mm = t.value("mean_mm", 0.0);
        w.effect_max_mm = t.value("effect_max_mm", 0.0);
        w.p_value = t.value("p_value", 1.0);
        w.disagrees = t.value("disagrees", false);
        w.outlier = t.value("outlier", false);
        input.window.push_back(w);
      }
    }
  }
}

}  // namespace

StoredReport WriteStoredReport(db::Database& database, const std::string& robot,
                               std::optional<int> version, const std::string& dir) {
  io::CheckOutputDirectory(dir, "--out");
  db::ReadSnapshot snapshot(database);  // every read of the report agrees with the others
  const auto robot_id = db::FindRobot(database, robot);
  if (!robot_id) {
    throw InputError({database.path(), 0, 0, "--robot"}, workflows::UnknownRobotMessage(database, robot));
  }
  const workflows::ActiveSignature loaded = workflows::LoadSignature(database, robot, version);
  const calibration::RobotModel& model = loaded.model;
  const workflows::Signature& sig = loaded.signature;
  const auto history = db::CalibrationHistory(database, *robot_id);
  const db::StoredCalibration* set = nullptr;
  for (const auto& c : history) {
    if (c.version == sig.version) set = &c;
  }
  if (!set) throw std::logic_error("WriteStoredReport: the loaded set is not in the history");
  const auto rows = db::LoadStoredResiduals(database, set->id);
  if (rows.empty()) {
    throw InputError({"--set", 0, 0, ""},
                     fmt::format("version {} of robot {} has no recorded residuals: no report "
                                 "can be made of it",
                                 set->version, workflows::ShellWord(robot)));
  }

  StoredRun stored = StoredRunOf(database, *robot_id, *set, rows);
  StoredReport out;
  out.version = set->version;
  out.missing_poses = stored.missing_poses;
  RestoreEstimate(model, sig, *set, stored);
  RestoreValidation(model, sig, *set, robot, stored);
  const workflows::CalibrationRun& run = stored.run;

  ReportInput input;
  input.robot = robot;
  input.version = set->version;
  input.armsig_version = ARMSIG_VERSION;
  std::string made_active;
  for (const auto& a : db::ActivationHistory(database, *robot_id)) {
    if (a.version == set->version)
      made_active = fmt::format(" (made active by {} at {})", a.activated_by, a.activated_at);
  }
  input.decision = fmt::format("version {} as stored on {}{}{}", set->version, set->created_at,
                               made_active, set->active ? "; active now" : "; not active now");
  input.gates = StoredGates(*set);
  input.model = &model;
  input.run = &run;
  input.validation = stored.validation;
  input.sources = LoadReportSources(database, run);
  {
    std::vector<int64_t> sessions;
    for (const auto& s : input.sources.sessions) sessions.push_back(s.id);
    input.temperature_c = db::PoseTemperatures(database, sessions);
  }
  input.history = ReportHistoryOf(database, *robot_id);
  input.drift_history = ReportDriftOf(database, model, *robot_id, StoredDriftTolerance(*set));
  AddStoredDecision(model, sig, *set, history, input);
  out.path = WriteReport(dir, input);
  return out;
}

}  // namespace armsig::report
