// The nightly recalibration: fit the robot's stored measurements, validate on the
// configurations not used in the fit, compare with the active set on the same data,
// and store a new active parameter set only when every gate passes.
#pragma once

#include <atomic>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "calibration/drift.h"
#include "calibration/estimation.h"
#include "db/sessions.h"

namespace armsig::nightly {

struct RecalibrateOptions {
  std::string db_path;
  std::string robot;
  // ISO date or date/time lower bound on the sessions used ("" = all), see SinceToUtc.
  std::string since;
  // The default keeps only the terms that pay on data the fit did not see (calibration's
  // transfer folds): the set that travels to another day's set-up. "all": every term of the
  // model, wherever the data put them.
  std::string params = "auto";
  // The session kinds fitted (db::SessionKind): ISO 9283 tests and check sessions are not
  // calibration data unless asked for.
  std::vector<db::SessionKind> kinds = {db::SessionKind::kCalibration};
  std::string residual_model = "auto";  // auto | off (calibrate's --residual-model)
  std::string orientation = "auto";     // auto | off (calibrate's --orientation)
  std::string tool_rotation = "per-session";  // per-session | shared
  // Configurations to fit (0: 60 %, at most 2,000).
  int select = 0;
  // Set (Ctrl-C, SIGTERM): the job stops at its next safe point — within the fit at its next
  // solver iteration, selection step or cross-validation, or after it and before anything is
  // stored — with `stopped` in the decision and nothing written.
  const std::atomic<bool>* stop = nullptr;
  // Gates; unset = the lab file's `recalibration:` block, else the defaults below.
  std::optional<double> max_validation_mean_mm, max_validation_max_mm, tolerance_mm, drift_sigma,
      drift_mm;
  // The window of sessions a fit may use; unset = the lab file's `recalibration: window:`,
  // else the newest kDefaultWindowSessions started within kDefaultWindowDays (0: no limit).
  std::optional<int> window_sessions, window_days;
  std::string report_dir;  // write the HTML report here ("" = none)
  std::string json_path;   // the caller will write the decision here: checked before any write
  int max_iterations = 50;  // of the fit; a fit that needs more fails (exit 1), not a gate
  int lock_wait_s = 600;
  bool force = false;  // refit even when a stored set already uses these inputs
};

// `--since` as the sessions' start times are stored (UTC, YYYY-MM-DDTHH:MM:SS.sssZ). An
// ISO 8601 date (its midnight) or date and time (T or one space between; HH:MM or
// HH:MM:SS with an optional fraction), in local time ($TZ) unless it ends in Z (UTC) or an
// offset from UTC (±HH:MM, ±HHMM, ±HH). Anything else, an impossible calendar date
// (2026-02-30, 2026-11-31) included, is an InputError naming the value.
std::string SinceToUtc(const std::string& text);

inline constexpr int kDefaultWindowSessions = 10;
inline constexpr int kDefaultWindowDays = 90;
// Drift needs the two sets' predicted positions to differ by more than this (mm) too.
inline constexpr double kDefaultDriftMm = calibration::kDefaultDriftMm;

struct Gate {
  std::string name;
  double value_mm = 0.0, limit_mm = 0.0;
  bool passed = false;
};

struct DriftedParameter {
  std::string name;
  double change = 0.0;  // mm or rad
  double sigmas = 0.0;
};

// The new set against the active one, by the positions both predict over configurations
// spread over the work volume (calibration::CompareModels), after aligning bases.
struct ModelDrift {
  int configurations = 0;
  double max_mm = 0.0, mean_mm = 0.0, rms_mm = 0.0;
  double chi2 = 0.0;
  int dof = 0;
  double p_value = 1.0;
  bool significant = false;         // p_value < 0.001
  double tolerance_mm = 0.0;        // drift needs max_mm above this too
  bool previous_covariance = true;  // false: the active set predates stored covariances
  bool same_subset = true;          // false: chi2 on the shape changes both subsets can make
};

// One session of the window tested against the active set (calibration::TestAgainstSet).
struct SessionVerdict {
  int64_t session = 0;
  std::string started_at;
  int poses = 0;
  double mean_mm = 0.0;  // the active set's error distances on it, its own frame placed
  bool disagrees = false;
  double p_value = 1.0, effect_max_mm = 0.0;
  bool outlier = false;  // disagrees, but a later session agrees: left out of the fit
};

// A physical cause of a change, as the decision names it (calibration::ExplainedCause).
struct NamedCause {
  std::string name, parameter;
  std::string unit;     // mrad | mm | ppm
  double size = 0.0;    // in `unit`
  double sigma = 0.0;   // in `unit`
  double explained = 0.0;  // share of the difference it explains alone (0–1)
  double effect_max_mm = 0.0, effect_mean_mm = 0.0;
  std::vector<std::string> equivalent;
  // Where the effect was taken: "on the configurations measured since" (a change found in
  // the sessions) or "over 50 configurations spread over the work volume" (two fitted sets).
  std::string over;
  // "joint 2 zero moved by +0.349 mrad (± 0.0055): up to 0.529 mm at the tool on the
  // configurations measured since, explains 100 % of the change"
  std::string Describe() const;
};

// What the robot did over the window, from the active set's point of view.
struct ChangeFinding {
  std::optional<int64_t> from_session;  // the first session after the change
  std::string from_started_at;
  std::vector<int64_t> after;           // the sessions from the change on
  int poses_after = 0;                  // their usable configurations
  int poses_needed = 0;                 // for a fit of them alone
  std::vector<NamedCause> causes;       // best first
  std::vector<std::string> indistinguishable;  // causes a moved measuring frame makes alike
  double effect_max_mm = 0.0, p_value = 1.0;
};

struct RecalibrationDecision {
  // kFailed: the fit itself did not produce a usable estimate (not converged, non-finite):
  // no gate can judge it, nothing is stored, and a scheduler sees a failure (exit 1), not
  // a set that validated badly (kRejected, exit 3). kDriftStored: the robot changed and a
  // set fitted on the sessions after the change alone is stored and active (exit 4).
  // kDriftSuspected: the newest sessions disagree with the active set but do not yet hold
  // enough configurations for a fit of their own; nothing is stored (exit 5).
  enum class Outcome { kUpToDate, kStored, kDriftStored, kDriftSuspected, kRejected, kFailed };
  Outcome outcome = Outcome::kRejected;
  bool stopped = false;  // RecalibrateOptions::stop was set: nothing stored (exit 130)
  std::string robot;
  // The stored version; when up to date, the version fitted on these inputs (the active
  // one, or — after a roll-back — another, which stays inactive).
  int version = 0;
  std::optional<int> previous_version;  // the set active before this run
  // Up to date with a set that is not the active one: how the active one was chosen (its
  // latest activation: recalibrate, activate, demo or migration, and when).
  std::string active_chosen_by, active_chosen_at;
  int poses = 0;
  int rank = 0;
  calibration::ErrorStats nominal, fit, validation;
  // With orientation equations (6-DoF sessions): the fit's and the validation's angle errors
  // as calibrate's JSON gives them (fit.orientation, validation.orientation); null otherwise.
  nlohmann::json fit_orientation, validation_orientation;
  std::optional<calibration::ErrorStats> previous_on_same_data;
  std::vector<Gate> gates;
  // Drift: the models differ significantly and by more than the tolerance in mm.
  bool drift = false;
  std::optional<ModelDrift> model_drift;  // when there was an active set to compare with
  double max_abs_sigmas = 0.0;            // per parameter, on the subset both sets share
  std::vector<DriftedParameter> drifted;  // those beyond drift_sigma, largest first
  std::vector<int64_t> sessions;          // the sessions fitted and validated
  // The window: its limits, the first session the active set allows (a confirmed change
  // point), every session in it tested against the active set, and what they showed.
  int window_sessions = 0, window_days = 0;
  std::optional<int64_t> floor_session;
  std::vector<SessionVerdict> tested;
  std::optional<ChangeFinding> change;
  // The set's difference from the active one explained (when a set was fitted and there
  // was an active one to compare with and drift was flagged).
  std::vector<NamedCause> causes;
  nlohmann::json residual_model;          // calibrate's residual_model object (null: not fitted)
  std::string report_path;                // "" when no report was written
  // A set was stored but an output that can only follow the commit (the report) could not
  // be written: what failed, and the command that writes it (exit 6 instead of 0).
  std::string output_error;
  std::string failure;                    // kFailed: why the fit gave no usable estimate
  // Why a set that passed the numeric gates may still not become active (kRejected): a
  // parameter no robot shows ("not this robot or not these units: joint 2 zero (gamma2):
  // +1840 mrad (limit 50 mrad)"), or worse than the active set on a session it was not fitted
  // on ("worse elsewhere: session 3 …").
  std::vector<std::string> refusals;
  // The sessions of another set-up the new set was tried on before activation (placed by
  // their own frame): its mean error there, the active set's (or the nominal model's when no
  // set is active), and whether it held.
  struct Elsewhere {
    int64_t session = 0;
    int poses = 0;
    double new_mean_mm = 0.0, reference_mean_mm = 0.0;
    std::string reference;  // "version 3" | "the nominal model"
    bool held = true;
  };
  std::vector<Elsewhere> elsewhere;
  // The controller's own calibration (UR KinematicsInfo) changed since the robot's previous
  // session (acquisition::ControllerCalibrationChange): named first among a drift's causes;
  // "" when it did not or the controller cannot say.
  std::string controller_calibration;

  bool passed() const {
    return outcome == Outcome::kUpToDate || outcome == Outcome::kStored ||
           outcome == Outcome::kDriftStored;
  }
  // The exit code a scheduler acts on: 0 stored or up to date, 4 drift (a new set stored),
  // 5 drift suspected (more data needed), 3 rejected by a gate, 1 failed, 6 stored (or up
  // to date) but its report could not be written (`output_error`).
  int ExitCode() const;
  // The line a person must see on a drift night ("" when there was no drift): what
  // changed, from when, the named cause and what was done about it.
  std::string DriftLine() const;
  // `causes` with controller_calibration in front (when there is one).
  std::string WithController(const std::string& causes) const;
  // "stored as version 4 (active)" / "rejected: a gate failed; version 3 stays active" /
  // "failed: the fit did not converge (…); version 3 stays active" / …
  std::string Describe() const;
  nlohmann::json ToJson() const;
  // The drift decision as stored with the new set (calibrations.drift_json); null when
  // there was no active set to compare with.
  nlohmann::json DriftJson() const;
};


// Throws InputError for an unknown robot, too few measurements or a malformed stored
// lab file; std::runtime_error when another recalibration holds the lock too long.
RecalibrationDecision Recalibrate(const RecalibrateOptions& options);

}  // namespace armsig::nightly
