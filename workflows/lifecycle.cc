#include "workflows/lifecycle.h"

#include <fmt/format.h>
#include <fmt/ranges.h>
#include <pwd.h>
#include <spdlog/spdlog.h>
#include <unistd.h>

#include <cctype>
#include <charconv>
#include <filesystem>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <optional>

#include "acquisition/plan.h"
#include "acquisition/session_owner.h"
#include "calibration/data_checks.h"
#include "core/error.h"
#include "core/fnv.h"
#include "core/plausibility.h"
#include "core/text.h"
#include "core/text_layout.h"
#include "core/wording.h"
#include "db/store.h"
#include "db/stored_json.h"
#include "db/jobs.h"
#include "io/atomic_file.h"
#include "io/file_lock.h"
#include "io/model_yaml.h"
#include "workflows/signature.h"
#include "workflows/hint.h"

namespace armsig::workflows {

namespace {

int64_t RobotId(db::Database& database, const std::string& robot) {
  const auto id = db::FindRobot(database, robot);
  if (!id) {
    throw InputError({database.path(), 0, 0, "--robot"},
                     UnknownRobotMessage(database, robot));
  }
  return *id;
}

}  // namespace

bool RegisterRobot(db::Database& database, const std::string& name, const std::string& model_path) {
  if (name.empty()) throw InputError({"NAME", 0, 0, ""}, "a robot needs a name");
  const std::string text = io::ReadWholeFile(model_path, io::kYamlFileLimit);
  const auto model = io::ParseRobotModel(text, model_path);  // refuses a bad file, by line
  db::WriteTransaction tx(database);
  if (const auto id = db::FindRobotInUse(database, name)) {  // a removed one: said so
    if (db::RobotModelYaml(database, *id) == text) return false;
    throw InputError({model_path, 0, 0, ""},
                     "robot " + Quoted(name) +
                         " is already registered with another model; choose another name (" +
                         Hint(database.path(), {"robot", "list"}) + ")");
  }
  db::EnsureRobot(database, name, model.name, text);
  tx.commit();
  spdlog::info("robot {}: registered with model {} ({} joints, {} parameters) from {}", name,
               model.name, model.num_joints(), model.num_parameters(), model_path);
  return true;
}

namespace {

std::string CurrentUser() {
  if (const passwd* pw = ::getpwuid(::geteuid())) return pw->pw_name;
  return "uid " + std::to_string(::geteuid());
}

// The nightly job's lock of a robot (its name's: a file beside SQLite, an advisory lock of a
// PostgreSQL server), held while the robot's name or sessions change: a run under way keeps
// the name it locked and the sessions it read, and no run starts meanwhile.
class RobotChangeLock {
 public:
  RobotChangeLock(db::Database& database, const std::string& robot) {
    constexpr int kWaitS = 5;
    try {
      if (database.backend() == db::Backend::kPostgres) {
        server_.emplace(database.connection(), "recalibrate", robot, kWaitS);
      } else {
        file_.emplace(RobotLockPath(database.path(), robot), kWaitS);
      }
    } catch (const std::runtime_error& e) {
      throw InputError({database.path(), 0, 0, "robots"},
                       "robot " + Quoted(robot) + " is being recalibrated (" + e.what() +
                           "): change it when that run has ended; nothing was changed");
    }
  }

 private:
  std::optional<io::FileLock> file_;
  std::optional<db::RobotLock> server_;
};

}  // namespace

void RenameRobot(db::Database& database, const std::string& name, const std::string& new_name,
                 const std::string& reason) {
  if (new_name.empty()) throw InputError({"NEW_NAME", 0, 0, ""}, "a robot needs a name");
  if (new_name == name) {
    throw InputError({"NEW_NAME", 0, 0, ""}, "robot " + Quoted(name) + " has that name already");
  }
  const RobotChangeLock old_name(database, name), taken(database, new_name);
  db::RenameRobot(database, name, new_name, reason, CurrentUser());
}

void RemoveRobot(db::Database& database, const std::string& name, const std::string& reason) {
  const RobotChangeLock lock(database, name);
  db::RemoveRobot(database, name, reason, CurrentUser());
}

void RestoreRobot(db::Database& database, const std::string& name, const std::string& reason) {
  db::RestoreRobot(database, name, reason, CurrentUser());
}

std::string MoveSession(db::Database& database, int64_t session_id, const std::string& robot,
                        const std::string& reason) {
  const auto session = db::LoadSession(database, session_id);
  if (!session) {
    throw InputError({database.path(), 0, 0, "sessions"},
                     "no session " + std::to_string(session_id) + " (armsig sessions lists them)");
  }
  // The same arm's kind: as many joints (each pose's angles must mean the other's joints).
  const int from = RegisteredModel(database, session->robot).num_joints();
  const int to = RegisteredModel(database, robot).num_joints();
  if (from != to) {
    throw InputError({"--robot", 0, 0, ""},
                     fmt::format("session {} holds {}-joint configurations of robot {}; robot {} "
                                 "has {} joints: nothing was moved",
                                 session_id, from, Quoted(session->robot), Quoted(robot), to));
  }
  if (session->robot == robot) {
    throw InputError({database.path(), 0, 0, "sessions"},
                     "session " + std::to_string(session_id) + " is robot " + robot + "'s already");
  }
  const RobotChangeLock from_lock(database, session->robot), to_lock(database, robot);
  return db::MoveSession(database, session_id, robot, reason, CurrentUser());
}

std::string FormatRobotHistory(db::Database& database, const std::string& robot, bool json) {
  std::optional<int64_t> id;
  for (const auto& r : db::ListRobots(database, true)) {
    if (r.name == robot) id = r.id;
  }
  if (!id) {
    throw InputError({database.path(), 0, 0, "--robot"}, UnknownRobotMessage(database, robot));
  }
  const auto events = db::RobotEvents(database, *id);
  if (json) {
    nlohmann::json out = nlohmann::json::array();
    for (const auto& e : events) {
      out.push_back({{"event", e.event},
                     {"session", e.session_id ? nlohmann::json(*e.session_id) : nlohmann::json()},
                     {"detail", e.detail},
                     {"reason", e.reason},
                     {"at", e.at},
                     {"by", e.by_user}});
    }
    return JsonText(out, 2) + "\n";
  }
  if (events.empty()) return "robot " + Printable(robot) + ": no renames, removals or moves\n";
  std::string text;
  for (const auto& e : events) {
    text += fmt::format("{}  {}{}, by {}\n", Printable(e.at), Printable(e.detail),
                        e.reason.empty() ? "" : ": " + Printable(e.reason), Printable(e.by_user));
  }
  return text;
}

calibration::RobotModel RegisteredModel(db::Database& database, const std::string& robot) {
  return io::ParseRobotModel(db::RobotModelYaml(database, RobotId(database, robot)),
                             "model of robot " + robot);
}

void PosesDigester::Add(const MeasuredPose& pose) {
  // FNV-1a over every joint angle and target coordinate, in order, each on a grid far
  // below any instrument's resolution (1e-10 rad, 1e-7 mm): the same measurements read
  // from a file in metres and one in millimetres differ in their last bits only (a unit
  // conversion's rounding) and are one digest.
  auto add = [&](double value, double grid) {
    const double steps = std::round(value / grid);
    int64_t n = std::isfinite(steps) && std::abs(steps) < 9e18 ? static_cast<int64_t>(steps) : 0;
    uint64_t bits = 0;
    std::memcpy(&bits, &n, sizeof bits);
    char bytes[8];  // least significant first, whatever the machine's byte order
    for (int k = 0; k < 8; ++k) bytes[k] = static_cast<char>((bits >> (8 * k)) & 0xff);
    hash_ = core::Fnv1a64(std::string_view(bytes, 8), hash_);
  };
  add(static_cast<double>(pose.joints_rad.size()), 1.0);
  for (int i = 0; i < pose.joints_rad.size(); ++i) add(pose.joints_rad(i), 1e-10);
  for (int i = 0; i < 3; ++i) add(pose.target_in_world(i), 1e-7);
  // A measured orientation counts when there is one (position-only digests are as before):
  // its matrix on a grid of 1e-10, its sigmas (rad) on one of 1e-12.
  if (pose.orientation) {
    for (int k = 0; k < 9; ++k) add(pose.orientation->world_from_target(k / 3, k % 3), 1e-10);
    if (pose.orientation->sigma_rad) {
      for (int k = 0; k < 3; ++k) add((*pose.orientation->sigma_rad)(k), 1e-12);
    }
  }
}

std::string PosesDigester::Hex() const { return fmt::format("{:016x}", hash_); }

std::string PosesDigest(const std::vector<MeasuredPose>& poses) {
  PosesDigester digest;
  for (const auto& p : poses) digest.Add(p);
  return digest.Hex();
}

namespace {

// Two sessions of poses are one measurement when every pose agrees within what writing it to a
// file and reading it back may change (armsig's own export, io::PosesCsvRow: 12 significant
// digits of an angle in degrees, 9 of a coordinate in mm): 1e-8 rad a joint (0.002″), a
// coordinate 0.1 µm or 1e-8 of its size (9 digits of a 100 m coordinate), 1e-9 an entry of an
// orientation matrix. Two measurings of the same configurations differ by the instrument's
// noise, and one coordinate 1 µm off is another measurement.
bool SameMeasurement(const std::vector<MeasuredPose>& a, const std::vector<MeasuredPose>& b) {
  constexpr double kJointRad = 1e-8, kPositionMm = 1e-4, kPositionRelative = 1e-8,
                   kRotation = 1e-9;
  if (a.size() != b.size()) return false;
  for (size_t k = 0; k < a.size(); ++k) {
    const MeasuredPose& p = a[k];
    const MeasuredPose& q = b[k];
    if (p.joints_rad.size() != q.joints_rad.size() || p.orientation.has_value() != q.orientation.has_value())
      return false;
    if ((p.joints_rad - q.joints_rad).cwiseAbs().maxCoeff() > kJointRad) return false;
    for (int c = 0; c < 3; ++c) {
      const double a = p.target_in_world(c), b = q.target_in_world(c);
      if (!(std::abs(a - b) <= std::max(kPositionMm, kPositionRelative * std::abs(a)))) return false;
    }
    if (p.orientation && (p.orientation->world_from_target - q.orientation->world_from_target)
                                 .cwiseAbs()
                                 .maxCoeff() > kRotation)
      return false;
  }
  return true;
}

}  // namespace

PosesSessionWriter::PosesSessionWriter(db::Database& database, const std::string& robot,
                                       const std::string& source, db::SessionKind kind)
    : database_(database),
      robot_(robot),
      source_(source),
      robot_id_(RobotId(database, robot)),
      tx_(database) {  // the look for a copy and the insert: one writer at a time
  model_ = io::ParseRobotModel(db::RobotModelYaml(database, robot_id_), "model of robot " + robot);
  num_joints_ = model_.num_joints();
  model_name_ = model_.name;
  session_ = db::CreateSession(database, robot_id_, "", "", db::SessionState::kCompleted,
                               // The file name is input: shown in the note, never obeyed.
                               std::string(TruncateUtf8("poses imported from " + Printable(source),
                                                        plausible::kMaxNoteLength)));
  if (kind != db::SessionKind::kCalibration) db::SetSessionKind(database, session_, kind);
}

void PosesSessionWriter::Add(const MeasuredPose& pose, const Eigen::Matrix3d* covariance_mm2) {
  if (pose.joints_rad.size() != num_joints_) {
    throw InputError({source_, 0, 0, ""}, "pose " + pose.id + " has " +
                                              std::to_string(pose.joints_rad.size()) +
                                              " joints; robot " + robot_ + "'s model " +
                                              model_name_ + " has " + std::to_string(num_joints_));
  }
  const int64_t pose_id = db::InsertPose(database_, session_, static_cast<int>(count_), pose.id,
                                         pose.joints_rad, "measured", 1);
  db::PointRow point;
  point.pose_id = pose_id;
  point.point = "target";
  point.position_mm = pose.target_in_world;
  point.covariance_mm2.setConstant(std::numeric_limits<double>::quiet_NaN());
  if (covariance_mm2) point.covariance_mm2 = *covariance_mm2;
  point.orientation = pose.orientation;
  db::InsertPoint(database_, session_, point);
  digest_.Add(pose);
  ++count_;
  // Every pose up to the sample's size, then each later one replaces a random member with
  // probability size/count (reservoir sampling): a uniform sample of the whole file.
  if (sample_.size() < kDoorSample) {
    sample_.push_back(pose);
  } else if (const size_t r = sampler_() % count_; r < kDoorSample) {
    sample_[r] = pose;
  }
}

void PosesSessionWriter::CheckAtTheDoor() const {
  const int distinct = calibration::DistinctConfigurations(sample_);
  if (distinct < 3) {
    const std::string what =
        distinct == static_cast<int>(count_)
            ? fmt::format("{} pose{}", count_, count_ == 1 ? "" : "s")
            : fmt::format("{} pose{} but only {} distinct configuration{} (the robot did not "
                          "move between some of them)",
                          count_, count_ == 1 ? "" : "s", distinct, distinct == 1 ? "" : "s");
    throw InputError({source_, 0, 0, ""},
                     what + ": a session needs at least 3 distinct configurations to place its "
                            "measuring frame (a calibration many more); nothing stored");
  }
  const calibration::PoseModelCheck check = calibration::CheckPosesAgainstModel(model_, sample_);
  if (!check.checked || check.fits) return;
  if (!check.reading.empty()) {
    throw InputError(
        {source_, 0, 0, ""},
        fmt::format("the nominal model of robot {} ({}) misses these poses by {:.1f} mm rms after "
                    "the best rigid placement, where an uncalibrated robot misses by millimetres; "
                    "read another way it fits to {:.2f} mm: {} (check the columns' unit suffixes "
                    "or --joint-unit / --length-scale); nothing stored",
                    robot_, model_name_, check.rms_mm, check.reading_rms_mm, check.reading));
  }
  throw InputError(
      {source_, 0, 0, ""},
      fmt::format("the nominal model of robot {} ({}) misses these poses by {:.1f} mm rms after the "
                  "best rigid placement, where an uncalibrated robot misses by millimetres, and no "
                  "other reading of the units fits: these are not robot {}'s poses with its "
                  "model's tool (another robot, another tool, or --robot mistyped?); nothing stored",
                  robot_, model_name_, check.rms_mm, robot_));
}

StoredPoses PosesSessionWriter::Finish(bool allow_duplicate) {
  if (count_ == 0) throw InputError({source_, 0, 0, ""}, "no poses to store");
  CheckAtTheDoor();
  StoredPoses result;
  result.digest = digest_.Hex();
  spdlog::debug("import poses: {} poses from {}: content digest {}", count_, source_,
                result.digest);
  // This session's poses as stored, read back only when another session has as many.
  std::optional<std::vector<MeasuredPose>> these;
  for (const auto& s : db::ListSessions(database_, robot_id_)) {
    if (s.id == session_ || s.measured != static_cast<int>(count_)) continue;
    const auto stored = db::LoadSessionPoses(database_, s.id);
    const std::string digest = PosesDigest(stored);
    spdlog::trace("import poses: session {} ({} poses): digest {}", s.id, s.measured, digest);
    if (digest != result.digest) {
      // The same poses after a round trip through a file (an export's rounding) hash apart.
      if (!these) these = db::LoadSessionPoses(database_, session_);
      if (!SameMeasurement(stored, *these)) continue;
    }
    if (allow_duplicate) {
      spdlog::warn(
          "import poses: session {} already holds these {} poses; storing them again "
          "(--allow-duplicate)",
          s.id, count_);
      break;
    }
    result.session = s.id;
    result.duplicate = true;
    spdlog::info(
        "import poses: robot {}: these {} poses are already stored as session {}; "
        "nothing stored (--allow-duplicate stores them again)",
        robot_, count_, s.id);
    return result;  // the transaction rolls back: nothing of this import stays
  }
  tx_.commit();
  spdlog::info("robot {}: session {} stores {} measured poses from {}", robot_, session_, count_,
               source_);
  result.session = session_;
  return result;
}

StoredPoses StorePosesSession(db::Database& database, const std::string& robot,
                              const std::vector<MeasuredPose>& poses, const std::string& source,
                              bool allow_duplicate,
                              const std::vector<Eigen::Matrix3d>& covariances_mm2,
                              db::SessionKind kind) {
  PosesSessionWriter writer(database, robot, source, kind);
  for (size_t k = 0; k < poses.size(); ++k)
    writer.Add(poses[k], k < covariances_mm2.size() ? &covariances_mm2[k] : nullptr);
  return writer.Finish(allow_duplicate);
}

std::vector<MeasuredPose> SessionPoses(db::Database& database, int64_t session_id) {
  if (!db::SessionExists(database, session_id)) {
    throw InputError({database.path(), 0, 0, ""},
                     fmt::format("no session {} ({} lists them)", session_id,
                                 Hint(database.path(), {"sessions"})));
  }
  return db::LoadSessionPoses(database, session_id);
}

int SessionJoints(db::Database& database, int64_t session_id) {
  const auto row = db::LoadSession(database, session_id);
  if (!row) {
    throw InputError({database.path(), 0, 0, ""},
                     fmt::format("no session {} ({} lists them)", session_id,
                                 Hint(database.path(), {"sessions"})));
  }
  const int64_t robot_id = RobotId(database, row->robot);
  return io::ParseRobotModel(db::RobotModelYaml(database, robot_id), "model of robot " + row->robot)
      .num_joints();
}

std::vector<ListedSession> Sessions(db::Database& database, const std::string& robot) {
  std::vector<ListedSession> listed;
  for (auto& s : db::ListSessions(database, robot.empty() ? std::nullopt
                                                          : std::optional<int64_t>(
                                                                RobotId(database, robot)))) {
    const std::string shown = acquisition::DisplayState(s.state, s.owner);
    if (s.state == db::SessionState::kRunning && shown != db::ToString(s.state)) {
      spdlog::debug("sessions: session {} is stored as running, its process {} is gone: {}",
                    s.id,
                    s.owner ? fmt::format("{} on {}", s.owner->pid, s.owner->host)
                            : std::string("(not recorded)"),
                    shown);
    }
    listed.push_back({std::move(s), shown});
  }
  return listed;
}

namespace {

db::SessionRow SessionToChange(db::Database& database, int64_t session_id) {
  const auto row = db::LoadSession(database, session_id);
  if (!row) {
    throw InputError({database.path(), 0, 0, ""},
                     fmt::format("no session {} ({} lists them)", session_id,
                                 Hint(database.path(), {"sessions"})));
  }
  return *row;
}

}  // namespace

db::SessionState DiscardSession(db::Database& database, int64_t session_id,
                                const std::string& reason) {
  db::WriteTransaction tx(database);
  const db::SessionRow row = SessionToChange(database, session_id);
  if (row.state == db::SessionState::kAborted) return db::SessionState::kAborted;
  if (row.state == db::SessionState::kRunning && row.owner &&
      acquisition::StateOf(*row.owner) != acquisition::OwnerState::kGone) {
    throw InputError({database.path(), 0, 0, ""},
                     fmt::format("session {} is being captured by process {} on {}: stop it "
                                 "first (Ctrl-C), then discard it",
                                 session_id, row.owner->pid, row.owner->host));
  }
  db::DiscardSession(database, session_id, reason.empty() ? "by hand" : reason);
  tx.commit();
  return db::SessionState::kAborted;
}

db::SessionState RestoreSession(db::Database& database, int64_t session_id) {
  db::WriteTransaction tx(database);
  const db::SessionRow row = SessionToChange(database, session_id);
  if (row.state != db::SessionState::kAborted) {
    throw InputError({database.path(), 0, 0, ""},
                     fmt::format("session {} is not discarded (it is {})", session_id,
                                 acquisition::DisplayState(row.state, row.owner)));
  }
  const size_t planned =
      row.plan_json.empty() ? 0
                            : acquisition::PlanFromJson(row.plan_json, {database.path(), "sessions",
                                                                        session_id, "plan_json"})
                                  .size();
  const size_t stored = db::StoredSeqs(database, session_id).size();
  const db::SessionState state =
      stored >= planned ? db::SessionState::kCompleted : db::SessionState::kPaused;
  db::SetSessionState(database, session_id, state);
  db::AppendSessionNote(database, session_id, "restored");
  tx.commit();
  return state;
}

std::vector<VersionInfo> Versions(db::Database& database, const std::string& robot) {
  std::vector<VersionInfo> out;
  const int64_t robot_id = RobotId(database, robot);
  for (const auto& c : db::CalibrationHistory(database, robot_id)) {
    VersionInfo v;
    v.version = c.version;
    v.active = c.active;
    v.created_at = c.created_at;
    v.params_spec = c.params_spec;
    v.rank = c.rank;
    v.poses_fit = c.poses_fit;
    v.poses_validation = c.poses_validation;
    v.fit_mean_mm = c.fit_mean_mm;
    v.validation_mean_mm = c.validation_mean_mm;
    v.validation_max_mm = c.validation_max_mm;
    const auto inputs =
        db::ParseStoredJson(c.inputs_json, {database.path(), "calibrations", c.id, "inputs_json"});
    if (inputs.is_object()) {
      v.sessions = InputSessions(inputs);
      if (inputs.contains("since") && inputs["since"].is_string()) v.since = inputs["since"];
      if (inputs.contains("floor_session") && inputs["floor_session"].is_number_integer())
        v.floor_session = inputs["floor_session"].get<int64_t>();
    }
    const auto drift =
        db::ParseStoredJson(c.drift_json, {database.path(), "calibrations", c.id, "drift_json"});
    if (drift.is_object() && drift.contains("flag") && drift["flag"].is_boolean()) {
      v.drift = drift["flag"].get<bool>();
      if (drift.contains("against") && drift["against"].is_number_integer())
        v.drift_against = drift["against"].get<int>();
      // The cause named: of the change found in the sessions, else of the two sets' difference.
      const auto* causes = &drift["causes"];
      if (drift.contains("change") && drift["change"].is_object()) {
        const auto& change = drift["change"];
        if (change.contains("from_session") && change["from_session"].is_number_integer())
          v.change_from_session = change["from_session"].get<int64_t>();
        if (change.contains("causes")) causes = &change["causes"];
      }
      if (causes->is_array() && !causes->empty() && (*causes)[0].is_object() &&
          (*causes)[0].contains("text") && (*causes)[0]["text"].is_string())
        v.cause = (*causes)[0]["text"].get<std::string>();
    }
    out.push_back(std::move(v));
  }
  for (const auto& a : db::ActivationHistory(database, robot_id)) {
    for (auto& v : out) {
      if (v.version == a.version) v.activations.push_back(a);
    }
  }
  return out;
}

std::optional<int> Activate(db::Database& database, const std::string& robot, int version,
                            const std::string& note) {
  const int64_t robot_id = RobotId(database, robot);
  db::WriteTransaction tx(database);
  const auto before = db::ActiveCalibration(database, robot_id);
  if (!db::SetActiveVersion(database, robot_id, version)) {
    throw InputError({"--version", 0, 0, ""},
                     fmt::format("robot {} has no parameter set version {} ({})", robot, version,
                                 Hint(database.path(), {"versions", "--robot", robot})));
  }
  const std::optional<int> previous = before ? std::optional<int>(before->version) : std::nullopt;
  if (previous == version) {  // nothing changed: no activation to record
    spdlog::info("activate: robot {}: version {} is already active; nothing recorded", robot,
                 version);
    return previous;
  }
  db::RecordActivation(database, robot_id, {version, previous, "", "activate", note});
  tx.commit();
  spdlog::info("activate: robot {}: version {} is now active (was {})", robot, version,
               previous ? "version " + std::to_string(*previous) : std::string("none"));
  return previous;
}

namespace {

std::string JsonArray(const auto& items) {
  nlohmann::json out = nlohmann::json::array();
  for (const auto& item : items) out.push_back(ToJson(item));
  return JsonText(out, 2) + "\n";
}

}  // namespace

std::string FormatRobots(const std::vector<db::RobotRow>& robots, bool json,
                         const std::string& db_path) {
  if (json) return JsonArray(robots);
  if (robots.empty()) return "no robots in " + Printable(db_path) + "\n";
  std::string text;
  for (const auto& r : robots) {
    text +=
        // Text from the database is shown, never obeyed (an edited file may hold anything).
        fmt::format("{:<20} model {:<12} {:>12}  active version {}\n", Printable(r.name),
                    Printable(r.model_name), Count(r.sessions, "session"),
                    r.active_version ? std::to_string(*r.active_version) : "none");
    if (!r.removed_at.empty()) text += "  removed " + Printable(r.removed_at) + "\n";
  }
  return text;
}

namespace {

// `line` and `more` on one line when it fits 100 columns, else `more` on the next, indented
// by `indent` columns.
std::string OneLineOrTwo(const std::string& line, const std::string& more, int indent) {
  if (more.empty()) return line + "\n";
  if (DisplayWidth(line) + 2 + DisplayWidth(more) <= 100) return line + "  " + more + "\n";
  return line + "\n" + std::string(indent, ' ') + more + "\n";
}

}  // namespace

db::SessionKind SetSessionKind(db::Database& database, int64_t session_id, db::SessionKind kind) {
  db::WriteTransaction tx(database);
  if (!db::SessionExists(database, session_id)) {
    throw InputError({database.path(), 0, 0, "session"},
                     fmt::format("no session {} ({})", session_id,
                                 Hint(database.path(), {"sessions"})));
  }
  const db::SessionKind was = db::LoadSession(database, session_id)->kind;
  db::SetSessionKind(database, session_id, kind);
  if (was != kind) {
    db::AppendSessionNote(database, session_id,
                          std::string("kind ") + db::ToString(was) + " -> " + db::ToString(kind));
  }
  tx.commit();
  return was;
}

std::string FormatSessions(const std::vector<ListedSession>& sessions, bool json) {
  if (json) return JsonArray(sessions);
  if (sessions.empty()) return "no sessions\n";
  std::string text;
  for (const auto& s : sessions) {
    // The counts whole, beside the session or on the next line; the note on its own line
    // (a width-wrap had cut "2773 | usable" apart).
    text += OneLineOrTwo(
        fmt::format("{:>4}  {:<14} {:<9} {:<11} {}", s.id, Printable(s.robot), Printable(s.shown_state),
                    db::ToString(s.kind), Printable(TimeToTheSecond(s.started_at))),
        fmt::format("{} measured, {} skipped, {} usable, {} flagged{}", s.measured, s.skipped,
                    s.usable, s.flagged,
                    s.sweep_segments > 0 && s.measured + s.skipped == 0
                        ? fmt::format("; {} swept, paired when the sweep ends",
                                      Count(s.sweep_segments, "segment"))
                        : ""),
        6);
    if (!s.note.empty()) text += "      " + Printable(s.note) + "\n";
  }
  return WrapLines(text, 100, 6);
}

// Two lines a version: what it is, then how it validated and its life cycle.
std::string FormatVersions(const std::vector<VersionInfo>& versions, bool json,
                           const std::string& robot) {
  if (json) return JsonArray(versions);
  if (versions.empty()) return "robot " + robot + " has no parameter set yet\n";
  std::string text;
  for (const auto& v : versions) {
    std::string activated = "never active";
    if (!v.activations.empty()) {
      const auto& a = v.activations.back();
      activated = fmt::format("activated {} by {}", Printable(TimeToTheSecond(a.activated_at)),
                              Printable(a.activated_by));
      if (v.activations.size() > 1)
        activated += fmt::format(" ({} times)", v.activations.size());
    }
    if (v.drift && *v.drift)
      activated += fmt::format("  DRIFT against v{}", v.drift_against.value_or(0));
    text += fmt::format("{} v{:<3} {}  params {:<9} rank {:>2}  fitted on {} of {}\n",
                        v.active ? "*" : " ", v.version, Printable(TimeToTheSecond(v.created_at)),
                        Printable(v.params_spec), v.rank, Count(v.poses_fit, "pose"),
                        v.sessions.empty()
                            ? std::string("sessions not recorded")
                            : fmt::format("{} {}", v.sessions.size() == 1 ? "session" : "sessions",
                                          fmt::join(v.sessions, ",")));
    text += OneLineOrTwo(
        fmt::format("       validation mean {:.4f} max {:.4f} mm on {}", v.validation_mean_mm,
                    v.validation_max_mm, Count(v.poses_validation, "pose")),
        activated, 7);
    if (v.drift && *v.drift && (v.change_from_session || !v.cause.empty())) {
      text += fmt::format(
          "       {}{}\n",
          v.change_from_session
              ? fmt::format("the robot changed from session {}; fitted on the sessions since: ",
                            *v.change_from_session)
              : std::string(),
          Printable(v.cause.empty() ? std::string("no cause named") : v.cause));
    }
  }
  return WrapLines(text, 100, 2);
}

nlohmann::json ToJson(const db::RobotRow& r) {
  return {{"name", r.name},
          {"model", r.model_name},
          {"registered_at", r.created_at},
          {"sessions", r.sessions},
          {"active_version",
           r.active_version ? nlohmann::json(*r.active_version) : nlohmann::json(nullptr)},
          {"removed_at", r.removed_at.empty() ? nlohmann::json(nullptr) : nlohmann::json(r.removed_at)}};
}

nlohmann::json ToJson(const ListedSession& s) {
  nlohmann::json owner = nullptr;
  if (s.owner) owner = {{"pid", s.owner->pid}, {"host", s.owner->host}};
  return {{"id", s.id},
          {"robot", s.robot},
          {"state", s.shown_state},
          {"kind", db::ToString(s.kind)},
          {"owner", owner},
          {"note", s.note},
          {"started_at", s.started_at},
          {"finished_at",
           s.finished_at.empty() ? nlohmann::json(nullptr) : nlohmann::json(s.finished_at)},
          {"measured", s.measured},
          {"skipped", s.skipped},
          {"usable_points", s.usable},
          {"flagged_points", s.flagged},
          {"sweep_segments", s.sweep_segments}};
}

nlohmann::json ToJson(const VersionInfo& v) {
  auto number = [](double x) {
    return std::isfinite(x) ? nlohmann::json(x) : nlohmann::json(nullptr);
  };
  nlohmann::json activations = nlohmann::json::array();
  for (const auto& a : v.activations) {
    activations.push_back(
        {{"at", a.activated_at},
         {"by", a.activated_by},
         {"previous", a.previous_version ? nlohmann::json(*a.previous_version) : nlohmann::json()},
         {"note", a.note}});
  }
  nlohmann::json drift = nullptr;
  if (v.drift) {
    drift = {{"flag", *v.drift},
             {"against", v.drift_against ? nlohmann::json(*v.drift_against) : nlohmann::json()},
             {"change_from_session", v.change_from_session
                                         ? nlohmann::json(*v.change_from_session)
                                         : nlohmann::json()},
             {"cause", v.cause.empty() ? nlohmann::json() : nlohmann::json(v.cause)}};
  }
  return {{"version", v.version},
          {"active", v.active},
          {"created_at", v.created_at},
          {"params", v.params_spec},
          {"rank", v.rank},
          {"poses_fit", v.poses_fit},
          {"poses_validation", v.poses_validation},
          {"fit_mean_mm", number(v.fit_mean_mm)},
          {"validation_mean_mm", number(v.validation_mean_mm)},
          {"validation_max_mm", number(v.validation_max_mm)},
          {"sessions", v.sessions},
          {"since", v.since},
          {"activations", activations},
          {"drift", drift},
          {"floor_session",
           v.floor_session ? nlohmann::json(*v.floor_session) : nlohmann::json(nullptr)}};
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


}  // namespace armsig::workflows
