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
};
// Every robot, by name.
std::vector<RobotRow> ListRobots(Database& db);

// The robot model file's text as stored with the robot ("" for an unknown id).
std::string RobotModelYaml(Database& db, int64_t robot_id);

}  // namespace armsig::db
