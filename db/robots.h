// The robots table: a robot's name and the model it was registered with.
#pragma once

#include <cstdint>
#include <optional>
#include <string>

#include "db/database.h"

namespace armsig::db {

int64_t EnsureRobot(Database& db, const std::string& name, const std::string& model_name,
                    const std::string& model_yaml);
std::optional<int64_t> FindRobot(Database& db, const std::string& name);
// The robot model file's text as stored with the robot ("" for an unknown id).
std::string RobotModelYaml(Database& db, int64_t robot_id);

}  // namespace armsig::db
