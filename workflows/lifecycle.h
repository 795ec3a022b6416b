// The life of a lab's database: robots registered with their models, measured poses
// from anywhere stored as sessions, sessions read back, parameter-set versions listed and
// activated (roll back or forward).
#pragma once

#include <random>

#include <cstdint>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "calibration/model.h"
#include "core/types.h"
#include "db/calibrations.h"
#include "db/database.h"
#include "db/robots.h"
#include "db/sessions.h"

namespace armsig::workflows {

// Registers `name` with the model file at `model_path` (read by the strict model
// reader; its text is stored). Returns true when added, false when the robot already has
// exactly this model; InputError when the name is taken with another model.
bool RegisterRobot(db::Database& database, const std::string& name, const std::string& model_path);

// The model a registered robot was stored with. InputError (naming `robot add`) for an
// unknown robot.
calibration::RobotModel RegisteredModel(db::Database& database, const std::string& robot);

// What measured poses are: their joints and targets, in order (not their ids), as a
// stable 64-bit FNV-1a digest in hex. Equal digests = the same measurements.
std::string PosesDigest(const std::vector<MeasuredPose>& poses);
// The same, one pose at a time.
class PosesDigester {
 public:
  void Add(const MeasuredPose& pose);
  std::string Hex() const;

 private:
  uint64_t hash_ = 0xcbf29ce484222325ULL;  // core::kFnv1a64Offset
};

struct StoredPoses {
  int64_t session = 0;     // the new session, or the one that already holds these poses
  bool duplicate = false;  // nothing stored: `session` holds exactly these poses already
  std::string digest;      // PosesDigest of the poses
};
// Stores measured poses (joints + target in the measuring frame) as a new completed
// session of a registered robot, in one transaction; the nightly job uses it like a
// captured session. Idempotent: when a session of the robot already holds exactly these
// joints and targets (the same file imported twice), nothing is stored and that session
// is named, unless `allow_duplicate`. InputError for an unknown robot or joints that do
// not fit its model. `covariances_mm2`: each pose's target covariance (from a point
// table's sigmas), empty or NaN where not known.
StoredPoses StorePosesSession(db::Database& database, const std::string& robot,
                              const std::vector<MeasuredPose>& poses, const std::string& source,
                              bool allow_duplicate = false,
                              const std::vector<Eigen::Matrix3d>& covariances_mm2 = {},
                              db::SessionKind kind = db::SessionKind::kCalibration);

// StorePosesSession one pose at a time (a file read row by row): the write transaction and
// the session begin with the writer, each Add stores a pose, Finish commits (or, when the
// poses are a copy of a stored session, rolls back and names it). A writer destroyed
// before Finish stores nothing.
// Before anything is kept, Finish checks the poses against the robot (calibration/
// data_checks.h): at least three distinct configurations (a robot that did not move gives
// one), and the robot's nominal model rigidly placed on them within centimetres — another
// robot's poses, another tool's or other units are refused, saying which reading would fit.
// The check uses every pose up to kDoorSample, then a seeded random sample of that size.
class PosesSessionWriter {
 public:
  PosesSessionWriter(db::Database& database, const std::string& robot, const std::string& source,
                     db::SessionKind kind = db::SessionKind::kCalibration);
  void Add(const MeasuredPose& pose, const Eigen::Matrix3d* covariance_mm2 = nullptr);
  StoredPoses Finish(bool allow_duplicate);
  size_t poses() const { return count_; }
  static constexpr size_t kDoorSample = 4000;

 private:
  void CheckAtTheDoor() const;
  db::Database& database_;
  std::string robot_, source_;
  int64_t robot_id_ = 0;
  int num_joints_ = 0;
  std::string model_name_;
  calibration::RobotModel model_;
  std::vector<MeasuredPose> sample_;  // for the door check
  std::mt19937 sampler_{1};
  db::WriteTransaction tx_;
  int64_t session_ = 0;
  size_t count_ = 0;
  PosesDigester digest_;
};

// A session's measured poses with their reduced targets (pose ids = the session's labels).
// InputError for an unknown session.
std::vector<MeasuredPose> SessionPoses(db::Database& database, int64_t session_id);
// The number of joints of the session's robot (its model), so that a session without a
// usable pose still exports the full poses header.
int SessionJoints(db::Database& database, int64_t session_id);

// A session as `sessions` lists it: as stored, and the state it is shown in (a `running`
// session whose process is gone is `interrupted`, an `aborted` one `discarded`:
// acquisition::DisplayState).
struct ListedSession : db::SessionSummary {
  std::string shown_state;
};
// Sessions, optionally of one robot (InputError when it is unknown).
std::vector<ListedSession> Sessions(db::Database& database, const std::string& robot);

// A session whose measurements no recalibration may use (a wrong set-up found later, a
// reflector that was not on the robot): stored state `aborted`, shown `discarded`, the
// reason in its note; its rows stay. Refused (InputError) for an unknown session and for
// one a live process is capturing. `RestoreSession` undoes it: the session is `completed`
// when every configuration of its plan is stored, else `paused`; InputError when it was
// not discarded. Both in one write transaction; return the state now stored.
db::SessionState DiscardSession(db::Database& database, int64_t session_id,
                                const std::string& reason);
db::SessionState RestoreSession(db::Database& database, int64_t session_id);
// What a session is for (db::SessionKind): the nightly job fits `calibration` sessions only
// (unless `recalibrate --kinds` says otherwise) and tries a new set on the others. The change
// is noted on the session. Returns the kind it had.
db::SessionKind SetSessionKind(db::Database& database, int64_t session_id, db::SessionKind kind);

struct VersionInfo {
  int version = 0;
  bool active = false;
  std::string created_at, params_spec;
  int rank = 0, poses_fit = 0, poses_validation = 0;
  double fit_mean_mm = 0.0, validation_mean_mm = 0.0, validation_max_mm = 0.0;
  std::vector<int64_t> sessions;  // session ids the set was fitted from (when recorded)
  std::string since;              // the --since it was asked with ("" = all)
  std::vector<db::Activation> activations{};  // every time it was made active, oldest first
  std::optional<bool> drift{};  // its drift decision against the set before, when made
  std::optional<int> drift_against{};
  // The nightly job's record: the change point it was fitted after (the first session its
  // window and every later window may use) and the named cause of the drift, when any.
  std::optional<int64_t> floor_session{};
  std::optional<int64_t> change_from_session{};
  std::string cause{};
};
// Every parameter set of a robot, oldest first. InputError for an unknown robot.
std::vector<VersionInfo> Versions(db::Database& database, const std::string& robot);

// Makes `version` the robot's active set (one transaction, recorded in the activation
// history as by `activate` with `note`) and logs it; the active version itself changes and
// records nothing. Returns the version that was active before. InputError for an unknown
// robot or version.
std::optional<int> Activate(db::Database& database, const std::string& robot, int version,
                            const std::string& note = "");

// A robot's history when the lab reorganises (db/robots.h): renamed, removed (hidden, no new
// work, every row kept), restored; a session moved to another robot of the same number of
// joints (the robot it leaves is returned). The user running the command is recorded.
void RenameRobot(db::Database& database, const std::string& name, const std::string& new_name,
                 const std::string& reason);
void RemoveRobot(db::Database& database, const std::string& name, const std::string& reason);
void RestoreRobot(db::Database& database, const std::string& name, const std::string& reason);
std::string MoveSession(db::Database& database, int64_t session_id, const std::string& robot,
                        const std::string& reason);
// `robot history NAME`: every change of the robot, oldest first (a table, or JSON).
std::string FormatRobotHistory(db::Database& database, const std::string& robot, bool json);

// What `robot list`, `sessions` and `versions` print: a table, or a JSON array.
std::string FormatRobots(const std::vector<db::RobotRow>& robots, bool json,
                         const std::string& db_path);
std::string FormatSessions(const std::vector<ListedSession>& sessions, bool json);
std::string FormatVersions(const std::vector<VersionInfo>& versions, bool json,
                           const std::string& robot);

nlohmann::json ToJson(const db::RobotRow& robot);
nlohmann::json ToJson(const ListedSession& session);
nlohmann::json ToJson(const VersionInfo& version);

// The file lock of one robot's recalibration beside the SQLite database
// ("lab.db.recalibrate.puma.lock"; characters other than [A-Za-z0-9._-] as %XX).
std::string RobotLockPath(const std::string& db_path, const std::string& robot);

}  // namespace armsig::workflows
