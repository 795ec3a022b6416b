// The robots table: a robot's name and the model it was registered with.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "db/database.h"

namespace armsig::db {

int64_t EnsureRobot(Database& db, const std::string& name, const std::string& model_name,
                    const std::string& model_yaml);
std::optional<int64_t> FindRobot(Database& db, const std::string& name);
struct RobotRow {
  int64_t id = 0;
  std::string name, model_name, created_at;
  int sessions = 0;
  std::optional<int> active_version;
  std::string removed_at;  // "" while in use
};
// Every robot in use, by name; with `removed` the removed ones too.
std::vector<RobotRow> ListRobots(Database& db, bool removed = false);

// ---- A robot's history (schema v15): rename, remove, restore, sessions moved ----
// Each change is a row of robot_events with the reason and the user; sessions, parameter
// sets, activations and jobs keep pointing at the robot's id, so its whole history follows a
// rename. Throw InputError naming what is wrong (an unknown robot, a name taken, a removed
// robot asked to work, a session of another robot's joint count).
struct RobotEvent {
  std::string event;  // renamed | removed | restored | session_moved_in | session_moved_out
  std::optional<int64_t> session_id;
  std::string detail, reason, at, by_user;
};
void RenameRobot(Database& db, const std::string& name, const std::string& new_name,
                 const std::string& reason, const std::string& user);
// Removed: hidden from `robot list`, refused for new work (capture, import, recalibrate,
// schedule), every row kept; its name stays taken until it is renamed.
void RemoveRobot(Database& db, const std::string& name, const std::string& reason,
                 const std::string& user);
void RestoreRobot(Database& db, const std::string& name, const std::string& reason,
                  const std::string& user);
// Moves a session (its poses, readings and points) to robot `to`, of the same number of
// joints; a session still running (being captured) is refused. Returns the robot it left.
std::string MoveSession(Database& db, int64_t session_id, const std::string& to,
                        const std::string& reason, const std::string& user);
std::vector<RobotEvent> RobotEvents(Database& db, int64_t robot_id);
// The id of a robot that may take new work; InputError naming the removal (when, why, how to
// bring it back) for a removed one; nullopt for an unknown name.
std::optional<int64_t> FindRobotInUse(Database& db, const std::string& name);

// The robot model file's text as stored with the robot ("" for an unknown id).
std::string RobotModelYaml(Database& db, int64_t robot_id);

}  // namespace armsig::db
