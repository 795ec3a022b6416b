// Sessions and their poses (the configurations a session measured or skipped), and the
// measured poses (joints + reduced target) read back for calibration.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "core/types.h"
#include "db/database.h"

namespace armsig::db {

// A session's state as stored (sessions.state): running while a process captures it, paused
// (resumable), completed, aborted (discarded: its measurements are not used).
enum class SessionState { kRunning, kPaused, kCompleted, kAborted };
// The stored word: "running", "paused", "completed", "aborted".
const char* ToString(SessionState state);
// The state a stored word names; std::invalid_argument for another word.
SessionState SessionStateOf(const std::string& text);

// A session created completed (an import) is finished at once: finished_at is set.
int64_t CreateSession(Database& db, int64_t robot_id, const std::string& lab_yaml,
                      const std::string& plan_json, SessionState state, const std::string& note);
void SetSessionState(Database& db, int64_t session_id, SessionState state);
// What a session was measured for (schema v13).
enum class SessionKind {
  kCalibration,  // the default: the nightly job fits it
  kTest,         // an ISO 9283 test: never fitted unless asked
  kCheck,        // data to judge a set where it was not fitted
};
const char* ToString(SessionKind kind);  // calibration | test | check
// The kind a word names; nullopt for another word.
std::optional<SessionKind> SessionKindNamed(const std::string& text);
void SetSessionKind(Database& db, int64_t session_id, SessionKind kind);
// A session whose measurements must not be used (its set-up was wrong): state `aborted`,
// the reason appended to its note ("discarded: …"). Its rows stay; LoadRobotPoses leaves
// it out.
void DiscardSession(Database& db, int64_t session_id, const std::string& reason);
// Appends to a session's note ("; " between).
void AppendSessionNote(Database& db, int64_t session_id, const std::string& text);

// The process that runs a session (capture, demo), schema v4: its pid, host name, and a
// token of its start (boot id and start tick), so that a reused pid is not taken for it.
struct SessionOwner {
  int64_t pid = 0;
  std::string host, started;
  bool operator==(const SessionOwner&) const = default;
};
void SetSessionOwner(Database& db, int64_t session_id, const SessionOwner& owner);
std::vector<int64_t> SessionIds(Database& db);
bool SessionExists(Database& db, int64_t session_id);

// A row of the sessions table with its robot's name: what every reader of a session takes.
struct SessionRow {
  int64_t id = 0;
  std::string robot;
  std::string lab_yaml, plan_json;  // "" when none was stored (imported poses)
  SessionState state = SessionState::kRunning;
  std::string note;
  std::string started_at, finished_at;  // ISO-8601 UTC; finished_at "" while not finished
  SessionKind kind = SessionKind::kCalibration;
  std::optional<SessionOwner> owner{};  // absent when none was recorded
};
std::optional<SessionRow> LoadSession(Database& db, int64_t session_id);
struct SessionSummary : SessionRow {
  int measured = 0, skipped = 0;  // configurations
  int usable = 0;                 // reduced points with coordinates
  int flagged = 0;                // of which carry a flag
  // Measured on the move: the sweep's segments stored; its configurations are paired (and
  // counted above) when the sweep completes.
  int sweep_segments = 0;
};
// Every session (of one robot when given), oldest first.
std::vector<SessionSummary> ListSessions(Database& db, std::optional<int64_t> robot_id);

// The lab file stored with the robot's newest session that has one ("" if none).
// The newest session of the robot stored with a lab file, and that file's text.
struct SessionLab {
  int64_t session = 0;
  std::string lab_yaml;
};
std::optional<SessionLab> LatestLabYaml(Database& db, int64_t robot_id);

// `controller_time_s`: the controller's own clock when it gave the joints (UR RTDE
// `timestamp`), when it has one.
int64_t InsertPose(Database& db, int64_t session_id, int seq, const std::string& label,
                   const std::optional<Eigen::VectorXd>& joints_rad, const std::string& status,
                   int attempts, std::optional<double> controller_time_s = std::nullopt);
// Plan indices already stored (measured or skipped) for a session.
std::vector<int> StoredSeqs(Database& db, int64_t session_id);

// Every measured configuration of the robot with a reduced point: joints + target, from
// every session that is not discarded (`aborted`).
// Pose ids are "<session>:<label>", and each pose's measurement frame is its session
// (MeasuredPose::frame = the session id). `since`: lower bound on the session start as
// stored (YYYY-MM-DDTHH:MM:SS.sssZ, UTC; empty = all). `max_pose_row` receives the newest
// pose row id.
// The queries of LoadRobotPoses and LoadSessionPoses (a test reads their plans).
extern const char* const kRobotPosesQuery;
extern const char* const kSessionPosesQuery;

std::vector<MeasuredPose> LoadRobotPoses(Database& db, int64_t robot_id, const std::string& since,
                                         int64_t* max_pose_row = nullptr);

// A session's measured configurations with their reduced points, in plan order, and
// each point's covariance (mm²). Their frame is the session id.
std::vector<MeasuredPose> LoadSessionPoses(Database& db, int64_t session_id,
                                           std::vector<Eigen::Matrix3d>* covariances = nullptr);

}  // namespace armsig::db
