#include "workflows/calibration_run.h"

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <cmath>
#include <iterator>
#include <map>
#include <numbers>
#include <numeric>
#include <optional>
#include <stdexcept>

#include "calibration/drift.h"
#include "calibration/orientation.h"
#include "core/error.h"
#include "core/text.h"
#include "io/residual_map_json.h"
#include "io/validity_json.h"

namespace armsig::workflows {

calibration::ErrorStats StatsOf(const std::vector<Eigen::Vector3d>& residuals) {
  return calibration::Summarise(calibration::Distances(residuals));
}

std::vector<Eigen::Vector3d> MappedResiduals(const calibration::RobotModel& model,
                                             const calibration::FrameBases& bases,
                                             const Eigen::VectorXd& params,
                                             const calibration::ResidualMap* map,
                                             const std::vector<MeasuredPose>& poses,
                                             std::vector<char>* outside) {
  if (outside) outside->assign(poses.size(), 0);
  if (!map) return calibration::Residuals(model, bases, params, poses);
  // The parametric model at the angles the map's joint curves correct, then its kernel.
  std::vector<MeasuredPose> corrected = poses;
  std::vector<char> curves_inside(poses.size(), 1);
  for (size_t i = 0; i < poses.size(); ++i) {
    curves_inside[i] = map->CorrectJoints(poses[i].joints_rad.data(), corrected[i].joints_rad.data());
  }
  std::vector<Eigen::Vector3d> r = calibration::Residuals(model, bases, params, corrected);
  for (size_t i = 0; i < poses.size(); ++i) {
    const auto prediction = map->Predict(poses[i].joints_rad.data());
    if (prediction.supported) {
      r[i] += bases.at(poses[i].frame).linear() * prediction.correction_in_base_mm;
    }
    if (outside && !(prediction.supported && curves_inside[i])) (*outside)[i] = 1;
  }
  return r;
}

CalibrationRun::MapValidation CalibrationRun::map_validation() const {
  MapValidation v;
  v.poses = static_cast<int>(validation_map_sigma_mm.size());
  if (v.poses == 0) return v;
  double sum = 0.0;
  for (int i = 0; i < v.poses; ++i) {
    v.outside += validation_map_extrapolated[i];
    sum += validation_map_sigma_mm[i];
  }
  v.mean_sigma_mm = sum / v.poses;
  return v;
}

std::vector<int> ParamsOf(const calibration::RobotModel& model, const std::string& spec) {
  try {
    return calibration::ParseParameterSpec(model, spec == "auto" ? "all" : spec);
  } catch (const std::invalid_argument& e) {
    throw InputError({"--params", 0, 0, ""}, e.what());
  }
}

namespace {

// The estimation options the settings ask for. With settings.model_subset the candidates
// are narrowed to what the model identifies from configurations spread over its joint
// limits, and `model_report` says which and why.
calibration::EstimationOptions EstimationOptionsOf(
    const calibration::RobotModel& model, const CalibrateSettings& settings,
    std::optional<calibration::IdentifiabilityReport>& model_report) {
  calibration::EstimationOptions options;
  options.robust_threshold_mm = settings.robust_threshold_mm;
  options.max_iterations = settings.max_iterations;
  options.identifiability.relative_tolerance = settings.rank_tolerance;
  options.parameters = ParamsOf(model, settings.params);
  if (settings.orientation != "auto" && settings.orientation != "off") {
    throw InputError({"--orientation", 0, 0, ""},
                     "expected auto or off, got '" + settings.orientation + "'");
  }
  options.use_orientation = settings.orientation == "auto";
  options.orientation_weight_mm_per_rad = settings.orientation_weight_mm_per_rad;
  if (settings.tool_rotation != "per-session" && settings.tool_rotation != "shared") {
    throw InputError({"--tool-rotation", 0, 0, ""},
                     "expected per-session or shared, got '" + settings.tool_rotation + "'");
  }
  options.shared_tool_rotation = settings.tool_rotation == "shared";
  options.stop = settings.stop;
  if (settings.model_subset) {
    model_report =
        calibration::ModelIdentifiability(model, options.parameters, settings.rank_tolerance);
    options.parameters = model_report->identified;
  }
  return options;
}

// Stage 1, --select N: the D-optimal N of the poses are fitted (`fit`), the others
// validate (`rest`). The selection looks at the parameters the whole candidate set can
// identify, and every measurement frame must keep three fitted poses for its base.
void SelectFitPoses(const calibration::RobotModel& model, const std::vector<MeasuredPose>& poses,
                    const calibration::EstimationOptions& options, int select, CalibrationRun& run,
                    std::vector<MeasuredPose>& fit, std::vector<MeasuredPose>& rest) {
  if (select >= static_cast<int>(poses.size())) {
    throw InputError({"--select", 0, 0, ""},
                     "cannot keep " + std::to_string(select) + " of " +
                         std::to_string(poses.size()) +
                         " poses and still validate on the rest (expected N < " +
                         std::to_string(poses.size()) + ")");
  }
  const std::vector<int64_t> frames = calibration::FramesOf(poses);
  std::vector<Eigen::VectorXd> joints;
  for (const auto& p : poses) joints.push_back(p.joints_rad);
  const auto report = calibration::AnalyseJacobian(
      calibration::StackedJacobian(model, Eigen::Isometry3d::Identity(),
                                   Eigen::VectorXd::Zero(model.num_parameters()), joints),
      options.parameters, options.identifiability);
  calibration::SelectionOptions selection_options;
  selection_options.count = select;
  selection_options.stop = options.stop;
  std::vector<int64_t> candidate_frames;
  if (frames.size() > 1) {
    for (const auto& p : poses) candidate_frames.push_back(p.frame);
  }
  run.selection = calibration::SelectConfigurations(model, joints, report.identified,
                                                    selection_options, candidate_frames);
  run.selection_candidates = static_cast<int>(poses.size());
  fit.clear();
  std::vector<char> chosen(poses.size(), 0);
  for (int i : run.selection->selected) chosen[i] = 1;
  for (size_t i = 0; i < poses.size(); ++i) (chosen[i] ? fit : rest).push_back(poses[i]);
  spdlog::debug(
      "calibration: selected {} of {} configurations (D-optimal on {} parameters{}), log det "
      "{:.2f}, condition number {:.3g}, {} exchanges",
      fit.size(), poses.size(), report.identified.size(),
      frames.size() > 1 ? fmt::format(" and the bases of {} further frames", frames.size() - 1)
                        : std::string(),
      run.selection->log_det, run.selection->condition_number, run.selection->exchanges);
  if (spdlog::should_log(spdlog::level::trace)) {
    for (const auto& p : fit) spdlog::trace("calibration: fit pose {} (frame {})", p.id, p.frame);
  }
  if (frames.size() > 1) {
    std::map<int64_t, int> fitted;
    for (const auto& p : fit) fitted[p.frame]++;
    for (int64_t f : frames) {
      if (fitted[f] < 3) {
        throw InputError(
            {"--select", 0, 0, ""},
            fmt::format("{} configurations are too few to fit {} measurement frames: frame "
                        "{} keeps {} of them, and every frame needs at least 3 (its base has "
                        "six unknowns); give a larger --select",
                        select, frames.size(), f, fitted[f]));
      }
    }
  }
}

// Stage 3: the fit itself. Data the fit cannot use are input errors; a fit that produced
// no numbers fails (exit 1, no table, JSON or stored set of numbers that are not results).
void EstimateSignature(const calibration::RobotModel& model, const std::vector<MeasuredPose>& fit,
                       const calibration::EstimationOptions& options,
                       const std::optional<calibration::IdentifiabilityReport>& model_report,
                       bool auto_params, CalibrationRun& run) {
  run.estimate = calibration::Estimate(model, fit, options);
  if (run.estimate.status.code == SolveCode::kTooFewObservations ||
      run.estimate.status.code == SolveCode::kDegenerate) {
    throw InputError({"--poses", 0, 0, ""}, run.estimate.status.message);
  }
  if (run.estimate.status.code == SolveCode::kNonFinite) {
    throw std::runtime_error("calibration failed: " + run.estimate.status.message);
  }
  if (model_report && !auto_params) {
    // The fit was asked for the model's subset only; what the user asked for is the spec,
    // and the parameters left out are the model's, with how each depends on the others.
    auto& id = run.estimate.identifiability;
    id.candidates = model_report->candidates;
    std::vector<int> asked = id.candidates, chosen = id.identified;
    std::sort(asked.begin(), asked.end());
    std::sort(chosen.begin(), chosen.end());
    id.unidentified.clear();
    std::set_difference(asked.begin(), asked.end(), chosen.begin(), chosen.end(),
                        std::back_inserter(id.unidentified));
    id.dependencies.insert(id.dependencies.end(), model_report->dependencies.begin(),
                           model_report->dependencies.end());
  }
  for (const auto& p : fit) run.fit_pose_ids.push_back(p.id);
}

// Validation, every pose in its own frame. A frame none of whose poses was fitted has no
// base from the fit: it is aligned on its validation poses with the fitted parameters;
// poses of a frame too small for that are left out (said). Returns every frame's base and
// records the frames and the validation poses in `run`.
calibration::FrameBases PlaceValidationPoses(const calibration::RobotModel& model,
                                             const std::vector<MeasuredPose>& fit,
                                             std::vector<MeasuredPose>& validation,
                                             CalibrationRun& run) {
  calibration::FrameBases bases = run.estimate.bases;
  std::map<int64_t, RunFrame> frame_info;
  for (const auto& [frame, base] : bases) frame_info[frame] = {frame, base, 0, 0, false};
  for (const auto& p : fit) frame_info[p.frame].fit_poses++;
  std::vector<MeasuredPose> unplaced;
  for (const auto& p : validation) {
    if (!bases.count(p.frame)) unplaced.push_back(p);
  }
  for (const auto& [frame, base] :
       calibration::AlignFrameBases(model, run.estimate.params, unplaced)) {
    bases[frame] = base;
    frame_info[frame] = {frame, base, 0, 0, true};
    spdlog::warn(
        "calibration: measurement frame {} has no fitted pose; its base is aligned on its "
        "validation poses with the fitted parameters",
        frame);
  }
  std::vector<MeasuredPose> placed;
  for (auto& p : validation) {
    if (bases.count(p.frame)) {
      placed.push_back(std::move(p));
    } else {
      spdlog::warn(
          "calibration: pose {} left out of the validation: its measurement frame {} "
          "has too few poses to be placed",
          p.id, p.frame);
    }
  }
  validation = std::move(placed);
  for (const auto& p : validation) {
    run.validation_pose_ids.push_back(p.id);
    frame_info[p.frame].validation_poses++;
  }
  for (const auto& [frame, info] : frame_info) run.frames.push_back(info);
  return bases;
}

// The validation poses' orientation errors, when the fit had orientation equations: each
// frame's tool rotation from the fit, or, for a frame none of whose poses was fitted, the
// shared one (--tool-rotation shared: the probe stayed on) or else one aligned on its
// validation poses' orientations with the fitted parameters (as its base).
void ValidateOrientations(const calibration::RobotModel& model,
                          const calibration::FrameBases& bases,
                          const std::vector<MeasuredPose>& validation, CalibrationRun& run) {
  run.tool_rotations = run.estimate.tool_rotations;
  if (run.tool_rotations.empty()) return;
  std::map<int64_t, std::vector<MeasuredPose>> unplaced;
  for (const auto& p : validation) {
    if (p.orientation && !run.tool_rotations.count(p.frame)) unplaced[p.frame].push_back(p);
  }
  for (const auto& [frame, poses] : unplaced) {
    if (run.estimate.tool_rotation_shared) {
      run.tool_rotations[frame] = run.estimate.tool_rotations.begin()->second;
      continue;
    }
    const auto base_of = [&](int64_t f) -> const Eigen::Isometry3d& { return bases.at(f); };
    if (const auto tool =
            calibration::AlignToolRotation(model, base_of, run.estimate.params, poses)) {
      run.tool_rotations[frame] = *tool;
    }
  }
  run.validation_orientation_residuals = calibration::OrientationResiduals(
      model, bases, run.tool_rotations, run.estimate.params, validation);
}

// --residual-model auto: the residual map, fitted and cross-validated on the fit poses
// only; when it is used, the validation residuals get its correction and every validation
// pose its predictive σ.
void FitResidualMapAndValidate(const calibration::RobotModel& model,
                               const std::vector<MeasuredPose>& fit,
                               const std::vector<MeasuredPose>& validation,
                               const calibration::FrameBases& bases, const core::StopToken& stop,
                               CalibrationRun& run) {
  calibration::ResidualMapOptions options;
  options.stop = stop;
  run.residual_map = calibration::FitResidualMap(model, run.estimate, fit, options);
  const auto& m = *run.residual_map;
  // Said once, by the caller: in calibrate's and the demo's table (FormatCalibrationReport),
  // in the nightly job's log.
  spdlog::debug("calibration: residual map {}: {}", m.used ? "used" : "not used", m.decision);
  if (!m.used || validation.empty()) return;
  const calibration::ResidualMap map(m.map);
  run.validation_parametric_residuals = run.validation_residuals;
  run.validation_residuals = MappedResiduals(model, bases, run.estimate.params, &map, validation,
                                             &run.validation_map_extrapolated);
  for (const auto& p : validation) {
    const double latent = map.CorrectionSigmaMm(p.joints_rad.data());
    run.validation_map_sigma_mm.push_back(
        std::sqrt(latent * latent + m.map.noise_sigma_mm * m.map.noise_sigma_mm));
  }
}

// With several measurement frames, each frame's poses and base in the debug log.
void LogFrames(const CalibrationRun& run) {
  if (run.frames.size() <= 1 || !spdlog::should_log(spdlog::level::debug)) return;
  for (const auto& f : run.frames) {
    const Eigen::Vector3d t = f.world_from_base.translation();
    spdlog::debug(
        "calibration: frame {}{}: {} fitted, {} validated; base at ({:.3f}, {:.3f}, {:.3f}) "
        "mm, rotated {:.4f} deg from the reference frame's",
        f.frame, f.frame == run.estimate.reference_frame ? " (reference)" : "", f.fit_poses,
        f.validation_poses, t.x(), t.y(), t.z(),
        Eigen::AngleAxisd(run.estimate.world_from_base.linear().transpose() *
                          f.world_from_base.linear())
                .angle() *
            180.0 / std::numbers::pi);
  }
}

}  // namespace

CalibrationRun RunCalibration(const calibration::RobotModel& model,
                              const std::vector<MeasuredPose>& poses,
                              const std::vector<MeasuredPose>& holdout,
                              const CalibrateSettings& settings) {
  CalibrationRun run;
  run.params_spec = settings.params;
  const bool auto_params = settings.params == "auto";
  std::optional<calibration::IdentifiabilityReport> model_report;
  calibration::EstimationOptions options = EstimationOptionsOf(model, settings, model_report);

  // 1. Which poses are fitted: all, or the D-optimal --select N.
  std::vector<MeasuredPose> fit = poses, rest;
  if (settings.select > 0) SelectFitPoses(model, poses, options, settings.select, run, fit, rest);
  // 2. Which parameters: --params auto adds the terms that pass an F-test and
  // cross-validation to the geometric model.
  if (auto_params) {
    run.auto_terms = calibration::SelectTermsByFTest(model, fit, options, settings.alpha);
    options.parameters = run.auto_terms->parameters;
    run.params_spec = "auto";
  }
  // 3. The fit.
  EstimateSignature(model, fit, options, model_report, auto_params, run);

  // Validation on the held-out poses (or those --select left), each in its own frame.
  std::vector<MeasuredPose> validation = holdout.empty() ? rest : holdout;
  const calibration::FrameBases bases = PlaceValidationPoses(model, fit, validation, run);
  if (!validation.empty()) {
    run.validation_residuals =
        calibration::Residuals(model, bases, run.estimate.params, validation);
    run.validation_nominal_residuals = calibration::Residuals(
        model, bases, Eigen::VectorXd::Zero(model.num_parameters()), validation);
    ValidateOrientations(model, bases, validation, run);
  }
  if (settings.residual_model == "auto" && run.estimate.status.ok()) {
    FitResidualMapAndValidate(model, fit, validation, bases, settings.stop, run);
  } else if (settings.residual_model != "auto" && settings.residual_model != "off") {
    throw InputError({"--residual-model", 0, 0, ""},
                     "expected auto or off, got '" + settings.residual_model + "'");
  }
  // Where the set holds and how well it predicts beside its fit poses.
  if (run.estimate.usable()) {
    run.validity = calibration::EstimateValidity(
        model, run.estimate, fit, run.residual_map ? &*run.residual_map : nullptr);
  }
  LogFrames(run);
  return run;
}

namespace {

// A rigid transform as its four matrix rows.
nlohmann::json RowsJson(const Eigen::Isometry3d& t) {
  nlohmann::json rows = nlohmann::json::array();
  for (int r = 0; r < 4; ++r)
    rows.push_back({t.matrix()(r, 0), t.matrix()(r, 1), t.matrix()(r, 2), t.matrix()(r, 3)});
  return rows;
}

// The tool mounting: known (the target's place is the lab's; the flange's turn across the
// lever is fitted, its turn about the lever is not identifiable, gamma{n} held) or fitted.
nlohmann::json ToolMountingJson(const calibration::RobotModel& model,
                                const std::vector<std::string>& names) {
  nlohmann::json mounting{{"tool_mounting", calibration::ToString(model.tool_mounting)}};
  nlohmann::json held = nlohmann::json::array();
  for (int k : model.HeldParameters()) held.push_back(names[k]);
  mounting["held"] = held;
  if (model.known_mounting()) {
    mounting["not_identifiable"] =
        "the flange's turn about the lever arm (held with " + names[model.tool_index() - 1] + ")";
  }
  return mounting;
}

}  // namespace

nlohmann::json CalibrationJson(const calibration::RobotModel& model, const CalibrationRun& run) {
  using nlohmann::json;
  const auto& est = run.estimate;
  const auto names = model.ParameterNames();
  std::vector<char> identified(model.num_parameters(), 0);
  for (int i : est.identifiability.identified) identified[i] = 1;
  auto stats = [](const calibration::ErrorStats& s) {
    return json{
        {"poses", s.poses}, {"mean_mm", s.mean_mm}, {"max_mm", s.max_mm}, {"rms_mm", s.rms_mm}};
  };
  json out;
  out["model"] = model.name;
  out["params"] = run.params_spec;
  json params = json::array();
  for (int k = 0; k < model.num_parameters(); ++k) {
    const bool unit_mm = model.UnitOf(k) == calibration::ParameterUnit::kMm;
    params.push_back({{"name", names[k]},
                      {"value", est.params(k)},
                      {"unit", unit_mm ? "mm" : "rad"},
                      {"identified", static_cast<bool>(identified[k])},
                      {"sigma", identified[k] ? json(est.sigmas(k)) : json(nullptr)}});
  }
  out["parameters"] = params;
  out["rank"] = est.identifiability.rank;
  out["structural_rank"] = est.identifiability.structural_rank;
  out["tool"] = ToolMountingJson(model, names);
  out["tool_mounting"] = calibration::ToString(model.tool_mounting);
  out["poses_used"] = static_cast<int>(run.fit_pose_ids.size());
  out["nominal"] = stats(est.nominal);
  json fit = stats(est.fit);
  fit["converged"] = est.status.ok();
  fit["iterations"] = est.iterations;
  fit["sigma0_mm"] = est.sigma0_mm;
  fit["redundancy"] = est.redundancy;
  fit["condition_number"] = est.identifiability.condition_number;
  auto angles = [](const calibration::AngleStats& a) {
    return json{
        {"poses", a.poses}, {"mean_rad", a.mean_rad}, {"max_rad", a.max_rad}, {"rms_rad", a.rms_rad}};
  };
  if (est.orientation_poses > 0) {
    json orientation = angles(est.fit_angle);
    orientation["sigma0_rad"] = est.sigma0_rad;
    orientation["weight_mm_per_rad"] = est.orientation_weight_mm_per_rad;
    orientation["nominal"] = angles(est.nominal_angle);
    fit["orientation"] = orientation;
  }
  out["fit"] = fit;
  json validation = stats(StatsOf(run.validation_residuals));
  validation["nominal"] = stats(StatsOf(run.validation_nominal_residuals));
  if (!run.tool_rotations.empty() && !run.validation_orientation_residuals.empty()) {
    validation["orientation"] = angles(
        calibration::SummariseAngles(calibration::Angles(run.validation_orientation_residuals)));
  }
  validation["pose_ids"] = run.validation_pose_ids;
  validation["map_applied"] = run.map_used();
  if (run.map_used() && !run.validation_parametric_residuals.empty()) {
    validation["parametric"] = stats(StatsOf(run.validation_parametric_residuals));
    validation["map_sigma_mm"] = run.validation_map_sigma_mm;
    json outside = json::array();
    for (size_t i = 0; i < run.validation_map_extrapolated.size(); ++i) {
      if (run.validation_map_extrapolated[i]) outside.push_back(run.validation_pose_ids[i]);
    }
    validation["map_extrapolated"] = outside;
  }
  out["validation"] = validation;
  out["residual_model"] = run.residual_map ? io::ResidualModelJson(*run.residual_map)
                                           : json{{"used", false},
                                                  {"kind", nullptr},
                                                  {"cv_mean_mm_parametric", nullptr},
                                                  {"cv_mean_mm_with_map", nullptr},
                                                  {"hyperparameters", nullptr},
                                                  {"decision", "--residual-model off"}};
  out["validity"] = run.validity ? io::ValidityToJson(*run.validity) : json();
  out["base"] = RowsJson(est.world_from_base);
  auto matrix3 = [](const Eigen::Matrix3d& m) {
    json rows = json::array();
    for (int r = 0; r < 3; ++r) rows.push_back({m(r, 0), m(r, 1), m(r, 2)});
    return rows;
  };
  if (const Eigen::Matrix3d* tool = est.tool_rotation_of(est.reference_frame)) {
    out["tool_rotation"] = matrix3(*tool);
  }
  json frames = json::array();
  for (const auto& f : run.frames) {
    frames.push_back({{"frame", f.frame},
                      {"reference", f.frame == est.reference_frame},
                      {"base", RowsJson(f.world_from_base)},
                      {"fit_poses", f.fit_poses},
                      {"validation_poses", f.validation_poses},
                      {"base_from_validation", f.base_from_validation}});
    if (const auto tool = run.tool_rotations.find(f.frame); tool != run.tool_rotations.end()) {
      frames.back()["tool_rotation"] = matrix3(tool->second);
    }
  }
  out["frames"] = frames;
  json deps = json::array();
  for (const auto& dep : est.identifiability.dependencies) {
    json on = json::array();
    for (const auto& [p, c] : dep.on) on.push_back({{"name", names[p]}, {"coefficient", c}});
    deps.push_back({{"name", names[dep.parameter]}, {"depends_on", on}});
  }
  out["unidentified"] = deps;
  json frozen = json::array();
  for (const auto& f : est.identifiability.frozen_joints) {
    json affected = json::array();
    for (int p : f.affected) affected.push_back(names[p]);
    frozen.push_back({{"joint", f.joint + 1}, {"range_rad", f.range_rad}, {"affected", affected}});
  }
  out["frozen_joints"] = frozen;
  if (run.selection) {
    out["selection"] = {{"criterion", "D-optimal"},
                        {"candidates", run.selection_candidates},
                        {"selected", run.selection->selected.size()},
                        {"log_det", run.selection->log_det},
                        {"o1", run.selection->o1},
                        {"condition_number", run.selection->condition_number},
                        {"exchanges", run.selection->exchanges}};
  }
  if (run.auto_terms) {
    json tests = json::array();
    for (const auto& t : run.auto_terms->tests) {
      tests.push_back({{"added", t.added},
                       {"f", t.f},
                       {"df1", t.df_added},
                       {"df2", t.df_residual},
                       {"p_value", t.p_value},
                       {"significant", t.significant}});
    }
    out["f_tests"] = tests;
  }
  json blunders = json::array();
  for (int i : est.downweighted) blunders.push_back(run.fit_pose_ids[i]);
  out["blunder_poses"] = blunders;
  return out;
}

db::CalibrationRecord CalibrationRecordOf(const calibration::RobotModel& model,
                                          const CalibrationRun& run, int64_t robot_id,
                                          const nlohmann::json& inputs,
                                          const nlohmann::json& options, bool active) {
  const auto& e = run.estimate;
  const auto v = StatsOf(run.validation_residuals);
  db::CalibrationRecord c;
  c.robot_id = robot_id;
  c.params_spec = run.params_spec;
  c.inputs_json = JsonText(inputs);
  c.options_json = JsonText(options);
  c.report_json = JsonText(CalibrationJson(model, run));
  c.rank = e.identifiability.rank;
  c.poses_fit = static_cast<int>(run.fit_pose_ids.size());
  c.poses_validation = static_cast<int>(run.validation_pose_ids.size());
  c.nominal_mean_mm = e.nominal.mean_mm;
  c.nominal_max_mm = e.nominal.max_mm;
  c.nominal_rms_mm = e.nominal.rms_mm;
  c.fit_mean_mm = e.fit.mean_mm;
  c.fit_max_mm = e.fit.max_mm;
  c.fit_rms_mm = e.fit.rms_mm;
  if (v.poses > 0) {
    c.validation_mean_mm = v.mean_mm;
    c.validation_max_mm = v.max_mm;
    c.validation_rms_mm = v.rms_mm;
  }
  c.active = active;
  c.world_from_base = e.world_from_base;
  if (const Eigen::Matrix3d* tool = e.tool_rotation_of(e.reference_frame)) c.tool_rotation = *tool;
  if (run.map_used()) c.residual_map_json = JsonText(io::ResidualMapToJson(run.residual_map->map));
  if (run.validity) c.validity_json = JsonText(io::ValidityToJson(*run.validity));
  if (e.covariance.rows() == static_cast<int>(e.identifiability.identified.size())) {
    const auto names = model.ParameterNames();
    for (int k : e.identifiability.identified) c.covariance_parameters.push_back(names[k]);
    c.covariance = e.covariance;
  }
  const auto names = model.ParameterNames();
  std::vector<char> identified(model.num_parameters(), 0);
  for (int k : e.identifiability.identified) identified[k] = 1;
  for (int k = 0; k < model.num_parameters(); ++k) {
    c.parameters.push_back({names[k],
                            model.UnitOf(k) == calibration::ParameterUnit::kMm ? "mm" : "rad",
                            e.params(k), identified[k] ? e.sigmas(k) : NAN, identified[k] != 0});
  }
  for (size_t i = 0; i < run.fit_pose_ids.size(); ++i) {
    c.residuals.push_back(
        {run.fit_pose_ids[i], "fit", e.fit_residuals[i], e.nominal_residuals[i].norm()});
  }
  for (size_t i = 0; i < run.validation_pose_ids.size(); ++i) {
    c.residuals.push_back({run.validation_pose_ids[i], "validation", run.validation_residuals[i],
                           run.validation_nominal_residuals[i].norm()});
  }
  return c;
}

}  // namespace armsig::workflows
