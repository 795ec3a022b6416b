#include "workflows/recalibrate.h"

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdlib>
#include <ctime>
#include <functional>
#include <map>
#include <optional>
#include <regex>
#include <set>

#include "acquisition/lab.h"
#include "calibration/compensation.h"
#include "calibration/drift.h"
#include "calibration/identifiability.h"
#include "core/error.h"
#include "core/text.h"
#include "db/database.h"
#include "db/jobs.h"
#include "db/report_queries.h"
#include "db/store.h"
#include "io/atomic_file.h"
#include "io/file_lock.h"
#include "io/model_yaml.h"
#include "workflows/calibration_run.h"
#include "workflows/hint.h"
#include "workflows/report.h"
#include "workflows/signature.h"

namespace armsig::workflows {

namespace {

struct Gates {
  double max_mean_mm = 0.5, max_max_mm = 2.0, tolerance_mm = 0.02, drift_sigma = 5.0,
         drift_mm = 0.05;
};

constexpr int kDriftConfigurations = 50;     // spread over the work volume, the same every night
constexpr size_t kMinPosesPerSession = 3;    // to place a session's measurement frame
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

// A calibration's stored inputs digest ("" when none was recorded).
std::string StoredDigest(const db::StoredCalibration& c) {
  const auto stored = nlohmann::json::parse(c.inputs_json.empty() ? "{}" : c.inputs_json, nullptr,
                                            false);
  return stored.is_object() ? stored.value("digest", std::string()) : std::string();
}

bool LeapYear(int y) { return (y % 4 == 0 && y % 100 != 0) || y % 400 == 0; }

int DaysInMonth(int year, int month) {
  static constexpr int kDays[12] = {31, 28, 31, 30, 31, 30, 31, 31, 30, 31, 30, 31};
  return month == 2 && LeapYear(year) ? 29 : kDays[month - 1];
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
  } else {  // local time of $TZ (a time that a DST change skips is read as mktime does)
    tm.tm_isdst = -1;
    utc = std::mktime(&tm);
    if (utc == static_cast<std::time_t>(-1) && !(year == 1969 && month == 12 && day == 31))
      throw fail("not a time this system can represent");
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
    case Outcome::kRejected: {
      std::string failed;
      for (const auto& g : gates) {
        if (g.passed) continue;
        failed += fmt::format("{}{} {:.4f} mm > {:.4f} mm", failed.empty() ? "" : ", ", g.name,
                              g.value_mm, g.limit_mm);
      }
      return fmt::format("rejected: {}; {}",
                         failed.empty() ? std::string("a gate failed") : "gate failed: " + failed,
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
  if (outcome == Outcome::kUpToDate) {
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
  j["decision"] = outcome == Outcome::kStored     ? "stored"
                  : outcome == Outcome::kFailed ? "failed"
                                                : "rejected";
  if (outcome == Outcome::kFailed) j["failure"] = failure;
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
  if (previous_version) j["drift"] = DriftJson();
  if (!residual_model.is_null()) j["residual_model"] = residual_model;
  j["sessions"] = sessions;
  if (!report_path.empty()) j["report"] = report_path;
  return j;
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
  return j;
}

std::string RobotLockPath(const std::string& db_path, const std::string& robot) {
  std::string name;
  for (unsigned char c : robot) {
    if (std::isalnum(c) || c == '-' || c == '_' || c == '.')
      name += static_cast<char>(c);
    else
      name += fmt::format("%{:02X}", c);
  }
  return db_path + ".recalibrate." + name + ".lock";
}

RecalibrationDecision Recalibrate(const RecalibrateOptions& o) {
  // Everything the run will write is checked before anything is stored.
  const std::string since = o.since.empty() ? std::string() : SinceToUtc(o.since);
  if (!o.json_path.empty()) io::CheckOutputFile(o.json_path, "--json");
  if (!o.report_dir.empty()) io::CheckOutputDirectory(o.report_dir, "--report");
  db::Database database(o.db_path, db::OpenMode::kMustExist);
  const auto robot_id = db::FindRobot(database, o.robot);
  if (!robot_id)
    throw InputError({o.db_path, 0, 0, "--robot"}, UnknownRobotMessage(database.path(), o.robot));
  // One run per robot at a time (the lock guards the robot's versions); other robots of
  // the same store recalibrate in parallel (`armsig worker --jobs N`). SQLite: a file lock
  // beside the file; PostgreSQL: an advisory lock of the server, whatever machine runs it.
  std::optional<io::FileLock> file_lock;
  std::optional<db::RobotLock> server_lock;
  if (database.backend() == db::Backend::kPostgres)
    server_lock.emplace(database.connection(), "recalibrate", o.robot, o.lock_wait_s);
  else
    file_lock.emplace(RobotLockPath(o.db_path, o.robot), o.lock_wait_s);
  auto log = [&](const std::string& message) {
    spdlog::info("recalibrate: {}: {}", o.robot, message);
  };

  // What the run decides on is read from one snapshot (a capture or a push may write
  // meanwhile): the model, the gates, the poses, the stored sets.
  std::optional<db::ReadSnapshot> snapshot(std::in_place, database);
  const auto model =
      io::ParseRobotModel(db::RobotModelYaml(database, *robot_id), "model of robot " + o.robot);
  const Gates gates = LoadGates(database, *robot_id, o);
  spdlog::debug(
      "recalibrate: gates: validation mean <= {} mm, max <= {} mm, tolerance {} mm, drift {} mm "
      "/ {} sigma",
      gates.max_mean_mm, gates.max_max_mm, gates.tolerance_mm, gates.drift_mm, gates.drift_sigma);
  std::vector<MeasuredPose> poses;
  {
    // Every session is a measurement frame of its own (its own set-up of the instruments);
    // one whose poses cannot place its frame adds nothing but unknowns.
    for (const auto& s : db::ListSessions(database, *robot_id)) {
      if (s.state == "aborted" && s.started_at >= since) {
        spdlog::info("recalibrate: {}: session {} is discarded ({}): left out", o.robot, s.id,
                     s.note);
      }
    }
    std::map<int64_t, std::vector<MeasuredPose>> by_session;
    for (auto& p : db::LoadRobotPoses(database, *robot_id, since))
      by_session[p.frame].push_back(std::move(p));
    for (auto& [session, list] : by_session) {
      if (list.size() < kMinPosesPerSession) {
        spdlog::warn(
            "recalibrate: {}: session {} has {} usable configuration{}: too few to place its "
            "measurement frame ({} needed); left out",
            o.robot, session, list.size(), list.size() == 1 ? "" : "s", kMinPosesPerSession);
        continue;
      }
      spdlog::debug("recalibrate: session {}: {} usable configurations (one measurement frame)",
                    session, list.size());
      for (auto& p : list) poses.push_back(std::move(p));
    }
  }
  const auto history = db::CalibrationHistory(database, *robot_id);
  snapshot.reset();  // not held while fitting
  std::optional<db::StoredCalibration> current;
  for (const auto& c : history) {
    if (c.active) current = c;
  }

  RecalibrationDecision d;
  d.robot = o.robot;
  d.poses = static_cast<int>(poses.size());
  if (current) d.previous_version = current->version;
  const std::string digest =
      InputDigest(poses, o.params + "|residual-model=" + o.residual_model, o.select);
  std::set<int64_t> sessions;
  for (const auto& p : poses) sessions.insert(p.frame);
  d.sessions.assign(sessions.begin(), sessions.end());
  const nlohmann::json inputs = {{"digest", digest},     {"poses", poses.size()},
                                 {"sessions", sessions}, {"since", since},
                                 {"params", o.params},   {"select", o.select},
                                 {"residual_model", o.residual_model}};
  spdlog::debug("recalibrate: inputs: {} poses from sessions {}, --params {} --select {}: digest {}",
                poses.size(), JsonText(nlohmann::json(sessions)), o.params, o.select, digest);
  // Idempotence on content: a stored set was already fitted on exactly these measurements
  // with these options, however they were asked for. The active one first; else the
  // newest other one (after `activate` chose another set: the night does not undo it).
  if (!o.force) {
    const db::StoredCalibration* same = nullptr;
    for (auto it = history.rbegin(); it != history.rend(); ++it) {
      if (StoredDigest(*it) != digest) continue;
      spdlog::debug("recalibrate: version {}{} has this digest", it->version,
                    it->active ? " (active)" : "");
      if (it->active || !same) same = &*it;
      if (it->active) break;
    }
    if (same) {
      d.outcome = RecalibrationDecision::Outcome::kUpToDate;
      d.version = same->version;
      if (current && current->version != same->version) {
        const auto activations = db::ActivationHistory(database, *robot_id);
        for (auto a = activations.rbegin(); a != activations.rend(); ++a) {
          if (a->version != current->version) continue;
          d.active_chosen_by = a->activated_by;
          d.active_chosen_at = a->activated_at;
          break;
        }
      }
      log(d.Describe());
      return d;
    }
  } else {
    spdlog::debug("recalibrate: --force: refitting whatever is stored");
  }
  if (poses.size() < 20) {
    throw InputError({o.db_path, 0, 0, "--robot"},
                     fmt::format("robot {} has {} measured configurations{}; a recalibration "
                                 "needs at least 20 (some to fit, the rest to validate); {} "
                                 "lists its sessions",
                                 o.robot, poses.size(), since.empty() ? "" : " since " + since,
                                 Hint(database.path(), {"sessions", "--robot", o.robot})));
  }
  CalibrateSettings settings;
  settings.params = o.params;
  settings.model_subset = true;
  settings.residual_model = o.residual_model;
  settings.max_iterations = o.max_iterations;
  // 60 %, at most 80 (the paper's) and 6 more for every further session: each session's
  // frame adds six base unknowns.
  const size_t most = 80 + 6 * (sessions.size() - 1);
  settings.select =
      o.select > 0
          ? o.select
          : static_cast<int>(std::min<size_t>(most, std::max<size_t>(poses.size() * 6 / 10, 10)));
  log(fmt::format("{} configurations from {} session{}: fitting {} ({}), validating on the rest",
                  poses.size(), sessions.size(), sessions.size() == 1 ? "" : "s", settings.select,
                  o.params));
  const CalibrationRun run = RunCalibration(model, poses, {}, settings);
  std::vector<MeasuredPose> fit, validation;
  {
    const std::set<std::string> fit_ids(run.fit_pose_ids.begin(), run.fit_pose_ids.end());
    const std::set<std::string> validation_ids(run.validation_pose_ids.begin(),
                                               run.validation_pose_ids.end());
    for (const auto& p : poses) {
      if (fit_ids.count(p.id)) fit.push_back(p);
      if (validation_ids.count(p.id)) validation.push_back(p);
    }
  }
  d.validation = StatsOf(run.validation_residuals);
  d.residual_model = CalibrationJson(model, run)["residual_model"];
  d.fit = run.estimate.fit;
  d.nominal = run.estimate.nominal;
  d.rank = run.estimate.identifiability.rank;
  spdlog::debug(
      "recalibrate: fit {} ({} iterations): rank {}, sigma0 {:.4f} mm, fit mean {:.4f} mm; "
      "validation mean {:.4f} mm, max {:.4f} mm on {} configurations",
      run.estimate.status.ok() ? "converged" : "NOT converged", run.estimate.iterations, d.rank,
      run.estimate.sigma0_mm, d.fit.mean_mm, d.validation.mean_mm, d.validation.max_mm,
      d.validation.poses);

  // An estimate the solver did not finish is judged by nothing: no gate, no drift.
  const bool fit_ok = run.estimate.status.ok();
  if (!fit_ok) {
    log(fmt::format("the fit did not give a usable estimate ({}): no gate and no drift judged",
                    run.estimate.status.message));
  }
  bool pass = fit_ok;
  auto gate = [&](const std::string& name, double value, double limit) {
    if (!fit_ok) return;
    const bool ok = value <= limit;
    d.gates.push_back({name, value, limit, ok});
    log(fmt::format("{}: {:.4f} mm (limit {:.4f} mm) {}", name, value, limit,
                    ok ? "passed" : "FAILED"));
    pass = pass && ok;
  };
  gate("validation mean", d.validation.mean_mm, gates.max_mean_mm);
  gate("validation max", d.validation.max_mm, gates.max_max_mm);
  std::vector<calibration::ParameterChange> changes;
  if (current && fit_ok) {
    // The current set on the same validation data, each session's base re-aligned on that
    // session's fit poses (the measuring frame moves between set-ups; the arm signature
    // does not), as the new fit placed each frame on them.
    const Signature old = SignatureOf(model, *current);
    calibration::FrameBases old_bases = calibration::AlignFrameBases(model, old.params, fit);
    {
      std::vector<MeasuredPose> unplaced;
      for (const auto& p : validation) {
        if (!old_bases.count(p.frame)) unplaced.push_back(p);
      }
      for (const auto& [frame, base] : calibration::AlignFrameBases(model, old.params, unplaced))
        old_bases[frame] = base;
    }
    bool placed = !validation.empty();
    for (const auto& p : validation) placed = placed && old_bases.count(p.frame) > 0;
    if (placed) {
      // With its residual map when it has one: the set as predict and compensate use it.
      d.previous_on_same_data =
          StatsOf(MappedResiduals(model, old_bases, old.params, old.map.get(), validation));
      spdlog::debug(
          "recalibrate: version {} on the same validation data ({} frames re-aligned): mean "
          "{:.4f} mm, max {:.4f} mm",
          current->version, old_bases.size(), d.previous_on_same_data->mean_mm,
          d.previous_on_same_data->max_mm);
      gate(fmt::format("not worse than version {} on the same data (+{:.3f} mm)", current->version,
                       gates.tolerance_mm),
           d.validation.mean_mm, d.previous_on_same_data->mean_mm + gates.tolerance_mm);
    } else {
      spdlog::debug("recalibrate: version {} could not be placed in every frame: no comparison "
                    "on the same data",
                    current->version);
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
    db::CalibrationRecord record = CalibrationRecordOf(model, run, *robot_id, inputs, options, true);
    if (d.previous_version) record.drift_json = JsonText(d.DriftJson());
    db::WriteTransaction tx(database);
    d.version = db::InsertCalibration(database, record).second;
    db::RecordActivation(
        database, *robot_id,
        {d.version, d.previous_version, "", "recalibrate",
         fmt::format("validation mean {:.4f} mm on {} configurations{}", d.validation.mean_mm,
                     d.validation.poses, d.drift ? "; drift flagged" : "")});
    tx.commit();
    d.outcome = RecalibrationDecision::Outcome::kStored;
  } else if (!run.estimate.status.ok()) {
    // No gate can judge an estimate the solver did not finish: the gates above ran on the
    // last step only to show how far it got.
    d.outcome = RecalibrationDecision::Outcome::kFailed;
    d.failure = fmt::format("the fit did not give a usable estimate: {}",
                            run.estimate.status.message);
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
    db::ReadSnapshot report_snapshot(database);  // the report's reads agree with each other
    input.sources = LoadReportSources(database, run);
    {
      std::vector<int64_t> sessions;
      for (const auto& s : input.sources.sessions) sessions.push_back(s.id);
      input.temperature_c = db::PoseTemperatures(database, sessions);
    }
    input.history = ReportHistoryOf(database, *robot_id);
    if (d.version == 0) {
      ReportHistoryPoint rejected{0, "this run (rejected)", d.validation.mean_mm, run.params_spec,
                                  false};
      rejected.drift = d.drift;
      input.history.push_back(rejected);
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
