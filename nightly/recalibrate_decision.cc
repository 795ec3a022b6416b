// The nightly job's decision in words and as JSON (nightly/recalibrate.h).
#include "nightly/recalibrate.h"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <algorithm>
#include <cmath>
#include <string>

#include "core/text.h"
#include "core/wording.h"
#include "nightly/nightly_job.h"

namespace armsig::nightly {


nlohmann::json StatsJson(const calibration::ErrorStats& s) {
  return {{"poses", s.poses}, {"mean_mm", s.mean_mm}, {"max_mm", s.max_mm}, {"rms_mm", s.rms_mm}};
}

// "2026-11-27T02:30:00.123Z" → "2026-11-27 02:30 UTC".
std::string ShortTime(const std::string& iso) {
  if (iso.size() < 16) return iso;
  return iso.substr(0, 10) + " " + iso.substr(11, 5) + " UTC";
}

std::string SessionList(const std::vector<int64_t>& sessions) {
  std::string out;
  for (size_t k = 0; k < sessions.size(); ++k) out += (k ? ", " : "") + std::to_string(sessions[k]);
  return (sessions.size() == 1 ? "session " : "sessions ") + out;
}

nlohmann::json CausesJson(const std::vector<NamedCause>& causes) {
  nlohmann::json out = nlohmann::json::array();
  for (const auto& c : causes) {
    out.push_back({{"name", c.name},
                   {"parameter", c.parameter},
                   {"size", c.size},
                   {"sigma", c.sigma},
                   {"unit", c.unit},
                   {"explained", c.explained},
                   {"effect_max_mm", c.effect_max_mm},
                   {"effect_mean_mm", c.effect_mean_mm},
                   {"equivalent", c.equivalent},
                   {"text", c.Describe()}});
  }
  return out;
}

nlohmann::json TestedJson(const std::vector<SessionVerdict>& tested) {
  nlohmann::json out = nlohmann::json::array();
  for (const auto& v : tested) {
    out.push_back({{"session", v.session},
                   {"started_at", v.started_at},
                   {"poses", v.poses},
                   {"mean_mm", v.mean_mm},
                   {"disagrees", v.disagrees},
                   {"p_value", v.p_value},
                   {"effect_max_mm", v.effect_max_mm},
                   {"outlier", v.outlier}});
  }
  return out;
}

nlohmann::json ChangeJson(const std::optional<ChangeFinding>& change) {
  if (!change) return nullptr;
  return {{"from_session", change->from_session ? nlohmann::json(*change->from_session)
                                                : nlohmann::json(nullptr)},
          {"from_started_at", change->from_started_at},
          {"sessions", change->after},
          {"poses", change->poses_after},
          {"poses_needed", change->poses_needed},
          {"effect_max_mm", change->effect_max_mm},
          {"p_value", change->p_value},
          {"causes", CausesJson(change->causes)},
          {"indistinguishable_from_frame", change->indistinguishable}};
}


using namespace nightly;

std::string RecalibrationDecision::Describe() const {
  switch (outcome) {
    case Outcome::kUpToDate:
      if (previous_version && *previous_version != version) {
        // A roll-back (or forward) chose the active set: the nightly job does not undo it.
        return fmt::format(
            "up to date: version {} already fits these {} poses with these options; version {} "
            "stays active (made active by {}{}); nothing to do (--force refits)",
            version, poses, *previous_version,
            active_chosen_by.empty() ? std::string("a choice not recorded") : active_chosen_by,
            active_chosen_at.empty() ? std::string() : " at " + active_chosen_at);
      }
      if (!previous_version) {
        return fmt::format(
            "up to date: version {} already fits these {} poses with these options; no set is "
            "active; nothing to do (--force refits)",
            version, poses);
      }
      return fmt::format("up to date: version {} already uses these {} poses; nothing to do",
                         version, poses);
    case Outcome::kStored:
      return fmt::format("stored as version {} (active)", version);
    case Outcome::kDriftStored:
      return fmt::format("stored as version {} (active): the robot changed{}", version,
                         change ? fmt::format(" from session {}; fitted on {} alone",
                                              *change->from_session, SessionList(sessions))
                                : std::string(" (drift)"));
    case Outcome::kDriftSuspected:
      return fmt::format(
          "drift suspected from session {}: {} configuration{} measured since, a fit of them "
          "alone needs {}: measure {} more; {}",
          change ? *change->from_session : 0, poses, poses == 1 ? "" : "s",
          change ? change->poses_needed : 0, change ? change->poses_needed - poses : 0,
          previous_version ? fmt::format("version {} stays active", *previous_version)
                           : std::string("no parameter set is active"));
    case Outcome::kRejected: {
      std::string failed;
      for (const auto& g : gates) {
        if (g.passed) continue;
        failed += fmt::format("{}{} {:.4f} mm > {:.4f} mm", failed.empty() ? "" : ", ", g.name,
                              g.value_mm, g.limit_mm);
      }
      for (const auto& r : refusals) failed += (failed.empty() ? "" : "; ") + r;
      return fmt::format("rejected: {}; {}",
                         failed.empty() ? std::string("a gate failed")
                         : refusals.empty() ? "gate failed: " + failed
                                            : failed,
                         previous_version
                             ? fmt::format("version {} stays active", *previous_version)
                             : std::string("no parameter set is active"));
    }
    case Outcome::kFailed:
      return fmt::format("failed: {}; {}", failure,
                         previous_version
                             ? fmt::format("version {} stays active", *previous_version)
                             : std::string("no parameter set is active"));
  }
  return "";
}

nlohmann::json RecalibrationDecision::ToJson() const {
  nlohmann::json j;
  j["robot"] = robot;
  j["poses"] = poses;
  if (!controller_calibration.empty()) j["controller_calibration"] = controller_calibration;
  if (outcome == Outcome::kUpToDate) {
    j["exit_code"] = ExitCode();
    if (!output_error.empty()) j["output_error"] = output_error;
    if (!report_path.empty()) j["report"] = report_path;
    j["decision"] = "up_to_date";
    j["version"] = version;
    j["active_version"] =
        previous_version ? nlohmann::json(*previous_version) : nlohmann::json(nullptr);
    if (previous_version && *previous_version != version) {
      j["active_chosen_by"] = active_chosen_by;
      j["active_chosen_at"] = active_chosen_at;
    }
    return j;
  }
  j["exit_code"] = ExitCode();
  if (!output_error.empty()) j["output_error"] = output_error;
  j["decision"] = outcome == Outcome::kStored || outcome == Outcome::kDriftStored ? "stored"
                  : outcome == Outcome::kDriftSuspected                         ? "drift_suspected"
                  : outcome == Outcome::kFailed                                 ? "failed"
                                                                                : "rejected";
  j["window"] = {{"sessions", window_sessions},
                 {"days", window_days},
                 {"floor_session", floor_session ? nlohmann::json(*floor_session)
                                                 : nlohmann::json(nullptr)}};
  j["tested"] = TestedJson(tested);
  j["change"] = ChangeJson(change);
  if (!DriftLine().empty()) j["drift_line"] = DriftLine();
  if (outcome == Outcome::kDriftSuspected) {
    j["version"] = nullptr;
    if (previous_version) j["previous_version"] = *previous_version;
    j["sessions"] = sessions;
    if (!report_path.empty()) j["report"] = report_path;
    return j;
  }
  if (outcome == Outcome::kFailed) j["failure"] = failure;
  j["version"] = version > 0 ? nlohmann::json(version) : nlohmann::json(nullptr);
  if (previous_version) j["previous_version"] = *previous_version;
  j["rank"] = rank;
  j["fit"] = StatsJson(fit);
  if (!fit_orientation.is_null()) j["fit"]["orientation"] = fit_orientation;
  j["nominal"] = StatsJson(nominal);
  j["validation"] = StatsJson(validation);
  if (!validation_orientation.is_null()) j["validation"]["orientation"] = validation_orientation;
  if (previous_on_same_data) j["current_on_same_data"] = StatsJson(*previous_on_same_data);
  j["gates"] = nlohmann::json::array();
  for (const auto& g : gates) {
    j["gates"].push_back({{"name", g.name},
                          {"value_mm", g.value_mm},
                          {"limit_mm", g.limit_mm},
                          {"passed", g.passed}});
  }
  j["refusals"] = refusals;
  j["elsewhere"] = nlohmann::json::array();
  for (const auto& e : elsewhere) {
    j["elsewhere"].push_back({{"session", e.session},
                              {"poses", e.poses},
                              {"mean_mm", e.new_mean_mm},
                              {"reference", e.reference},
                              {"reference_mean_mm", e.reference_mean_mm},
                              {"held", e.held}});
  }
  if (previous_version) j["drift"] = DriftJson();
  if (!residual_model.is_null()) j["residual_model"] = residual_model;
  j["sessions"] = sessions;
  if (!report_path.empty()) j["report"] = report_path;
  return j;
}

std::string NamedCause::Describe() const {
  const bool zero = name.size() > 5 && name.compare(name.size() - 5, 5, " zero") == 0;
  std::string text = fmt::format("{} {} by {:+.3g} {}", name, zero ? "moved" : "changed", size,
                                 unit);
  if (sigma > 0 && std::isfinite(sigma)) text += fmt::format(" (± {:.2g})", sigma);
  text += fmt::format(": up to {:.3f} mm at the tool{}, explains {:.0f} % of the change",
                      effect_max_mm, over.empty() ? "" : " " + over, 100.0 * explained);
  if (!equivalent.empty()) {
    // Equivalent, not the same: these data move the arm alike for each of them, other
    // configurations would tell them apart.
    text += "; these data cannot tell it from ";
    for (size_t k = 0; k < equivalent.size(); ++k) {
      text += (k == 0 ? "" : k + 1 == equivalent.size() ? " or " : ", ") + equivalent[k];
    }
    text += " (an equivalent cause: configurations that move them differently would)";
  }
  return text;
}

int RecalibrationDecision::ExitCode() const {
  switch (outcome) {
    case Outcome::kUpToDate:
    case Outcome::kStored:
      return output_error.empty() ? 0 : 6;
    case Outcome::kDriftStored:
      return 4;
    case Outcome::kDriftSuspected:
      return 5;
    case Outcome::kRejected:
      // The robot changed and the fit of the sessions since failed a gate: no usable set
      // for the robot as it is now — as urgent as a change with too few data.
      return change ? 5 : 3;
    case Outcome::kFailed:
      return 1;
  }
  return 1;
}

namespace {

std::string CauseSummary(const std::vector<NamedCause>& causes) {
  if (causes.empty()) return "no physical cause the model can express explains it";
  const NamedCause& best = causes.front();
  if (best.explained >= 0.5) return best.Describe();
  std::string text = "no single cause explains most of it; the best: ";
  for (size_t k = 0; k < causes.size(); ++k) text += (k ? "; " : "") + causes[k].Describe();
  return text;
}

}  // namespace

// The controller's own calibration change, when there was one, is named first.
std::string RecalibrationDecision::WithController(const std::string& causes) const {
  return controller_calibration.empty() ? causes : controller_calibration + "; " + causes;
}

std::string RecalibrationDecision::DriftLine() const {
  if (!drift && !change) return "";
  const std::string stays = previous_version
                                ? fmt::format("version {} stays active", *previous_version)
                                : std::string("no parameter set is active");
  if (change) {
    const std::string from =
        fmt::format("{} changed from session {} ({})", robot, *change->from_session,
                    ShortTime(change->from_started_at));
    const std::string cause = WithController(CauseSummary(change->causes));
    if (outcome == Outcome::kDriftSuspected) {
      return fmt::format(
          "DRIFT SUSPECTED: {}: {}; {} configuration{} measured since, a fit of them alone needs "
          "{}: measure {} more; {} (it misses the robot by up to {:.3f} mm now)",
          from, cause, change->poses_after, change->poses_after == 1 ? "" : "s",
          change->poses_needed, change->poses_needed - change->poses_after, stays,
          change->effect_max_mm);
    }
    if (outcome == Outcome::kDriftStored) {
      return fmt::format(
          "DRIFT: {}: {}; version {}, fitted on {} ({} configurations) alone, is now active "
          "(validation mean {:.4f} mm)",
          from, cause, version, SessionList(sessions), poses, validation.mean_mm);
    }
    return fmt::format("DRIFT: {}: {}; the fit of {} since did not pass: {}; check the set-up "
                       "and measure again",
                       from, cause, SessionList(sessions), Describe());
  }
  const std::string cause = WithController(CauseSummary(causes));
  if (model_drift) {
    return fmt::format(
        "DRIFT: version {} differs from version {} by up to {:.3f} mm over the work volume ({}): "
        "{}; {}",
        version > 0 ? std::to_string(version) : std::string("(this run)"),
        previous_version.value_or(0), model_drift->max_mm, PValueText(model_drift->p_value), cause,
        outcome == Outcome::kDriftStored ? fmt::format("version {} is now active", version)
                                         : stays);
  }
  return "DRIFT: " + cause;
}

nlohmann::json RecalibrationDecision::DriftJson() const {
  if (!previous_version) return nullptr;
  nlohmann::json moved = nlohmann::json::array();
  for (const auto& p : drifted)
    moved.push_back({{"name", p.name}, {"change", p.change}, {"sigmas", p.sigmas}});
  nlohmann::json j = {{"flag", drift},
                      {"against", *previous_version},
                      {"max_abs_sigmas", max_abs_sigmas},
                      {"parameters", moved}};
  if (model_drift) {
    const auto& m = *model_drift;
    j["positions"] = {{"configurations", m.configurations},
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
  j["causes"] = CausesJson(causes);
  j["change"] = ChangeJson(change);
  j["tested"] = TestedJson(tested);
  if (const std::string line = DriftLine(); !line.empty()) j["drift_line"] = line;
  return j;
}

}  // namespace armsig::nightly
