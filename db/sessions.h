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

int64_t CreateSession(Database& db, int64_t robot_id, const std::string& lab_yaml,
                      const std::string& plan_json, const std::string& state,
                      const std::string& note);
void SetSessionState(Database& db, int64_t session_id, const std::string& state);
std::vector<int64_t> SessionIds(Database& db);
bool SessionExists(Database& db, int64_t session_id);

struct SessionRow {
  int64_t id = 0;
  std::string robot;
  std::string lab_yaml, plan_json, state, note;
};
std::optional<SessionRow> LoadSession(Database& db, int64_t session_id);
struct SessionSummary {
  int64_t id = 0;
  std::string robot, state, note, started_at, finished_at;
  int measured = 0, skipped = 0;  // configurations
  int usable = 0;                 // reduced points with coordinates
  int flagged = 0;                // of which carry a flag
};
// Every session (of one robot when given), oldest first.
std::vector<SessionSummary> ListSessions(Database& db, std::optional<int64_t> robot_id);

// The lab file stored with the robot's newest session that has one ("" if none).
std::string LatestLabYaml(Database& db, int64_t robot_id);

int64_t InsertPose(Database& db, int64_t session_id, int seq, const std::string& label,
                   const std::optional<Eigen::VectorXd>& joints_rad, const std::string& status,
                   int attempts);
// Plan indices already stored (measured or skipped) for a session.
std::vector<int> StoredSeqs(Database& db, int64_t session_id);

// Every measured configuration of the robot with a reduced point: joints + target.
// Pose ids are "<session>:<label>". `since`: ISO date/time lower bound on the session
// start (empty = all). `max_pose_row` receives the newest pose row id (for idempotence).
std::vector<MeasuredPose> LoadRobotPoses(Database& db, int64_t robot_id, const std::string& since,
                                         int64_t* max_pose_row = nullptr);

// A session's measured configurations with their reduced points, in plan order, and
// each point's covariance (mm²).
std::vector<MeasuredPose> LoadSessionPoses(Database& db, int64_t session_id,
                                           std::vector<Eigen::Matrix3d>* covariances = nullptr);

}  // namespace armsig::db
