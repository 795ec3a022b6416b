// The night against the active set: the window's sessions tested against it, the
// configurations two sets are compared on, the new set tried where it was not fitted, and
// the comparison that names a change (nightly/nightly_job.h).
#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <cmath>

#include "nightly/nightly_job.h"

namespace armsig::nightly {

namespace {

// The sessions a stored set was fitted on (its inputs' "sessions").
std::set<int64_t> OwnSessions(const db::StoredCalibration& set) {
  std::set<int64_t> own;
  const auto inputs = nlohmann::json::parse(set.inputs_json, nullptr, false);
  if (inputs.is_object() && inputs.contains("sessions") && inputs["sessions"].is_array()) {
    for (const auto& id : inputs["sessions"]) {
      if (id.is_number_integer()) own.insert(id.get<int64_t>());
    }
  }
  return own;
}

// A session's verdict against the active set.
SessionVerdict VerdictOf(const db::SessionSummary& session, const calibration::SessionTest& t) {
  SessionVerdict v;
  v.session = session.id;
  v.started_at = session.started_at;
  v.poses = t.poses;
  v.mean_mm = t.mean_mm;
  v.disagrees = t.poses > 0 && t.disagrees;
  v.p_value = t.p_value;
  v.effect_max_mm = t.effect_max_mm;
  return v;
}

}  // namespace

// Every session of the window against the active set, its own measuring frame placed:
// where does the robot stop agreeing with it, and why?
void NightlyJob::TestAgainstActive() {
  if (!current_ || window_.empty()) return;
  const workflows::Signature old = workflows::SignatureOf(model_, *current_);
  calibration::FittedSet set = FittedSetOf(model_, old, *current_);
  if (set.identified.empty()) {
    // A set stored before covariances were: the subset its kind of fit identifies, with no
    // uncertainty of its own (each session's scatter still judges it).
    try {
      set.identified = calibration::ModelIdentifiableSubset(
          model_, calibration::ParseParameterSpec(model_, current_->params_spec));
    } catch (const std::invalid_argument&) {
    }
    set.covariance = Eigen::MatrixXd::Zero(set.identified.size(), set.identified.size());
  }
  // The reference: the active set refitted on every configuration of its own sessions
  // still in the window (what they say the robot is, not the selection its fit used), with
  // the scatter those sessions show between them.
  const std::set<int64_t> own = OwnSessions(*current_);
  std::vector<MeasuredPose> reference_poses;
  for (const auto& w : window_) {
    if (own.count(w.summary.id))
      reference_poses.insert(reference_poses.end(), w.poses.begin(), w.poses.end());
  }
  const calibration::ChangeReference reference = calibration::MakeChangeReference(
      model_, set, SetSigmaMm(*current_), reference_poses, TermsOf(model_, current_->params_spec));
  spdlog::debug(
      "recalibrate: sessions judged against version {} refitted on its {} session{} in the "
      "window ({} configurations): noise {:.4f} mm per coordinate, their single causes "
      "scatter {:.2f} times as much as that noise says",
      current_->version, reference.sessions, reference.sessions == 1 ? "" : "s",
      reference_poses.size(), reference.sigma_mm, std::sqrt(reference.overdispersion));
  calibration::ChangeTestOptions options;
  options.significance = kDriftSignificance;
  options.tolerance_mm = gates_.drift_mm;
  auto against = [&](const std::vector<MeasuredPose>& poses) {
    return calibration::TestAgainstReference(model_, reference, poses, options);
  };
  // A set judges the robot only where it was fitted: beyond its terms' joint arcs and its
  // map's support its own error is extrapolation, which a new set-up measuring a new region
  // would take for a change (a false alarm, then a set fitted on that session alone). A
  // configuration just past an arc is still judged when the set predicts it the same whether
  // its terms are held at the arc's edge or carried on (within a quarter of the drift
  // tolerance): there the prediction does not depend on how the set is extended.
  calibration::RobotModel held = model_;
  held.term_support = old.validity.term_arcs;
  calibration::RobotModel carried_on = model_;
  carried_on.term_support.clear();
  const double extension_tolerance_mm = 0.25 * gates_.drift_mm;
  auto judged = [&](const std::vector<MeasuredPose>& poses) {
    std::vector<Eigen::VectorXd> joints;
    for (const auto& p : poses) joints.push_back(p.joints_rad);
    const auto predicted = calibration::PredictPositions(held, Eigen::Isometry3d::Identity(),
                                                         old.params, old.map.get(), joints);
    const auto extended = calibration::PredictPositions(
        carried_on, Eigen::Isometry3d::Identity(), old.params, old.map.get(), joints);
    std::vector<MeasuredPose> inside;
    for (size_t i = 0; i < poses.size(); ++i) {
      const auto support = calibration::SupportAt(model_, old.params, old.validity,
                                                  poses[i].joints_rad, predicted[i].extrapolated);
      const bool same_either_way =
          !support.map_outside &&
          (predicted[i].position_mm - extended[i].position_mm).norm() <= extension_tolerance_mm;
      if (support.inside || same_either_way) inside.push_back(poses[i]);
    }
    return inside;
  };
  std::vector<bool> disagrees;
  for (const auto& w : window_) {
    const std::vector<MeasuredPose> inside = own.count(w.summary.id) ? w.poses : judged(w.poses);
    if (inside.size() < kMinJudgedPoses) {
      Log(fmt::format("session {}: {} of its {} configurations lie where version {} was fitted; "
                      "too few to tell a change of the robot from the set's extrapolation "
                      "elsewhere: not tested against it",
                      w.summary.id, inside.size(), w.poses.size(), current_->version));
      SessionVerdict v;
      v.session = w.summary.id;
      v.started_at = w.summary.started_at;
      disagrees.push_back(false);
      decision_.tested.push_back(v);
      extended_ = true;
      continue;
    }
    if (inside.size() < w.poses.size()) {
      spdlog::debug("recalibrate: session {}: {} of {} configurations inside version {}'s "
                    "support are tested against it",
                    w.summary.id, inside.size(), w.poses.size(), current_->version);
    }
    const auto t = against(inside);
    const SessionVerdict v = VerdictOf(w.summary, t);
    spdlog::debug(
        "recalibrate: session {} ({} configurations) against version {}: mean {:.4f} mm; most "
        "significant cause changes it by up to {:.3f} mm, p = {:.2g}: {}",
        v.session, v.poses, current_->version, v.mean_mm, v.effect_max_mm, v.p_value,
        v.disagrees ? "DISAGREES" : "agrees");
    if (!t.explanation.causes.empty()) {
      const auto& top = t.explanation.causes.front();
      spdlog::debug("recalibrate: session {}: best single cause {} ({:+.4g} ± {:.2g}, chi2 {:.3g}, "
                    "up to {:.3f} mm, explains {:.0f} %)",
                    v.session, top.cause.name, top.size, top.sigma, top.chi2, top.effect_max_mm,
                    100 * top.explained);
    }
    disagrees.push_back(v.disagrees);
    decision_.tested.push_back(v);
  }
  const auto point = calibration::LocateChange(disagrees);
  for (int i : point.outliers) {
    decision_.tested[i].outlier = true;
    Log(fmt::format(
        "session {} disagrees with version {} (a change of up to {:.3f} mm) while a later "
        "session agrees: a set-up fault, not the robot; left out of this fit ({} keeps it out "
        "for good)",
        decision_.tested[i].session, current_->version, decision_.tested[i].effect_max_mm,
        workflows::Hint(database_->path(), {"session", "discard", std::to_string(decision_.tested[i].session)})));
  }
  if (point.first_changed < 0) return;
  ChangeFinding change;
  std::vector<MeasuredPose> after;
  std::vector<MeasuredPose> after_inside;
  for (size_t i = point.first_changed; i < window_.size(); ++i) {
    change.after.push_back(window_[i].summary.id);
    after.insert(after.end(), window_[i].poses.begin(), window_[i].poses.end());
    const auto inside = judged(window_[i].poses);
    after_inside.insert(after_inside.end(), inside.begin(), inside.end());
  }
  change.from_session = window_[point.first_changed].summary.id;
  change.from_started_at = window_[point.first_changed].summary.started_at;
  change.poses_after = static_cast<int>(after.size());
  change.poses_needed =
      PosesNeeded(static_cast<int>(set.identified.size()), static_cast<int>(change.after.size()));
  // The change explained on every session since at once, where the set can judge it.
  const auto t = against(after_inside);
  for (const auto& c : t.explanation.causes) {
    if (change.causes.size() == 3) break;
    change.causes.push_back(NameOf(c, "on the configurations measured since"));
  }
  change.indistinguishable = t.explanation.indistinguishable_from_frame;
  change.effect_max_mm = t.effect_max_mm;
  change.p_value = t.p_value;
  decision_.change = std::move(change);
  Log(fmt::format("the robot disagrees with version {} from session {} onwards ({} configurations)",
                  current_->version, *decision_.change->from_session, decision_.change->poses_after));
}


namespace {

// Error distances of a set's predictions (terms held to their arcs, the map where it
// applies) against a session's measured positions, its frame placed by a rigid best fit of
// all of them.
std::optional<double> PlacedMeanMm(const calibration::RobotModel& model,
                                   const Eigen::VectorXd& params,
                                   const calibration::ResidualMap* map,
                                   const std::vector<MeasuredPose>& poses) {
  std::vector<Eigen::VectorXd> joints;
  std::vector<Eigen::Vector3d> measured, predicted;
  for (const auto& p : poses) {
    joints.push_back(p.joints_rad);
    measured.push_back(p.target_in_world);
  }
  for (const auto& x : calibration::PredictPositions(model, Eigen::Isometry3d::Identity(), params,
                                                     map, joints))
    predicted.push_back(x.position_mm);
  const auto a = calibration::iso9283::AlignRigidly(measured, predicted);
  if (!a) return std::nullopt;
  double sum = 0.0;
  for (double d : a->residual_mm) sum += d;
  return sum / static_cast<double>(a->residual_mm.size());
}

}  // namespace

// Two sets are compared where both were fitted: the configurations spread over the work
// volume inside both sets' term arcs; when fewer than half of them are, the window's own
// configurations inside both (at most kDriftConfigurations, evenly taken). Beyond the arcs
// each set extrapolates, and two extrapolations differ without the robot having changed.
void NightlyJob::DriftConfigurations(const workflows::Signature& old) {
  compared_.clear();
  const calibration::SetValidity fresh = run_->validity.value_or(calibration::SetValidity{});
  auto inside_both = [&](const Eigen::VectorXd& q) {
    return calibration::SupportAt(model_, old.params, old.validity, q, false).inside &&
           calibration::SupportAt(model_, run_->estimate.params, fresh, q, false).inside;
  };
  for (const auto& q : spread_) {
    if (inside_both(q)) compared_.push_back(q);
  }
  compared_over_ = compared_.size() == spread_.size()
                       ? "spread over the work volume"
                       : "spread over where both sets were fitted";
  if (2 * compared_.size() >= spread_.size()) return;
  std::vector<Eigen::VectorXd> window;
  for (const auto& p : fit_) {
    if (inside_both(p.joints_rad)) window.push_back(p.joints_rad);
  }
  compared_.clear();
  const size_t take = std::min<size_t>(window.size(), kDriftConfigurations);
  for (size_t k = 0; k < take; ++k) compared_.push_back(window[k * window.size() / take]);
  compared_over_ = "of the fit where both sets were fitted";
  if (compared_.size() < 10) compared_.clear();
}

// Before a new set becomes active it is tried where it was not fitted: every session of
// the robot the night left out (other kinds, outside the window; never one from before a
// change), each placed by its own frame. It must not be worse there than the active set
// (or, with none, than the nominal model) by more than the noise of such a comparison.
void NightlyJob::TryElsewhere() {
  if (!pass_ || !run_ || !run_->estimate.usable() || elsewhere_.empty()) return;
  std::set<int64_t> after;
  if (decision_.change) after.insert(decision_.change->after.begin(), decision_.change->after.end());
  calibration::RobotModel signed_model = model_;
  if (run_->validity) signed_model.term_support = run_->validity->term_arcs;
  std::optional<calibration::ResidualMap> new_map;
  if (run_->map_used()) new_map.emplace(run_->residual_map->map);
  std::optional<workflows::ActiveSignature> active;
  if (current_) active = workflows::LoadSignature(*database_, options_.robot, current_->version);
  for (const auto& w : elsewhere_) {
    // After a change the older sessions are another robot's: not a test of this one.
    if (decision_.change && !after.count(w.summary.id)) continue;
    if (w.poses.size() < kMinElsewherePoses) continue;
    RecalibrationDecision::Elsewhere e;
    e.session = w.summary.id;
    e.poses = static_cast<int>(w.poses.size());
    const auto fresh = PlacedMeanMm(signed_model, run_->estimate.params,
                                    new_map ? &*new_map : nullptr, w.poses);
    const auto reference =
        active ? PlacedMeanMm(active->model, active->signature.params,
                              active->signature.map.get(), w.poses)
               : PlacedMeanMm(model_, Eigen::VectorXd::Zero(model_.num_parameters()), nullptr,
                              w.poses);
    if (!fresh || !reference) continue;
    e.new_mean_mm = *fresh;
    e.reference_mean_mm = *reference;
    e.reference = active ? fmt::format("version {}", active->signature.version)
                         : std::string("the nominal model");
    e.held = e.new_mean_mm <= e.reference_mean_mm * (1.0 + kElsewhereTolerance) +
                                  gates_.tolerance_mm;
    Log(fmt::format("tried on session {} ({} {}, {} configurations, placed by its own frame): "
                    "{:.4f} mm, {} {:.4f} mm: {}",
                    e.session, db::ToString(w.summary.kind), ShortTime(w.summary.started_at), e.poses,
                    e.new_mean_mm, e.reference, e.reference_mean_mm,
                    e.held ? "holds" : "WORSE"));
    if (!e.held) {
      decision_.refusals.push_back(fmt::format(
          "worse elsewhere: on session {} (not fitted; its frame placed on its {} "
          "configurations) the new set misses by {:.4f} mm on average, {} by {:.4f} mm",
          e.session, e.poses, e.new_mean_mm, e.reference, e.reference_mean_mm));
      pass_ = false;
    }
    decision_.elsewhere.push_back(e);
  }
}

// The active set on the new fit's validation data (a gate): not worse than it by more than
// the tolerance.
void NightlyJob::CompareOnSameData(const workflows::Signature& old) {
  // The current set on the same validation data, each session's base re-aligned on that
  // session's fit poses (the measuring frame moves between set-ups; the arm signature
  // does not), as the new fit placed each frame on them.
  calibration::FrameBases old_bases = calibration::AlignFrameBases(model_, old.params, fit_);
  {
    std::vector<MeasuredPose> unplaced;
    for (const auto& p : validation_) {
      if (!old_bases.count(p.frame)) unplaced.push_back(p);
    }
    for (const auto& [frame, base] : calibration::AlignFrameBases(model_, old.params, unplaced))
      old_bases[frame] = base;
  }
  bool placed = !validation_.empty();
  for (const auto& p : validation_) placed = placed && old_bases.count(p.frame) > 0;
  // Judged on the validation configurations neither set was fitted on. The active set's
  // residual map has its training configurations as centres, and a map reproduces the poses
  // it learned far better than new ones (its joint curves all the more): scored on them, the
  // active set would win against any new one.
  std::set<std::vector<double>> trained;
  if (old.map) {
    for (const auto& c : old.map->data().centres_rad) trained.insert(c);
  }
  std::map<std::string, size_t> residual_of;
  for (size_t i = 0; i < run_->validation_pose_ids.size(); ++i)
    residual_of[run_->validation_pose_ids[i]] = i;
  std::vector<MeasuredPose> unseen;
  std::vector<Eigen::Vector3d> now_residuals;
  for (const auto& p : validation_) {
    std::vector<double> angles;
    if (old.map) {
      for (int j : old.map->data().joints) angles.push_back(p.joints_rad(j));
    }
    const auto r = residual_of.find(p.id);
    if (trained.count(angles) || r == residual_of.end()) continue;
    unseen.push_back(p);
    now_residuals.push_back(run_->validation_residuals[r->second]);
  }
  if (placed && !unseen.empty()) {
    // With its residual map when it has one: the set as predict and compensate use it.
    decision_.previous_on_same_data =
        workflows::StatsOf(workflows::MappedResiduals(model_, old_bases, old.params, old.map.get(), unseen));
    const calibration::ErrorStats now = workflows::StatsOf(now_residuals);
    spdlog::debug(
        "recalibrate: version {} on the same validation data ({} of {} configurations, the "
        "others trained its map; {} frames re-aligned): mean {:.4f} mm, max {:.4f} mm; the new "
        "set there: mean {:.4f} mm",
        current_->version, unseen.size(), validation_.size(), old_bases.size(),
        decision_.previous_on_same_data->mean_mm, decision_.previous_on_same_data->max_mm, now.mean_mm);
    Gate(fmt::format("not worse than version {} on the same data (+{:.3f} mm)", current_->version,
                     gates_.tolerance_mm),
         now.mean_mm, decision_.previous_on_same_data->mean_mm + gates_.tolerance_mm);
  } else {
    spdlog::debug("recalibrate: version {} could not be placed in every frame: no comparison "
                  "on the same data",
                  current_->version);
  }
}

// The new set against the active one: on the same validation data (a gate), and by the
// positions both predict over the work volume (drift), the difference named by its causes.
void NightlyJob::CompareWithActive() {
  if (!current_ || !run_->estimate.status.ok()) return;
  const workflows::Signature old = workflows::SignatureOf(model_, *current_);
  CompareOnSameData(old);
  // Drift: do the two models put the arm in different places, beyond what both fits'
  // uncertainty explains and by more than the tolerance?
  const workflows::CalibrationRun& run = *run_;
  const calibration::FittedSet now{run.estimate.params, run.estimate.identifiability.identified,
                                   run.estimate.covariance};
  calibration::FittedSet before = FittedSetOf(model_, old, *current_);
  ModelDrift m;
  m.previous_covariance = !before.identified.empty();
  if (!m.previous_covariance) {
    // Stored before covariances were: take this fit's (same lab, same procedure).
    before.identified = now.identified;
    before.covariance = now.covariance;
  }
  DriftConfigurations(old);
  if (compared_.empty()) {
    Log(fmt::format("no drift test against version {}: no configuration lies where both sets "
                    "were fitted (the new set's sessions and version {}'s cover different "
                    "joint ranges)",
                    current_->version, current_->version));
    return;
  }
  const auto c = calibration::CompareModels(model_, before, now, compared_);
  m.configurations = c.configurations;
  m.max_mm = c.max_mm;
  m.mean_mm = c.mean_mm;
  m.rms_mm = c.rms_mm;
  m.chi2 = c.chi2;
  m.dof = c.dof;
  m.p_value = c.p_value;
  m.same_subset = c.shared_shape_space;
  m.significant = c.p_value < kDriftSignificance;
  m.tolerance_mm = gates_.drift_mm;
  // A change found in the sessions is drift whatever the two fits' scatter says. A night
  // that brought a session where the active set was never fitted (a new set-up measuring a
  // new region, which the set could not judge) changes what the fit covers: the two sets then
  // differ without the robot having changed, and only the sessions can say it did.
  const bool sets_differ = m.significant && m.max_mm > m.tolerance_mm;
  // The same measurements fitted again (another --params, --select, residual model) cannot
  // show the robot changed: whatever differs is the model's.
  const bool same_measurements = SameMeasurements(*current_, decision_.sessions, input_poses_);
  decision_.drift = (sets_differ && !extended_ && !same_measurements) || decision_.change.has_value();
  decision_.model_drift = m;
  if (sets_differ && same_measurements && !decision_.change) {
    Log(fmt::format("the new set differs from version {} by up to {:.3f} mm on the same "
                    "measurements (sessions and poses): another model (--params {} against {}), "
                    "not a change of the robot: not called drift",
                    current_->version, m.max_mm, options_.params, current_->params_spec));
  }
  if (sets_differ && extended_ && !decision_.change) {
    Log(fmt::format("the new set differs from version {} by up to {:.3f} mm where both were "
                    "fitted, but this night extends the fit to configurations version {} never "
                    "covered and no session it could judge disagrees with it: not called drift",
                    current_->version, m.max_mm, current_->version));
  }
  Log(fmt::format(
      "{}: against version {} the predicted positions differ by up to {:.3f} mm (mean {:.3f} "
      "mm) over {} configurations {}; chi2 {:.1f} on {} dof ({}), "
      "tolerance {:.3f} mm{}",
      decision_.drift ? "DRIFT" : "no drift", current_->version, m.max_mm, m.mean_mm, m.configurations,
      compared_over_, m.chi2, m.dof, PValueText(m.p_value), m.tolerance_mm,
      m.same_subset ? ""
                    : fmt::format("; the two sets estimate different parameters: chi2 only "
                                  "on the shape changes both can make (version {}: {})",
                                  current_->version, current_->params_spec)));
  // Per parameter: on the parameters both sets identified, in one gauge (the rigid part
  // the two base alignments put into the parameters taken out).
  const auto names = model_.ParameterNames();
  for (const auto& p : c.parameters) {
    changes_.push_back({p.parameter, p.change, p.z});
    decision_.max_abs_sigmas = std::max(decision_.max_abs_sigmas, std::abs(p.z));
    if (decision_.drift && std::abs(p.z) > gates_.drift_sigma) {
      decision_.drifted.push_back({names[p.parameter], p.change, p.z});
      const bool angle = model_.UnitOf(p.parameter) == calibration::ParameterUnit::kRad;
      spdlog::debug("recalibrate: drift: {} changed by {:+.4f} {} ({:.1f} sigma)",
                    names[p.parameter], angle ? p.change * 1e3 : p.change, angle ? "mrad" : "mm",
                    p.z);
    }
  }
  if (decision_.drift && decision_.change && !decision_.change->causes.empty()) {
    // One ranking everywhere: the change found in the sessions themselves is named from what
    // they measured, and the two sets' difference is reported with the same causes.
    decision_.causes = decision_.change->causes;
    for (const auto& cause : decision_.causes) Log("drift: " + cause.Describe());
  } else if (decision_.drift) {
    // What physically changed between the two sets, one cause at a time.
    const auto explanation = calibration::ExplainDifference(
        model_, before.params, calibration::SetDifference(model_, before, now, compared_), 3,
        TermsOf(model_, run.params_spec));
    const std::string over =
        fmt::format("over {} configurations {}", compared_.size(), compared_over_);
    for (const auto& cause : explanation.causes) decision_.causes.push_back(NameOf(cause, over));
    for (const auto& cause : decision_.causes) Log("drift: " + cause.Describe());
  }
}


}  // namespace armsig::nightly
