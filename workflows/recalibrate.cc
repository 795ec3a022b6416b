#include "workflows/recalibrate.h"

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
#include "workflows/calibration_run.h"
#include "workflows/hint.h"
#include "workflows/report.h"
#include "workflows/signature.h"
#include "workflows/stored_report.h"

namespace armsig::workflows {

namespace {

struct Gates {
  double max_mean_mm = 0.5, max_max_mm = 2.0, tolerance_mm = 0.02, drift_sigma = 5.0,
         drift_mm = kDefaultDriftMm;
  int window_sessions = kDefaultWindowSessions, window_days = kDefaultWindowDays;
};

constexpr int kDriftConfigurations = 50;     // spread over the work volume, the same every night
constexpr size_t kMinPosesPerSession = 3;    // to place a session's measurement frame
// A session the new set is tried on before activation needs enough configurations for its
// own frame's six degrees of freedom to leave a meaningful mean; the new set may be worse
// there than the reference by this share (and the tolerance in mm) before it is refused.
constexpr size_t kMinElsewherePoses = 10;
// A session is tested against the active set on its configurations inside the set's support
// (its terms' arcs, its map's); with fewer than this there, it is not tested. Six: their 18
// coordinates leave 12 beyond the six unknowns of the session's own frame, twice as many.
constexpr size_t kMinJudgedPoses = 6;
constexpr double kElsewhereTolerance = 0.05;

constexpr double kDriftSignificance = 1e-3;  // p-value below which two sets differ

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

nlohmann::json Stats(const calibration::ErrorStats& s) {
  return {{"poses", s.poses}, {"mean_mm", s.mean_mm}, {"max_mm", s.max_mm}, {"rms_mm", s.rms_mm}};
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

bool LeapYear(int y) { return (y % 4 == 0 && y % 100 != 0) || y % 400 == 0; }

int DaysInMonth(int year, int month) {
  static constexpr int kDays[12] = {31, 28, 31, 30, 31, 30, 31, 31, 30, 31, 30, 31};
  return month == 2 && LeapYear(year) ? 29 : kDays[month - 1];
}

}  // namespace

namespace {

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
  static const std::regex iso(
      R"(^(\d{4})-(\d{2})-(\d{2})(?:[T ](\d{2}):(\d{2})(?::(\d{2})(?:\.(\d+))?)?(Z|([+-])(\d{2})(?::?(\d{2}))?)?)?$)");
  auto fail = [&](const std::string& why) -> InputError {
    return InputError({"--since", 0, 0, ""}, Quoted(text) + ": " + why);
  };
  std::smatch m;
  if (!std::regex_match(text, m, iso)) {
    throw fail(
        "expected an ISO 8601 date or date and time, e.g. 2026-11-01, 2026-11-01T02:30 (local "
        "time), 2026-11-01T02:30:00Z (UTC) or 2026-11-01T02:30+01:00");
  }
  auto number = [&](int group) { return m[group].matched ? std::stoi(m[group].str()) : 0; };
  const int year = number(1), month = number(2), day = number(3);
  const int hour = number(4), minute = number(5), second = number(6);
  if (month < 1 || month > 12) throw fail(fmt::format("there is no month {:02d}", month));
  if (day < 1 || day > DaysInMonth(year, month)) {
    throw fail(fmt::format("{:04d}-{:02d} has {} days, there is no day {:02d}", year, month,
                           DaysInMonth(year, month), day));
  }
  if (hour > 23 || minute > 59 || second > 59)
    throw fail(fmt::format("{:02d}:{:02d}:{:02d} is no time of day", hour, minute, second));
  const int offset_hours = number(10), offset_minutes = number(11);
  if (offset_hours > 23 || offset_minutes > 59)
    throw fail(fmt::format("{} is no offset from UTC", m[8].str()));
  int milliseconds = 0;
  if (m[7].matched) milliseconds = std::stoi((m[7].str() + "00").substr(0, 3));
  std::tm tm{};
  tm.tm_year = year - 1900;
  tm.tm_mon = month - 1;
  tm.tm_mday = day;
  tm.tm_hour = hour;
  tm.tm_min = minute;
  tm.tm_sec = second;
  std::time_t utc = 0;
  if (m[8].matched) {  // Z or an offset: that many hours east of UTC
    const int sign = m[9].matched && m[9].str() == "-" ? -1 : 1;
    utc = ::timegm(&tm) - sign * (offset_hours * 3600 + offset_minutes * 60);
  } else {
    utc = LocalTimeToUtc(tm, fail);
  }
  std::tm out{};
  if (!::gmtime_r(&utc, &out)) throw fail("not a time this system can represent");
  const std::string bound =
      fmt::format("{:04d}-{:02d}-{:02d}T{:02d}:{:02d}:{:02d}.{:03d}Z", out.tm_year + 1900,
                  out.tm_mon + 1, out.tm_mday, out.tm_hour, out.tm_min, out.tm_sec, milliseconds);
  spdlog::debug("recalibrate: --since {} ({}) = {}", text,
                m[8].matched ? (m[8].str() == "Z" ? std::string("UTC") : "UTC" + m[8].str())
                             : fmt::format("local time, TZ={}", std::getenv("TZ") ? std::getenv("TZ")
                                                                                   : "(unset)"),
                bound);
  return bound;
}

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
  j["fit"] = Stats(fit);
  if (!fit_orientation.is_null()) j["fit"]["orientation"] = fit_orientation;
  j["nominal"] = Stats(nominal);
  j["validation"] = Stats(validation);
  if (!validation_orientation.is_null()) j["validation"]["orientation"] = validation_orientation;
  if (previous_on_same_data) j["current_on_same_data"] = Stats(*previous_on_same_data);
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

namespace {

// `text` cut to `keep` bytes and its fingerprint, when it is longer than that.
std::string Shortened(const std::string& text, size_t keep) {
  if (text.size() <= keep) return text;
  return text.substr(0, keep) + fmt::format("~{:016x}", core::Fnv1a64(text));
}

}  // namespace

std::string RobotLockPath(const std::string& db_path, const std::string& robot) {
  std::string name;
  for (unsigned char c : robot) {
    if (std::isalnum(c) || c == '-' || c == '_' || c == '.')
      name += static_cast<char>(c);
    else
      name += fmt::format("%{:02X}", c);
  }
  // The store's own file, whatever path named it (a symlink, a relative path, ./): two runs
  // on one store take one lock.
  std::error_code error;
  const std::filesystem::path real = std::filesystem::weakly_canonical(db_path, error);
  const std::filesystem::path store = error ? std::filesystem::path(db_path) : real;
  std::string file = store.filename().string() + ".recalibrate." + name + ".lock";
  // A file name has at most 255 bytes (NAME_MAX): a long store name beside a long robot name
  // (a 64-byte name is 192 bytes %-encoded) are cut and told apart by their fingerprints.
  constexpr size_t kNameMax = 255;
  if (file.size() > kNameMax) {
    file = Shortened(store.filename().string(), 100) + ".recalibrate." + Shortened(name, 80) +
           ".lock";
  }
  return (store.parent_path() / file).string();
}

namespace {

// A session the night may use, with its usable configurations.
struct WindowSession {
  db::SessionSummary summary;
  std::vector<MeasuredPose> poses;
};

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

// One night of the job, step by step: read the window, test its sessions against the
// active set, choose what to fit (never across a change), fit, judge, compare, store,
// report.
class NightlyJob {
 public:
  explicit NightlyJob(const RecalibrateOptions& options) : o_(options) {}
  RecalibrationDecision Run();

 private:
  void Log(const std::string& message) const {
    spdlog::info("recalibrate: {}: {}", o_.robot, message);
  }
  void OpenAndLock();
  void ReadInputs();
  void SelectWindow(const std::vector<db::SessionSummary>& sessions,
                    std::vector<MeasuredPose> poses);
  void TestAgainstActive();
  std::vector<MeasuredPose> FitInput() const;
  bool UpToDate(const std::string& digest);
  void Fit(const std::vector<MeasuredPose>& poses);
  void JudgeGates();
  void CompareWithActive();
  void TryElsewhere();
  void DriftConfigurations(const Signature& old);
  void Store(const nlohmann::json& inputs);
  void WriteRunReport();
  // A drift-suspected night's page: no fit, the decision and the window (report.h).
  void WriteDecisionOnlyReport();
  // The decision's part of a report: the drift line, its causes, the window tested.
  void AddDecision(ReportInput& input) const;
  void WriteOutput(const std::function<void()>& write);
  void Gate(const std::string& name, double value, double limit);

  const RecalibrateOptions& o_;
  std::string since_;
  std::optional<db::Database> database_;
  int64_t robot_id_ = 0;
  std::optional<io::FileLock> file_lock_;
  std::optional<db::RobotLock> server_lock_;
  calibration::RobotModel model_;
  Gates gates_;
  std::vector<WindowSession> window_;
  // Sessions of the robot the night does not fit (other kinds, outside the window) and that
  // are not from before a change: where a new set is tried before it becomes active.
  std::vector<WindowSession> elsewhere_;
  std::string floor_started_at_;
  std::vector<db::StoredCalibration> history_;
  std::optional<db::StoredCalibration> current_;
  size_t input_poses_ = 0;  // the poses this night fits and validates on
  std::vector<Eigen::VectorXd> spread_;
  // The configurations two sets are compared on: spread_, kept where both sets were fitted
  // (their terms' arcs), else the window's configurations there (DriftConfigurations).
  std::vector<Eigen::VectorXd> compared_;
  std::string compared_over_;
  // A window session lay outside the active set's support and was not tested against it.
  bool extended_ = false;
  RecalibrationDecision d_;
  std::optional<CalibrationRun> run_;
  CalibrateSettings settings_;
  std::vector<MeasuredPose> fit_, validation_;
  std::vector<calibration::ParameterChange> changes_;
  bool pass_ = false;
};

void NightlyJob::OpenAndLock() {
  database_.emplace(o_.db_path, db::OpenMode::kMustExist);
  const auto robot_id = db::FindRobotInUse(*database_, o_.robot);  // a removed one: refused
  if (!robot_id) {
    throw InputError({o_.db_path, 0, 0, "--robot"},
                     UnknownRobotMessage(*database_, o_.robot));
  }
  robot_id_ = *robot_id;
  // One run per robot at a time (the lock guards the robot's versions); other robots of
  // the same store recalibrate in parallel (`armsig worker --jobs N`). SQLite: a file lock
  // beside the file; PostgreSQL: an advisory lock of the server, whatever machine runs it.
  if (database_->backend() == db::Backend::kPostgres)
    server_lock_.emplace(database_->connection(), "recalibrate", o_.robot, o_.lock_wait_s);
  else
    file_lock_.emplace(RobotLockPath(o_.db_path, o_.robot), o_.lock_wait_s);
}

// What the run decides on is read from one snapshot (a capture or a push may write
// meanwhile): the model, the gates, the sessions and poses, the stored sets.
void NightlyJob::ReadInputs() {
  db::ReadSnapshot snapshot(*database_);
  model_ = io::ParseRobotModel(db::RobotModelYaml(*database_, robot_id_),
                               "model of robot " + o_.robot);
  ParamsOf(model_, o_.params);  // a typo in --params is refused before any data is read
  gates_ = LoadGates(*database_, robot_id_, o_);
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
      d_.floor_session = inputs["floor_session"].get<int64_t>();
      if (inputs.contains("floor_started_at") && inputs["floor_started_at"].is_string())
        floor_started_at_ = inputs["floor_started_at"].get<std::string>();
    }
  }
  d_.controller_calibration = acquisition::ControllerCalibrationChange(*database_, robot_id_);
  if (!d_.controller_calibration.empty())
    spdlog::warn("recalibrate: robot {}: {}", o_.robot, d_.controller_calibration);
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
    if (s.state == "aborted") {
      Log(fmt::format("session {} is discarded ({}): left out", s.id, s.note));
      continue;
    }
    if (s.state == "running" && s.owner &&
        acquisition::StateOf(*s.owner) != acquisition::OwnerState::kGone) {
      Log(fmt::format("session {} is still being captured (process {} on {}): left out until "
                      "it is finished",
                      s.id, s.owner->pid, s.owner->host));
      continue;
    }
    // Before the change point in the order the store gave the sessions their ids (a capture
    // machine's clock may be wrong; the store's sequence is not).
    if (d_.floor_session && s.id < *d_.floor_session) {
      spdlog::debug("recalibrate: session {} is from before the change at session {}: left out",
                    s.id, *d_.floor_session);
      continue;
    }
    auto it = by_session.find(s.id);
    if (it == by_session.end()) continue;  // no usable configuration
    const size_t distinct = static_cast<size_t>(calibration::DistinctConfigurations(it->second));
    if (distinct < kMinPosesPerSession) {
      spdlog::warn(
          "recalibrate: {}: session {} has {} distinct usable configuration{} ({} poses): too "
          "few to place its measurement frame ({} needed); left out",
          o_.robot, s.id, distinct, distinct == 1 ? "" : "s", it->second.size(),
          kMinPosesPerSession);
      continue;
    }
    if (std::find(o_.kinds.begin(), o_.kinds.end(), s.kind) == o_.kinds.end()) {
      spdlog::debug("recalibrate: session {} is a {} session: not fitted (--kinds {})", s.id,
                    s.kind, fmt::join(o_.kinds, ","));
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
  d_.window_sessions = gates_.window_sessions;
  d_.window_days = gates_.window_days;
}

// Every session of the window against the active set, its own measuring frame placed:
// where does the robot stop agreeing with it, and why?
void NightlyJob::TestAgainstActive() {
  if (!current_ || window_.empty()) return;
  const Signature old = SignatureOf(model_, *current_);
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
  std::set<int64_t> own;
  {
    const auto inputs = nlohmann::json::parse(current_->inputs_json, nullptr, false);
    if (inputs.is_object() && inputs.contains("sessions") && inputs["sessions"].is_array()) {
      for (const auto& id : inputs["sessions"]) {
        if (id.is_number_integer()) own.insert(id.get<int64_t>());
      }
    }
  }
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
      d_.tested.push_back(v);
      extended_ = true;
      continue;
    }
    if (inside.size() < w.poses.size()) {
      spdlog::debug("recalibrate: session {}: {} of {} configurations inside version {}'s "
                    "support are tested against it",
                    w.summary.id, inside.size(), w.poses.size(), current_->version);
    }
    const auto t = against(inside);
    SessionVerdict v;
    v.session = w.summary.id;
    v.started_at = w.summary.started_at;
    v.poses = t.poses;
    v.mean_mm = t.mean_mm;
    v.disagrees = t.poses > 0 && t.disagrees;
    v.p_value = t.p_value;
    v.effect_max_mm = t.effect_max_mm;
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
    d_.tested.push_back(v);
  }
  const auto point = calibration::LocateChange(disagrees);
  for (int i : point.outliers) {
    d_.tested[i].outlier = true;
    Log(fmt::format(
        "session {} disagrees with version {} (a change of up to {:.3f} mm) while a later "
        "session agrees: a set-up fault, not the robot; left out of this fit ({} keeps it out "
        "for good)",
        d_.tested[i].session, current_->version, d_.tested[i].effect_max_mm,
        Hint(database_->path(), {"session", "discard", std::to_string(d_.tested[i].session)})));
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
  d_.change = std::move(change);
  Log(fmt::format("the robot disagrees with version {} from session {} onwards ({} configurations)",
                  current_->version, *d_.change->from_session, d_.change->poses_after));
}

// What the night fits: the sessions after a change alone, else the window less its
// outliers.
std::vector<MeasuredPose> NightlyJob::FitInput() const {
  std::set<int64_t> use;
  if (d_.change) {
    use.insert(d_.change->after.begin(), d_.change->after.end());
  } else {
    for (const auto& w : window_) use.insert(w.summary.id);
    for (const auto& v : d_.tested) {
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
  d_.outcome = RecalibrationDecision::Outcome::kUpToDate;
  d_.version = same->version;
  if (current_ && current_->version != same->version) {
    const auto activations = db::ActivationHistory(*database_, robot_id_);
    for (auto a = activations.rbegin(); a != activations.rend(); ++a) {
      if (a->version != current_->version) continue;
      d_.active_chosen_by = a->activated_by;
      d_.active_chosen_at = a->activated_at;
      break;
    }
  }
  Log(d_.Describe());
  return true;
}

void NightlyJob::Fit(const std::vector<MeasuredPose>& poses) {
  const std::set<int64_t> sessions(d_.sessions.begin(), d_.sessions.end());
  settings_.params = o_.params;
  settings_.model_subset = true;
  settings_.residual_model = o_.residual_model;
  settings_.orientation = o_.orientation;
  settings_.tool_rotation = o_.tool_rotation;
  settings_.max_iterations = o_.max_iterations;
  settings_.stop = core::StopToken(o_.stop);
  // 60 %, at most 2,000 (the residual map trains on up to that many). It was at most 80,
  // the paper's count, while the model was parametric only; the map's joint curves need
  // the poses: on the UR10 (eight nights of series C) the nightly validation mean falls from
  // 0.21–0.25 to 0.09–0.10 mm, with no false alarm and the planted changes named as before
  // (docs/how-to/nightly-job.md).
  const size_t most = 2000;
  settings_.select =
      o_.select > 0
          ? o_.select
          : static_cast<int>(std::min<size_t>(most, std::max<size_t>(poses.size() * 6 / 10, 10)));
  Log(fmt::format("{} configurations from {}: fitting {} ({}), validating on the rest",
                  poses.size(), SessionList(d_.sessions), settings_.select, o_.params));
  run_.emplace(RunCalibration(model_, poses, {}, settings_));
  const CalibrationRun& run = *run_;
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
  d_.validation = StatsOf(run.validation_residuals);
  const nlohmann::json calibration_json = CalibrationJson(model_, run);
  d_.residual_model = calibration_json["residual_model"];
  const auto orientation_of = [&](const char* part) {
    const auto it = calibration_json.find(part);
    return it != calibration_json.end() && it->is_object()
               ? it->value("orientation", nlohmann::json())
               : nlohmann::json();
  };
  d_.fit_orientation = orientation_of("fit");
  d_.validation_orientation = orientation_of("validation");
  d_.fit = run.estimate.fit;
  d_.nominal = run.estimate.nominal;
  d_.rank = run.estimate.identifiability.rank;
  spdlog::debug(
      "recalibrate: fit {} ({} iterations): rank {}, sigma0 {:.4f} mm, fit mean {:.4f} mm; "
      "validation mean {:.4f} mm, max {:.4f} mm on {} configurations",
      run.estimate.status.ok() ? "converged" : "NOT converged", run.estimate.iterations, d_.rank,
      run.estimate.sigma0_mm, d_.fit.mean_mm, d_.validation.mean_mm, d_.validation.max_mm,
      d_.validation.poses);
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
  d_.gates.push_back({name, value, limit, ok});
  Log(fmt::format("{}: {:.4f} mm (limit {:.4f} mm) {}", name, value, limit,
                  ok ? "passed" : "FAILED"));
  pass_ = pass_ && ok;
}

void NightlyJob::JudgeGates() {
  Gate("validation mean", d_.validation.mean_mm, gates_.max_mean_mm);
  Gate("validation max", d_.validation.max_mm, gates_.max_max_mm);
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
  d_.refusals.push_back("not this robot or not these units (another robot's data, another tool, "
                        "radians read as degrees, metres as millimetres?): " + values);
  Log("REFUSED: " + d_.refusals.back());
  pass_ = false;
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
void NightlyJob::DriftConfigurations(const Signature& old) {
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
  if (d_.change) after.insert(d_.change->after.begin(), d_.change->after.end());
  calibration::RobotModel signed_model = model_;
  if (run_->validity) signed_model.term_support = run_->validity->term_arcs;
  std::optional<calibration::ResidualMap> new_map;
  if (run_->map_used()) new_map.emplace(run_->residual_map->map);
  std::optional<ActiveSignature> active;
  if (current_) active = LoadSignature(*database_, o_.robot, current_->version);
  for (const auto& w : elsewhere_) {
    // After a change the older sessions are another robot's: not a test of this one.
    if (d_.change && !after.count(w.summary.id)) continue;
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
                    e.session, w.summary.kind, ShortTime(w.summary.started_at), e.poses,
                    e.new_mean_mm, e.reference, e.reference_mean_mm,
                    e.held ? "holds" : "WORSE"));
    if (!e.held) {
      d_.refusals.push_back(fmt::format(
          "worse elsewhere: on session {} (not fitted; its frame placed on its {} "
          "configurations) the new set misses by {:.4f} mm on average, {} by {:.4f} mm",
          e.session, e.poses, e.new_mean_mm, e.reference, e.reference_mean_mm));
      pass_ = false;
    }
    d_.elsewhere.push_back(e);
  }
}

// The new set against the active one: on the same validation data (a gate), and by the
// positions both predict over the work volume (drift), the difference named by its causes.
void NightlyJob::CompareWithActive() {
  if (!current_ || !run_->estimate.status.ok()) return;
  // The current set on the same validation data, each session's base re-aligned on that
  // session's fit poses (the measuring frame moves between set-ups; the arm signature
  // does not), as the new fit placed each frame on them.
  const Signature old = SignatureOf(model_, *current_);
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
    d_.previous_on_same_data =
        StatsOf(MappedResiduals(model_, old_bases, old.params, old.map.get(), unseen));
    const calibration::ErrorStats now = StatsOf(now_residuals);
    spdlog::debug(
        "recalibrate: version {} on the same validation data ({} of {} configurations, the "
        "others trained its map; {} frames re-aligned): mean {:.4f} mm, max {:.4f} mm; the new "
        "set there: mean {:.4f} mm",
        current_->version, unseen.size(), validation_.size(), old_bases.size(),
        d_.previous_on_same_data->mean_mm, d_.previous_on_same_data->max_mm, now.mean_mm);
    Gate(fmt::format("not worse than version {} on the same data (+{:.3f} mm)", current_->version,
                     gates_.tolerance_mm),
         now.mean_mm, d_.previous_on_same_data->mean_mm + gates_.tolerance_mm);
  } else {
    spdlog::debug("recalibrate: version {} could not be placed in every frame: no comparison "
                  "on the same data",
                  current_->version);
  }
  // Drift: do the two models put the arm in different places, beyond what both fits'
  // uncertainty explains and by more than the tolerance?
  const CalibrationRun& run = *run_;
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
  const bool same_measurements = SameMeasurements(*current_, d_.sessions, input_poses_);
  d_.drift = (sets_differ && !extended_ && !same_measurements) || d_.change.has_value();
  d_.model_drift = m;
  if (sets_differ && same_measurements && !d_.change) {
    Log(fmt::format("the new set differs from version {} by up to {:.3f} mm on the same "
                    "measurements (sessions and poses): another model (--params {} against {}), "
                    "not a change of the robot: not called drift",
                    current_->version, m.max_mm, o_.params, current_->params_spec));
  }
  if (sets_differ && extended_ && !d_.change) {
    Log(fmt::format("the new set differs from version {} by up to {:.3f} mm where both were "
                    "fitted, but this night extends the fit to configurations version {} never "
                    "covered and no session it could judge disagrees with it: not called drift",
                    current_->version, m.max_mm, current_->version));
  }
  Log(fmt::format(
      "{}: against version {} the predicted positions differ by up to {:.3f} mm (mean {:.3f} "
      "mm) over {} configurations {}; chi2 {:.1f} on {} dof ({}), "
      "tolerance {:.3f} mm{}",
      d_.drift ? "DRIFT" : "no drift", current_->version, m.max_mm, m.mean_mm, m.configurations,
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
    d_.max_abs_sigmas = std::max(d_.max_abs_sigmas, std::abs(p.z));
    if (d_.drift && std::abs(p.z) > gates_.drift_sigma) {
      d_.drifted.push_back({names[p.parameter], p.change, p.z});
      const bool angle = model_.UnitOf(p.parameter) == calibration::ParameterUnit::kRad;
      spdlog::debug("recalibrate: drift: {} changed by {:+.4f} {} ({:.1f} sigma)",
                    names[p.parameter], angle ? p.change * 1e3 : p.change, angle ? "mrad" : "mm",
                    p.z);
    }
  }
  if (d_.drift && d_.change && !d_.change->causes.empty()) {
    // One ranking everywhere: the change found in the sessions themselves is named from what
    // they measured, and the two sets' difference is reported with the same causes.
    d_.causes = d_.change->causes;
    for (const auto& cause : d_.causes) Log("drift: " + cause.Describe());
  } else if (d_.drift) {
    // What physically changed between the two sets, one cause at a time.
    const auto explanation = calibration::ExplainDifference(
        model_, before.params, calibration::SetDifference(model_, before, now, compared_), 3,
        TermsOf(model_, run.params_spec));
    const std::string over =
        fmt::format("over {} configurations {}", compared_.size(), compared_over_);
    for (const auto& cause : explanation.causes) d_.causes.push_back(NameOf(cause, over));
    for (const auto& cause : d_.causes) Log("drift: " + cause.Describe());
  }
}

void NightlyJob::Store(const nlohmann::json& inputs) {
  const CalibrationRun& run = *run_;
  const nlohmann::json options = {{"select", settings_.select},
                                  {"params", o_.params},
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
                                 d_.validation.mean_mm, d_.validation.poses);
  if (d_.change) {
    note += fmt::format("; drift: changed from session {}", *d_.change->from_session);
    if (!d_.change->causes.empty()) note += ": " + d_.change->causes.front().Describe();
  } else if (d_.drift) {
    note += "; drift flagged";
    if (!d_.causes.empty()) note += ": " + d_.causes.front().Describe();
  }
  d_.outcome = d_.drift ? RecalibrationDecision::Outcome::kDriftStored
                        : RecalibrationDecision::Outcome::kStored;
  db::WriteTransaction tx(*database_);
  const auto [id, version] = db::InsertCalibration(*database_, record);
  d_.version = version;
  // The drift decision names the version it made: written once the version is known.
  if (d_.previous_version) db::SetDriftJson(*database_, id, JsonText(d_.DriftJson()));
  db::RecordActivation(*database_, robot_id_,
                       {d_.version, d_.previous_version, "", "recalibrate", note});
  tx.commit();
}

void NightlyJob::AddDecision(ReportInput& input) const {
  input.drift = d_.drift;
  input.drift_line = d_.DriftLine();
  for (const auto& v : d_.tested) {
    input.window.push_back({v.session, v.started_at, v.poses, v.mean_mm, v.effect_max_mm,
                            v.p_value, v.disagrees, v.outlier});
  }
  for (const auto& c : d_.change ? d_.change->causes : d_.causes)
    input.causes.push_back(c.Describe());
}

void NightlyJob::WriteDecisionOnlyReport() {
  ReportInput input;
  input.robot = o_.robot;
  input.version = 0;
  input.decision = d_.Describe();
  input.armsig_version = ARMSIG_VERSION;
  db::ReadSnapshot report_snapshot(*database_);
  input.history = ReportHistoryOf(*database_, robot_id_);
  input.drift_history = ReportDriftOf(*database_, model_, robot_id_, gates_.drift_mm);
  if (current_) {
    input.previous_version = current_->version;
    input.previous_params_spec = current_->params_spec;
  }
  AddDecision(input);
  d_.report_path = WriteDecisionReport(o_.report_dir, input);
  Log("report: " + d_.report_path);
}

void NightlyJob::WriteRunReport() {
  const CalibrationRun& run = *run_;
  ReportInput input;
  input.robot = o_.robot;
  input.version = d_.version;
  input.decision = d_.Describe();
  for (const auto& g : d_.gates) {
    input.gates.push_back(fmt::format("{}: {:.4f} mm (limit {:.4f} mm) {}", g.name, g.value_mm,
                                      g.limit_mm, g.passed ? "passed" : "FAILED"));
  }
  input.model = &model_;
  input.run = &run;
  input.validation = validation_;
  input.armsig_version = ARMSIG_VERSION;
  db::ReadSnapshot report_snapshot(*database_);  // the report's reads agree with each other
  input.sources = LoadReportSources(*database_, run);
  {
    std::vector<int64_t> sessions;
    for (const auto& s : input.sources.sessions) sessions.push_back(s.id);
    input.temperature_c = db::PoseTemperatures(*database_, sessions);
  }
  input.history = ReportHistoryOf(*database_, robot_id_);
  input.drift_history = ReportDriftOf(*database_, model_, robot_id_, gates_.drift_mm);
  if (d_.version == 0 && current_) {
    // This run, not stored: against the active set, as its drift decision was taken.
    const calibration::FittedSet now{run.estimate.params, run.estimate.identifiability.identified,
                                     run.estimate.covariance};
    ReportDriftPoint point = DriftPointOf(
        model_, FittedSetOf(model_, SignatureOf(model_, *current_), *current_), now,
        compared_.empty() ? spread_ : compared_);
    point.version = 0;
    point.against = current_->version;
    point.drift = d_.drift;
    input.drift_history.points.push_back(point);
  }
  if (d_.version == 0) {
    ReportHistoryPoint rejected{0, "this run (rejected)", d_.validation.mean_mm, run.params_spec,
                                false};
    rejected.drift = d_.drift;
    input.history.push_back(rejected);
  }
  if (current_) {
    input.previous_version = current_->version;
    input.previous_params_spec = current_->params_spec;
  }
  input.changes = changes_;
  AddDecision(input);
  if (d_.model_drift) {
    const auto& m = *d_.model_drift;
    input.changes_note = fmt::format(
        "{}: against version {}, the positions the two models predict over {} configurations "
        "spread over the work volume differ by up to {:.3f} mm (mean {:.3f} mm) after aligning "
        "bases; chi2 {:.1f} on {} degrees of freedom ({}); drift needs p < 0.001 and "
        "more than {:.3f} mm. Parameter changes are shown in one gauge (the rigid part of the "
        "two base alignments removed).",
        d_.drift ? "DRIFT" : "No drift", *d_.previous_version, m.configurations, m.max_mm,
        m.mean_mm, m.chi2, m.dof, PValueText(m.p_value), m.tolerance_mm);
  }
  d_.report_path = WriteReport(o_.report_dir, input);
  Log("report: " + d_.report_path);
}

RecalibrationDecision NightlyJob::Run() {
  // Everything the run will write is checked before anything is stored.
  since_ = o_.since.empty() ? std::string() : SinceToUtc(o_.since);
  if (!o_.json_path.empty()) io::CheckOutputFile(o_.json_path, "--json");
  if (!o_.report_dir.empty()) io::CheckOutputDirectory(o_.report_dir, "--report");
  OpenAndLock();
  ReadInputs();
  d_.robot = o_.robot;
  if (current_) d_.previous_version = current_->version;
  spread_ = calibration::SpreadConfigurations(model_, kDriftConfigurations);
  TestAgainstActive();
  if (d_.change && d_.change->poses_after < d_.change->poses_needed) {
    // Too few configurations since the change for a fit of their own; a fit reaching back
    // before it would blend two robots.
    d_.outcome = RecalibrationDecision::Outcome::kDriftSuspected;
    d_.drift = true;
    d_.poses = d_.change->poses_after;
    d_.sessions = d_.change->after;
    Log(d_.Describe());
    if (!o_.report_dir.empty()) {
      RemoveReportDebris(o_.report_dir, 0.0);  // this run holds the robot's lock
      WriteDecisionOnlyReport();  // nothing stored: a report that fails is the run's failure
    }
    return d_;
  }
  const std::vector<MeasuredPose> poses = FitInput();
  d_.poses = static_cast<int>(poses.size());
  {
    std::set<int64_t> sessions;
    for (const auto& p : poses) sessions.insert(p.frame);
    d_.sessions.assign(sessions.begin(), sessions.end());
  }
  const std::string digest =
      InputDigest(poses,
                  o_.params + "|residual-model=" + o_.residual_model +
                      // Said only when it is not the default, so that the digests of the
                      // sets stored before orientations were fitted stay what they were.
                      (o_.orientation == "auto" ? "" : "|orientation=" + o_.orientation) +
                      (o_.tool_rotation == "per-session" ? "" : "|tool-rotation=" + o_.tool_rotation),
                  o_.select);
  input_poses_ = poses.size();
  nlohmann::json inputs = {{"digest", digest},         {"poses", poses.size()},
                           {"sessions", d_.sessions},  {"since", since_},
                           {"params", o_.params},      {"select", o_.select},
                           {"residual_model", o_.residual_model},
                           {"orientation", o_.orientation},
                           {"tool_rotation", o_.tool_rotation}};
  // The change point the set was fitted after (a new one, or the active set's): the
  // windows of the nights after it never reach back before it.
  if (d_.change) {
    inputs["floor_session"] = *d_.change->from_session;
    inputs["floor_started_at"] = d_.change->from_started_at;
  } else if (d_.floor_session) {
    inputs["floor_session"] = *d_.floor_session;
    inputs["floor_started_at"] = floor_started_at_;
  }
  spdlog::debug("recalibrate: inputs: {} poses from sessions {}, --params {} --select {}: digest {}",
                poses.size(), JsonText(nlohmann::json(d_.sessions)), o_.params, o_.select, digest);
  if (!o_.force && UpToDate(digest)) {
    // A report the night that stored the set could not write is written now.
    if (!o_.report_dir.empty() && !HasReportOf(o_.report_dir, o_.robot, d_.version))
      WriteOutput([&] {
        d_.report_path = WriteStoredReport(*database_, o_.robot, d_.version, o_.report_dir).path;
        Log(fmt::format("report of version {}: {}", d_.version, d_.report_path));
      });
    return d_;
  }
  if (o_.force) spdlog::debug("recalibrate: --force: refitting whatever is stored");
  if (poses.size() < 20) {
    throw InputError(
        {o_.db_path, 0, 0, "--robot"},
        fmt::format("robot {} has {} measured configurations{} in its window; a recalibration "
                    "needs at least 20 (some to fit, the rest to validate); {} lists its sessions",
                    o_.robot, poses.size(), since_.empty() ? "" : " since " + since_,
                    Hint(database_->path(), {"sessions", "--robot", o_.robot})));
  }
  auto stopped = [&] {
    if (!o_.stop || !o_.stop->load()) return false;
    d_.stopped = true;
    Log("stopped before storing anything: the same command fits again");
    return true;
  };
  if (stopped()) return d_;
  // The fit and the judges stop within a solver iteration, a selection step or a
  // cross-validation when asked (core::Stopped), before anything is stored.
  try {
    Fit(poses);
    JudgeGates();
    CompareWithActive();
    TryElsewhere();
  } catch (const core::Stopped&) {
  }
  if (stopped()) return d_;
  if (pass_) {
    Store(inputs);
  } else if (!run_->estimate.status.ok()) {
    // No gate can judge an estimate the solver did not finish.
    d_.outcome = RecalibrationDecision::Outcome::kFailed;
    d_.failure = fmt::format("the fit did not give a usable estimate: {}",
                             run_->estimate.status.message);
  } else {
    d_.outcome = RecalibrationDecision::Outcome::kRejected;
  }
  Log(d_.Describe());
  if (!o_.report_dir.empty()) {
    // This run holds the robot's lock: temporary files in its report folder are a stopped
    // run's.
    RemoveReportDebris(o_.report_dir, 0.0);
    if (d_.version > 0)
      WriteOutput([&] { WriteRunReport(); });
    else
      WriteRunReport();  // nothing stored: a report that fails is the run's failure
  }
  return d_;
}

// An output that can only follow the commit: its failure is said with the stored version
// and the command that writes it later, not taken for the run's.
void NightlyJob::WriteOutput(const std::function<void()>& write) {
  try {
    write();
  } catch (const std::exception& e) {
    d_.output_error = fmt::format(
        "version {} is stored, but its report could not be written to {}: {}; write it with "
        "{} (or run the job again)",
        d_.version, o_.report_dir, e.what(),
        Hint(database_->path(), {"report", "--robot", o_.robot, "--set",
                                 std::to_string(d_.version), "--out", o_.report_dir}));
    spdlog::error("recalibrate: {}: {}", o_.robot, d_.output_error);
  }
}

}  // namespace

RecalibrationDecision Recalibrate(const RecalibrateOptions& options) {
  return NightlyJob(options).Run();
}


}  // namespace armsig::workflows
