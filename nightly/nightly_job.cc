// The nightly job's run (nightly/recalibrate.h): open and lock, read the window, fit,
// judge, store, report; and --since read as an instant.
#include "nightly/nightly_job.h"

#include <fmt/format.h>
#include <fmt/ranges.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdlib>
#include <ctime>
#include <filesystem>
#include <functional>
#include <map>
#include <optional>
#include <regex>
#include <set>
#include <tuple>

#include "acquisition/controller_record.h"
#include "acquisition/lab.h"
#include "acquisition/session_owner.h"
#include "calibration/change.h"
#include "calibration/compensation.h"
#include "calibration/data_checks.h"
#include "calibration/drift.h"
#include "calibration/identifiability.h"
#include "calibration/iso9283_figures.h"
#include "calibration/signature_limits.h"
#include "core/error.h"
#include "core/fnv.h"
#include "core/text.h"
#include "core/wording.h"
#include "db/database.h"
#include "db/jobs.h"
#include "db/report_queries.h"
#include "db/robots.h"
#include "db/store.h"
#include "io/atomic_file.h"
#include "io/file_lock.h"
#include "io/model_yaml.h"
#include "io/time_stamp.h"
#include "workflows/calibration_run.h"
#include "workflows/hint.h"
#include "workflows/lifecycle.h"
#include "report/report.h"
#include "workflows/signature.h"
#include "report/stored_report.h"

namespace armsig::nightly {


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

// Gates from the latest session's lab file (`recalibration:` block), then the options.
Gates LoadGates(db::Database& database, int64_t robot_id, const RecalibrateOptions& o) {
  Gates g;
  // A malformed block is an input error (never a silent fall-back to the defaults).
  if (const auto lab = db::LatestLabYaml(database, robot_id)) {
    const auto settings = io::StoredLabSettings(lab->lab_yaml, lab->session, database.path());
    if (const auto& r = settings->recalibration) {
      g.max_mean_mm = r->max_validation_mean_mm.value_or(g.max_mean_mm);
      g.max_max_mm = r->max_validation_max_mm.value_or(g.max_max_mm);
      g.tolerance_mm = r->tolerance_mm.value_or(g.tolerance_mm);
      g.drift_sigma = r->drift_sigma.value_or(g.drift_sigma);
      g.drift_mm = r->drift_mm.value_or(g.drift_mm);
      g.window_sessions = r->window_sessions.value_or(g.window_sessions);
      g.window_days = r->window_days.value_or(g.window_days);
    }
  }
  g.window_sessions = o.window_sessions.value_or(g.window_sessions);
  g.window_days = o.window_days.value_or(g.window_days);
  g.drift_mm = o.drift_mm.value_or(g.drift_mm);
  g.max_mean_mm = o.max_validation_mean_mm.value_or(g.max_mean_mm);
  g.max_max_mm = o.max_validation_max_mm.value_or(g.max_max_mm);
  g.tolerance_mm = o.tolerance_mm.value_or(g.tolerance_mm);
  g.drift_sigma = o.drift_sigma.value_or(g.drift_sigma);
  return g;
}

// A calibration's stored inputs digest ("" when none was recorded).
std::string StoredDigest(const db::StoredCalibration& c) {
  // Bounded when the set was loaded (db::CalibrationHistory); an edited value of another
  // type counts as none.
  const auto stored = nlohmann::json::parse(c.inputs_json.empty() ? "{}" : c.inputs_json, nullptr,
                                            false);
  return stored.is_object() && stored.contains("digest") && stored["digest"].is_string()
             ? stored["digest"].get<std::string>()
             : std::string();
}

// Whether a stored set was fitted on the same measurements as this night: the same sessions
// and as many poses (sessions only grow; the same ones re-reduced are the same robot too).
bool SameMeasurements(const db::StoredCalibration& c, const std::vector<int64_t>& sessions,
                      size_t poses) {
  const auto stored = nlohmann::json::parse(c.inputs_json.empty() ? "{}" : c.inputs_json, nullptr,
                                            false);
  if (!stored.is_object() || !stored.contains("sessions") || !stored["sessions"].is_array() ||
      !stored.contains("poses") || !stored["poses"].is_number_unsigned())
    return false;
  std::vector<int64_t> theirs;
  for (const auto& s : stored["sessions"]) {
    if (!s.is_number_integer()) return false;
    theirs.push_back(s.get<int64_t>());
  }
  return theirs == sessions && stored["poses"].get<size_t>() == poses;
}

// Configurations a run of sessions needs for a fit of its own: the job fits 60 % of them
// and wants as many redundant equations (3 per configuration) as unknowns — the identified
// parameters and six for every measuring frame beyond the first — and twenty at least, so
// that the rest can validate.
int PosesNeeded(int identified, int sessions) {
  const int unknowns = identified + 6 * std::max(sessions - 1, 0);
  const int fit = (2 * unknowns + 2) / 3;
  return std::max(20, static_cast<int>(std::ceil(fit / 0.6)));
}

// The time `days` before now as session start times are stored (UTC, ISO 8601).
std::string DaysAgoUtc(int days) {
  const std::time_t t = std::time(nullptr) - static_cast<std::time_t>(days) * 86400;
  std::tm out{};
  ::gmtime_r(&t, &out);
  return fmt::format("{:04d}-{:02d}-{:02d}T{:02d}:{:02d}:{:02d}.000Z", out.tm_year + 1900,
                     out.tm_mon + 1, out.tm_mday, out.tm_hour, out.tm_min, out.tm_sec);
}

NamedCause NameOf(const calibration::ExplainedCause& c, std::string over) {
  NamedCause n;
  n.over = std::move(over);
  n.name = c.cause.name;
  n.parameter = c.cause.parameter;
  const double scale = c.cause.scale ? 1e6 : c.cause.angle ? 1e3 : 1.0;
  n.unit = c.cause.scale ? "ppm" : c.cause.angle ? "mrad" : "mm";
  n.size = c.size * scale;
  n.sigma = c.sigma * scale;
  n.explained = c.explained;
  n.effect_max_mm = c.effect_max_mm;
  n.effect_mean_mm = c.effect_mean_mm;
  n.equivalent = c.equivalent;
  return n;
}

// The non-geometric terms a set of this --params estimates: the only terms that may be
// named as causes (nullopt: the spec cannot be read, every term).
std::optional<std::vector<int>> TermsOf(const calibration::RobotModel& model,
                                        const std::string& params_spec) {
  try {
    std::vector<int> terms;
    for (int k : calibration::ParseParameterSpec(model, params_spec)) {
      if (k >= model.num_geometric()) terms.push_back(k);
    }
    return terms;
  } catch (const std::invalid_argument&) {
    return std::nullopt;
  }
}

// The active set's error per coordinate out of sample: what a session of the same robot
// shows against it (its validation rms over three coordinates).
double SetSigmaMm(const db::StoredCalibration& c) {
  if (std::isfinite(c.validation_rms_mm) && c.validation_rms_mm > 0)
    return c.validation_rms_mm / std::sqrt(3.0);
  // Sets stored without their rms: a 3-D error distance's rms is about 1.13 × its mean.
  if (std::isfinite(c.validation_mean_mm) && c.validation_mean_mm > 0)
    return 1.13 * c.validation_mean_mm / std::sqrt(3.0);
  return 0.01;
}


namespace {

// "calibration,test": the kinds a night fits, as --kinds names them.
std::string KindsText(const std::vector<db::SessionKind>& kinds) {
  std::string text;
  for (const auto kind : kinds) text += (text.empty() ? "" : ",") + std::string(db::ToString(kind));
  return text;
}

// A wall-clock time of $TZ as the instant it names. A time the clocks skipped (the hour
// daylight saving time begins) names none and one they passed twice (the hour it ends) two:
// both are refused, with the offsets that make them exact, rather than read as mktime
// guesses.
template <typename Fail>
std::time_t LocalTimeToUtc(const std::tm& wall, const Fail& fail) {
  std::vector<std::pair<std::time_t, long>> readings;  // the instant and its UTC offset (s)
  for (const int dst : {0, 1}) {
    std::tm t = wall;
    t.tm_isdst = dst;
    const std::time_t at = std::mktime(&t);
    std::tm back{};
    if (!::localtime_r(&at, &back)) continue;
    const bool same = back.tm_year == wall.tm_year && back.tm_mon == wall.tm_mon &&
                      back.tm_mday == wall.tm_mday && back.tm_hour == wall.tm_hour &&
                      back.tm_min == wall.tm_min && back.tm_sec == wall.tm_sec;
    const bool seen = std::any_of(readings.begin(), readings.end(),
                                  [&](const auto& r) { return r.first == at; });
    if (same && !seen) readings.emplace_back(at, back.tm_gmtoff);
  }
  auto offset = [](long seconds) {
    const long minutes = std::labs(seconds) / 60;
    return fmt::format("{}{:02d}:{:02d}", seconds < 0 ? '-' : '+', minutes / 60, minutes % 60);
  };
  const char* tz = std::getenv("TZ");
  const std::string zone = fmt::format("TZ={}", tz ? tz : "(unset)");
  if (readings.empty()) {
    throw fail(fmt::format("this local time ({}) does not exist: the clocks skipped it (daylight "
                           "saving time began); give the time in UTC (…Z) or with its offset",
                           zone));
  }
  if (readings.size() > 1) {
    std::sort(readings.begin(), readings.end());
    throw fail(fmt::format("this local time ({}) happened twice: the clocks went back over it "
                           "(daylight saving time ended); give its offset, {} for the first or "
                           "{} for the second",
                           zone, offset(readings[0].second), offset(readings[1].second)));
  }
  return readings.front().first;
}

}  // namespace

std::string SinceToUtc(const std::string& text) {
  auto fail = [&](const std::string& why) -> InputError {
    return InputError({"--since", 0, 0, ""}, Quoted(text) + ": " + why);
  };
  std::string why;
  const std::optional<io::IsoDateTime> t = io::ParseIsoDateTime(text, &why);
  if (!t) throw fail(why);
  std::tm tm{};
  tm.tm_year = t->year - 1900;
  tm.tm_mon = t->month - 1;
  tm.tm_mday = t->day;
  tm.tm_hour = t->hour;
  tm.tm_min = t->minute;
  tm.tm_sec = t->second;
  // Z or an offset: that many seconds east of UTC; none: the local time of $TZ.
  const std::time_t utc =
      t->zone.empty() ? LocalTimeToUtc(tm, fail) : ::timegm(&tm) - t->offset_s;
  std::tm out{};
  if (!::gmtime_r(&utc, &out)) throw fail("not a time this system can represent");
  const std::string bound =
      fmt::format("{:04d}-{:02d}-{:02d}T{:02d}:{:02d}:{:02d}.{:03d}Z", out.tm_year + 1900,
                  out.tm_mon + 1, out.tm_mday, out.tm_hour, out.tm_min, out.tm_sec,
                  t->milliseconds);
  const char* tz = std::getenv("TZ");
  spdlog::debug("recalibrate: --since {} ({}) = {}", text,
                t->zone.empty() ? fmt::format("local time, TZ={}", tz ? tz : "(unset)")
                : t->zone == "Z" ? std::string("UTC")
                                 : "UTC" + t->zone,
                bound);
  return bound;
}



void NightlyJob::OpenAndLock() {
  database_.emplace(options_.db_path, db::OpenMode::kMustExist);
  const auto robot_id = db::FindRobotInUse(*database_, options_.robot);  // a removed one: refused
  if (!robot_id) {
    throw InputError({options_.db_path, 0, 0, "--robot"},
                     workflows::UnknownRobotMessage(*database_, options_.robot));
  }
  robot_id_ = *robot_id;
  // One run per robot at a time (the lock guards the robot's versions); other robots of
  // the same store recalibrate in parallel (`armsig worker --jobs N`). SQLite: a file lock
  // beside the file; PostgreSQL: an advisory lock of the server, whatever machine runs it.
  if (database_->backend() == db::Backend::kPostgres)
    server_lock_.emplace(database_->connection(), "recalibrate", options_.robot, options_.lock_wait_s);
  else
    file_lock_.emplace(workflows::RobotLockPath(options_.db_path, options_.robot), options_.lock_wait_s);
}

// What the run decides on is read from one snapshot (a capture or a push may write
// meanwhile): the model, the gates, the sessions and poses, the stored sets.
void NightlyJob::ReadInputs() {
  db::ReadSnapshot snapshot(*database_);
  model_ = io::ParseRobotModel(db::RobotModelYaml(*database_, robot_id_),
                               "model of robot " + options_.robot);
  workflows::ParamsOf(model_, options_.params);  // a typo in --params is refused before any data is read
  gates_ = LoadGates(*database_, robot_id_, options_);
  spdlog::debug(
      "recalibrate: gates: validation mean <= {} mm, max <= {} mm, tolerance {} mm, drift {} mm "
      "/ {} sigma; window: {} sessions, {} days",
      gates_.max_mean_mm, gates_.max_max_mm, gates_.tolerance_mm, gates_.drift_mm,
      gates_.drift_sigma, gates_.window_sessions, gates_.window_days);
  history_ = db::CalibrationHistory(*database_, robot_id_);
  for (const auto& c : history_) {
    if (c.active) current_ = c;
  }
  // The first session the active set allows: the change point it was fitted after.
  if (current_) {
    const auto inputs = nlohmann::json::parse(current_->inputs_json, nullptr, false);
    if (inputs.is_object() && inputs.contains("floor_session") &&
        inputs["floor_session"].is_number_integer()) {
      decision_.floor_session = inputs["floor_session"].get<int64_t>();
      if (inputs.contains("floor_started_at") && inputs["floor_started_at"].is_string())
        floor_started_at_ = inputs["floor_started_at"].get<std::string>();
    }
  }
  decision_.controller_calibration = acquisition::ControllerCalibrationChange(*database_, robot_id_);
  if (!decision_.controller_calibration.empty())
    spdlog::warn("recalibrate: robot {}: {}", options_.robot, decision_.controller_calibration);
  SelectWindow(db::ListSessions(*database_, robot_id_),
               db::LoadRobotPoses(*database_, robot_id_, since_));
}

// The sessions the night may use, oldest first: not discarded, at or after --since and
// the active set's change point, with enough usable configurations to place their frame,
// then the newest `window_sessions` started within `window_days`.
void NightlyJob::SelectWindow(const std::vector<db::SessionSummary>& sessions,
                              std::vector<MeasuredPose> poses) {
  std::map<int64_t, std::vector<MeasuredPose>> by_session;
  for (auto& p : poses) by_session[p.frame].push_back(std::move(p));
  std::vector<WindowSession> candidates;
  for (const auto& s : sessions) {
    if (!since_.empty() && s.started_at < since_) continue;
    if (s.state == db::SessionState::kAborted) {
      Log(fmt::format("session {} is discarded ({}): left out", s.id, s.note));
      continue;
    }
    if (s.state == db::SessionState::kRunning && s.owner &&
        acquisition::StateOf(*s.owner) != acquisition::OwnerState::kGone) {
      Log(fmt::format("session {} is still being captured (process {} on {}): left out until "
                      "it is finished",
                      s.id, s.owner->pid, s.owner->host));
      continue;
    }
    // Before the change point in the order the store gave the sessions their ids (a capture
    // machine's clock may be wrong; the store's sequence is not).
    if (decision_.floor_session && s.id < *decision_.floor_session) {
      spdlog::debug("recalibrate: session {} is from before the change at session {}: left out",
                    s.id, *decision_.floor_session);
      continue;
    }
    auto it = by_session.find(s.id);
    if (it == by_session.end()) continue;  // no usable configuration
    const size_t distinct = static_cast<size_t>(calibration::DistinctConfigurations(it->second));
    if (distinct < kMinPosesPerSession) {
      spdlog::warn(
          "recalibrate: {}: session {} has {} distinct usable configuration{} ({} poses): too "
          "few to place its measurement frame ({} needed); left out",
          options_.robot, s.id, distinct, distinct == 1 ? "" : "s", it->second.size(),
          kMinPosesPerSession);
      continue;
    }
    if (std::find(options_.kinds.begin(), options_.kinds.end(), s.kind) == options_.kinds.end()) {
      spdlog::debug("recalibrate: session {} is a {} session: not fitted (--kinds {})", s.id,
                    db::ToString(s.kind), KindsText(options_.kinds));
      elsewhere_.push_back({s, std::move(it->second)});
      continue;
    }
    candidates.push_back({s, std::move(it->second)});
  }
  // Oldest first in the order the store sequenced them, not by the capture machines' clocks:
  // one session stamped 2031 by a wrong clock would stay "the newest" and hide every change
  // after it ("a later session agrees"). A start time later than this machine's clock is
  // said.
  std::sort(candidates.begin(), candidates.end(),
            [](const auto& a, const auto& b) { return a.summary.id < b.summary.id; });
  const std::string tomorrow = DaysAgoUtc(-1);
  for (const auto& w : candidates) {
    if (w.summary.started_at > tomorrow) {
      Log(fmt::format("session {} says it started at {}, after this machine's clock: the clock "
                      "of the machine that captured it was wrong; it is taken in the order it "
                      "was stored",
                      w.summary.id, w.summary.started_at));
    }
  }
  if (gates_.window_days > 0) {
    const std::string cutoff = DaysAgoUtc(gates_.window_days);
    std::erase_if(candidates, [&](WindowSession& w) {
      const bool old = w.summary.started_at < cutoff;
      if (old) {
        spdlog::debug("recalibrate: session {} started more than {} days ago: outside the window",
                      w.summary.id, gates_.window_days);
        elsewhere_.push_back(std::move(w));
      }
      return old;
    });
  }
  if (gates_.window_sessions > 0 && candidates.size() > static_cast<size_t>(gates_.window_sessions)) {
    const size_t drop = candidates.size() - gates_.window_sessions;
    spdlog::debug("recalibrate: {} older session{} outside the window of the newest {}", drop,
                  drop == 1 ? "" : "s", gates_.window_sessions);
    for (size_t k = 0; k < drop; ++k) elsewhere_.push_back(std::move(candidates[k]));
    candidates.erase(candidates.begin(), candidates.begin() + static_cast<std::ptrdiff_t>(drop));
  }
  window_ = std::move(candidates);
  decision_.window_sessions = gates_.window_sessions;
  decision_.window_days = gates_.window_days;
}


// What the night fits: the sessions after a change alone, else the window less its
// outliers.
std::vector<MeasuredPose> NightlyJob::FitInput() const {
  std::set<int64_t> use;
  if (decision_.change) {
    use.insert(decision_.change->after.begin(), decision_.change->after.end());
  } else {
    for (const auto& w : window_) use.insert(w.summary.id);
    for (const auto& v : decision_.tested) {
      if (v.outlier) use.erase(v.session);
    }
  }
  std::vector<MeasuredPose> poses;
  for (const auto& w : window_) {
    if (use.count(w.summary.id)) poses.insert(poses.end(), w.poses.begin(), w.poses.end());
  }
  return poses;
}

// Idempotence on content: a stored set was already fitted on exactly these measurements
// with these options, however they were asked for. The active one first; else the newest
// other one (after `activate` chose another set: the night does not undo it).
bool NightlyJob::UpToDate(const std::string& digest) {
  const db::StoredCalibration* same = nullptr;
  for (auto it = history_.rbegin(); it != history_.rend(); ++it) {
    if (StoredDigest(*it) != digest) continue;
    spdlog::debug("recalibrate: version {}{} has this digest", it->version,
                  it->active ? " (active)" : "");
    if (it->active || !same) same = &*it;
    if (it->active) break;
  }
  if (!same) return false;
  decision_.outcome = RecalibrationDecision::Outcome::kUpToDate;
  decision_.version = same->version;
  if (current_ && current_->version != same->version) {
    const auto activations = db::ActivationHistory(*database_, robot_id_);
    for (auto a = activations.rbegin(); a != activations.rend(); ++a) {
      if (a->version != current_->version) continue;
      decision_.active_chosen_by = a->activated_by;
      decision_.active_chosen_at = a->activated_at;
      break;
    }
  }
  Log(decision_.Describe());
  return true;
}

void NightlyJob::Fit(const std::vector<MeasuredPose>& poses) {
  const std::set<int64_t> sessions(decision_.sessions.begin(), decision_.sessions.end());
  settings_.params = options_.params;
  settings_.model_subset = true;
  settings_.residual_model = options_.residual_model;
  settings_.orientation = options_.orientation;
  settings_.tool_rotation = options_.tool_rotation;
  settings_.max_iterations = options_.max_iterations;
  settings_.stop = core::StopToken(options_.stop);
  // 60 %, at most 2,000 (the residual map trains on up to that many). It was at most 80,
  // the paper's count, while the model was parametric only; the map's joint curves need
  // the poses: on the UR10 (eight nights of series C) the nightly validation mean falls from
  // 0.21–0.25 to 0.09–0.10 mm, with no false alarm and the planted changes named as before
  // (docs/how-to/nightly-job.md).
  const size_t most = 2000;
  settings_.select =
      options_.select > 0
          ? options_.select
          : static_cast<int>(std::min<size_t>(most, std::max<size_t>(poses.size() * 6 / 10, 10)));
  Log(fmt::format("{} configurations from {}: fitting {} ({}), validating on the rest",
                  poses.size(), SessionList(decision_.sessions), settings_.select, options_.params));
  run_.emplace(RunCalibration(model_, poses, {}, settings_));
  const workflows::CalibrationRun& run = *run_;
  if (run.residual_map) {  // the nightly log is where this run says it (once)
    Log(fmt::format("residual map {}: {}", run.residual_map->used ? "used" : "not used",
                    run.residual_map->decision));
  }
  const std::set<std::string> fit_ids(run.fit_pose_ids.begin(), run.fit_pose_ids.end());
  const std::set<std::string> validation_ids(run.validation_pose_ids.begin(),
                                             run.validation_pose_ids.end());
  for (const auto& p : poses) {
    if (fit_ids.count(p.id)) fit_.push_back(p);
    if (validation_ids.count(p.id)) validation_.push_back(p);
  }
  decision_.validation = workflows::StatsOf(run.validation_residuals);
  const nlohmann::json calibration_json = CalibrationJson(model_, run);
  decision_.residual_model = calibration_json["residual_model"];
  const auto orientation_of = [&](const char* part) {
    const auto it = calibration_json.find(part);
    return it != calibration_json.end() && it->is_object()
               ? it->value("orientation", nlohmann::json())
               : nlohmann::json();
  };
  decision_.fit_orientation = orientation_of("fit");
  decision_.validation_orientation = orientation_of("validation");
  decision_.fit = run.estimate.fit;
  decision_.nominal = run.estimate.nominal;
  decision_.rank = run.estimate.identifiability.rank;
  spdlog::debug(
      "recalibrate: fit {} ({} iterations): rank {}, sigma0 {:.4f} mm, fit mean {:.4f} mm; "
      "validation mean {:.4f} mm, max {:.4f} mm on {} configurations",
      run.estimate.status.ok() ? "converged" : "NOT converged", run.estimate.iterations, decision_.rank,
      run.estimate.sigma0_mm, decision_.fit.mean_mm, decision_.validation.mean_mm, decision_.validation.max_mm,
      decision_.validation.poses);
  pass_ = run.estimate.status.ok();
  // An estimate the solver did not finish is judged by nothing: no gate, no drift.
  if (!pass_) {
    Log(fmt::format("the fit did not give a usable estimate ({}): no gate and no drift judged",
                    run.estimate.status.message));
  }
}

void NightlyJob::Gate(const std::string& name, double value, double limit) {
  if (!run_->estimate.status.ok()) return;
  const bool ok = value <= limit;
  decision_.gates.push_back({name, value, limit, ok});
  Log(fmt::format("{}: {:.4f} mm (limit {:.4f} mm) {}", name, value, limit,
                  ok ? "passed" : "FAILED"));
  pass_ = pass_ && ok;
}

void NightlyJob::JudgeGates() {
  Gate("validation mean", decision_.validation.mean_mm, gates_.max_mean_mm);
  Gate("validation max", decision_.validation.max_mm, gates_.max_max_mm);
  if (!run_->estimate.usable()) return;
  // A set that moves a link by centimetres or tilts an axis by degrees fits *some* data, not
  // this robot in these units: refused whatever its validation says.
  const auto implausible = calibration::ImplausibleParameters(
      model_, run_->estimate.params, run_->estimate.identifiability.identified);
  if (implausible.empty()) return;
  std::string values;
  for (size_t k = 0; k < implausible.size() && k < 3; ++k)
    values += (k ? "; " : "") + implausible[k].Describe();
  if (implausible.size() > 3) values += fmt::format("; {} more", implausible.size() - 3);
  decision_.refusals.push_back("not this robot or not these units (another robot's data, another tool, "
                        "radians read as degrees, metres as millimetres?): " + values);
  Log("REFUSED: " + decision_.refusals.back());
  pass_ = false;
}


void NightlyJob::Store(const nlohmann::json& inputs) {
  const workflows::CalibrationRun& run = *run_;
  const nlohmann::json options = {{"select", settings_.select},
                                  {"params", options_.params},
                                  {"gates",
                                   {{"max_mean_mm", gates_.max_mean_mm},
                                    {"max_max_mm", gates_.max_max_mm},
                                    {"tolerance_mm", gates_.tolerance_mm},
                                    {"drift_sigma", gates_.drift_sigma},
                                    {"drift_mm", gates_.drift_mm}}},
                                  {"window",
                                   {{"sessions", gates_.window_sessions},
                                    {"days", gates_.window_days}}}};
  db::CalibrationRecord record =
      CalibrationRecordOf(model_, run, robot_id_, inputs, options, true);
  std::string note = fmt::format("validation mean {:.4f} mm on {} configurations",
                                 decision_.validation.mean_mm, decision_.validation.poses);
  if (decision_.change) {
    note += fmt::format("; drift: changed from session {}", *decision_.change->from_session);
    if (!decision_.change->causes.empty()) note += ": " + decision_.change->causes.front().Describe();
  } else if (decision_.drift) {
    note += "; drift flagged";
    if (!decision_.causes.empty()) note += ": " + decision_.causes.front().Describe();
  }
  decision_.outcome = decision_.drift ? RecalibrationDecision::Outcome::kDriftStored
                        : RecalibrationDecision::Outcome::kStored;
  db::WriteTransaction tx(*database_);
  const auto [id, version] = db::InsertCalibration(*database_, record);
  decision_.version = version;
  // The drift decision names the version it made: written once the version is known.
  if (decision_.previous_version) db::SetDriftJson(*database_, id, JsonText(decision_.DriftJson()));
  db::RecordActivation(*database_, robot_id_,
                       {decision_.version, decision_.previous_version, "", "recalibrate", note});
  tx.commit();
}

void NightlyJob::AddDecision(report::ReportInput& input) const {
  input.drift = decision_.drift;
  input.drift_line = decision_.DriftLine();
  for (const auto& v : decision_.tested) {
    input.window.push_back({v.session, v.started_at, v.poses, v.mean_mm, v.effect_max_mm,
                            v.p_value, v.disagrees, v.outlier});
  }
  for (const auto& c : decision_.change ? decision_.change->causes : decision_.causes)
    input.causes.push_back(c.Describe());
}

void NightlyJob::WriteDecisionOnlyReport() {
  report::ReportInput input;
  input.robot = options_.robot;
  input.version = 0;
  input.decision = decision_.Describe();
  input.armsig_version = ARMSIG_VERSION;
  db::ReadSnapshot report_snapshot(*database_);
  input.history = report::ReportHistoryOf(*database_, robot_id_);
  input.drift_history = report::ReportDriftOf(*database_, model_, robot_id_, gates_.drift_mm);
  if (current_) {
    input.previous_version = current_->version;
    input.previous_params_spec = current_->params_spec;
  }
  AddDecision(input);
  decision_.report_path = WriteDecisionReport(options_.report_dir, input);
  Log("report: " + decision_.report_path);
}

void NightlyJob::WriteRunReport() {
  const workflows::CalibrationRun& run = *run_;
  report::ReportInput input;
  input.robot = options_.robot;
  input.version = decision_.version;
  input.decision = decision_.Describe();
  for (const auto& g : decision_.gates) {
    input.gates.push_back(fmt::format("{}: {:.4f} mm (limit {:.4f} mm) {}", g.name, g.value_mm,
                                      g.limit_mm, g.passed ? "passed" : "FAILED"));
  }
  input.model = &model_;
  input.run = &run;
  input.validation = validation_;
  input.armsig_version = ARMSIG_VERSION;
  db::ReadSnapshot report_snapshot(*database_);  // the report's reads agree with each other
  input.sources = report::LoadReportSources(*database_, run);
  {
    std::vector<int64_t> sessions;
    for (const auto& s : input.sources.sessions) sessions.push_back(s.id);
    input.temperature_c = db::PoseTemperatures(*database_, sessions);
  }
  input.history = report::ReportHistoryOf(*database_, robot_id_);
  input.drift_history = report::ReportDriftOf(*database_, model_, robot_id_, gates_.drift_mm);
  if (decision_.version == 0 && current_) {
    // This run, not stored: against the active set, as its drift decision was taken.
    const calibration::FittedSet now{run.estimate.params, run.estimate.identifiability.identified,
                                     run.estimate.covariance};
    report::ReportDriftPoint point = report::DriftPointOf(
        model_, FittedSetOf(model_, workflows::SignatureOf(model_, *current_), *current_), now,
        compared_.empty() ? spread_ : compared_);
    point.version = 0;
    point.against = current_->version;
    point.drift = decision_.drift;
    input.drift_history.points.push_back(point);
  }
  if (decision_.version == 0) {
    report::ReportHistoryPoint rejected{0, "this run (rejected)", decision_.validation.mean_mm, run.params_spec,
                                false};
    rejected.drift = decision_.drift;
    input.history.push_back(rejected);
  }
  if (current_) {
    input.previous_version = current_->version;
    input.previous_params_spec = current_->params_spec;
  }
  input.changes = changes_;
  AddDecision(input);
  if (decision_.model_drift) {
    const auto& m = *decision_.model_drift;
    input.changes_note = fmt::format(
        "{}: against version {}, the positions the two models predict over {} configurations "
        "spread over the work volume differ by up to {:.3f} mm (mean {:.3f} mm) after aligning "
        "bases; chi2 {:.1f} on {} degrees of freedom ({}); drift needs p < 0.001 and "
        "more than {:.3f} mm. Parameter changes are shown in one gauge (the rigid part of the "
        "two base alignments removed).",
        decision_.drift ? "DRIFT" : "No drift", *decision_.previous_version, m.configurations, m.max_mm,
        m.mean_mm, m.chi2, m.dof, PValueText(m.p_value), m.tolerance_mm);
  }
  decision_.report_path = WriteReport(options_.report_dir, input);
  Log("report: " + decision_.report_path);
}

RecalibrationDecision NightlyJob::Run() {
  // Everything the run will write is checked before anything is stored.
  since_ = options_.since.empty() ? std::string() : SinceToUtc(options_.since);
  if (!options_.json_path.empty()) io::CheckOutputFile(options_.json_path, "--json");
  if (!options_.report_dir.empty()) io::CheckOutputDirectory(options_.report_dir, "--report");
  OpenAndLock();
  ReadInputs();
  decision_.robot = options_.robot;
  if (current_) decision_.previous_version = current_->version;
  spread_ = calibration::SpreadConfigurations(model_, kDriftConfigurations);
  TestAgainstActive();
  if (decision_.change && decision_.change->poses_after < decision_.change->poses_needed) {
    // Too few configurations since the change for a fit of their own; a fit reaching back
    // before it would blend two robots.
    decision_.outcome = RecalibrationDecision::Outcome::kDriftSuspected;
    decision_.drift = true;
    decision_.poses = decision_.change->poses_after;
    decision_.sessions = decision_.change->after;
    Log(decision_.Describe());
    if (!options_.report_dir.empty()) {
      report::RemoveReportDebris(options_.report_dir, 0.0);  // this run holds the robot's lock
      WriteDecisionOnlyReport();  // nothing stored: a report that fails is the run's failure
    }
    return decision_;
  }
  const std::vector<MeasuredPose> poses = FitInput();
  decision_.poses = static_cast<int>(poses.size());
  {
    std::set<int64_t> sessions;
    for (const auto& p : poses) sessions.insert(p.frame);
    decision_.sessions.assign(sessions.begin(), sessions.end());
  }
  const std::string digest =
      InputDigest(poses,
                  options_.params + "|residual-model=" + options_.residual_model +
                      // Said only when it is not the default, so that the digests of the
                      // sets stored before orientations were fitted stay what they were.
                      (options_.orientation == "auto" ? "" : "|orientation=" + options_.orientation) +
                      (options_.tool_rotation == "per-session" ? "" : "|tool-rotation=" + options_.tool_rotation),
                  options_.select);
  input_poses_ = poses.size();
  nlohmann::json inputs = {{"digest", digest},         {"poses", poses.size()},
                           {"sessions", decision_.sessions},  {"since", since_},
                           {"params", options_.params},      {"select", options_.select},
                           {"residual_model", options_.residual_model},
                           {"orientation", options_.orientation},
                           {"tool_rotation", options_.tool_rotation}};
  // The change point the set was fitted after (a new one, or the active set's): the
  // windows of the nights after it never reach back before it.
  if (decision_.change) {
    inputs["floor_session"] = *decision_.change->from_session;
    inputs["floor_started_at"] = decision_.change->from_started_at;
  } else if (decision_.floor_session) {
    inputs["floor_session"] = *decision_.floor_session;
    inputs["floor_started_at"] = floor_started_at_;
  }
  spdlog::debug("recalibrate: inputs: {} poses from sessions {}, --params {} --select {}: digest {}",
                poses.size(), JsonText(nlohmann::json(decision_.sessions)), options_.params, options_.select, digest);
  if (!options_.force && UpToDate(digest)) {
    // A report the night that stored the set could not write is written now.
    if (!options_.report_dir.empty() && !report::HasReportOf(options_.report_dir, options_.robot, decision_.version))
      WriteOutput([&] {
        decision_.report_path = report::WriteStoredReport(*database_, options_.robot, decision_.version, options_.report_dir).path;
        Log(fmt::format("report of version {}: {}", decision_.version, decision_.report_path));
      });
    return decision_;
  }
  if (options_.force) spdlog::debug("recalibrate: --force: refitting whatever is stored");
  if (poses.size() < 20) {
    throw InputError(
        {options_.db_path, 0, 0, "--robot"},
        fmt::format("robot {} has {} measured configurations{} in its window; a recalibration "
                    "needs at least 20 (some to fit, the rest to validate); {} lists its sessions",
                    options_.robot, poses.size(), since_.empty() ? "" : " since " + since_,
                    workflows::Hint(database_->path(), {"sessions", "--robot", options_.robot})));
  }
  auto stopped = [&] {
    if (!options_.stop || !options_.stop->load()) return false;
    decision_.stopped = true;
    Log("stopped before storing anything: the same command fits again");
    return true;
  };
  if (stopped()) return decision_;
  // The fit and the judges stop within a solver iteration, a selection step or a
  // cross-validation when asked (core::Stopped), before anything is stored.
  try {
    Fit(poses);
    JudgeGates();
    CompareWithActive();
    TryElsewhere();
  } catch (const core::Stopped&) {
  }
  if (stopped()) return decision_;
  if (pass_) {
    Store(inputs);
  } else if (!run_->estimate.status.ok()) {
    // No gate can judge an estimate the solver did not finish.
    decision_.outcome = RecalibrationDecision::Outcome::kFailed;
    decision_.failure = fmt::format("the fit did not give a usable estimate: {}",
                             run_->estimate.status.message);
  } else {
    decision_.outcome = RecalibrationDecision::Outcome::kRejected;
  }
  Log(decision_.Describe());
  if (!options_.report_dir.empty()) {
    // This run holds the robot's lock: temporary files in its report folder are a stopped
    // run's.
    report::RemoveReportDebris(options_.report_dir, 0.0);
    if (decision_.version > 0)
      WriteOutput([&] { WriteRunReport(); });
    else
      WriteRunReport();  // nothing stored: a report that fails is the run's failure
  }
  return decision_;
}

// An output that can only follow the commit: its failure is said with the stored version
// and the command that writes it later, not taken for the run's.
void NightlyJob::WriteOutput(const std::function<void()>& write) {
  try {
    write();
  } catch (const std::exception& e) {
    decision_.output_error = fmt::format(
        "version {} is stored, but its report could not be written to {}: {}; write it with "
        "{} (or run the job again)",
        decision_.version, options_.report_dir, e.what(),
        workflows::Hint(database_->path(), {"report", "--robot", options_.robot, "--set",
                                 std::to_string(decision_.version), "--out", options_.report_dir}));
    spdlog::error("recalibrate: {}: {}", options_.robot, decision_.output_error);
  }
}


RecalibrationDecision Recalibrate(const RecalibrateOptions& options) {
  return NightlyJob(options).Run();
}

}  // namespace armsig::nightly
