// What a robot controller said it is, stored with the session it began and with the robot
// (schema v13): model, serial number, software, and its own kinematics (UR KinematicsInfo:
// the checksum, and the DH table as JSON, written and read by acquisition/controller_record.h).
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "db/database.h"

namespace armsig::db {

struct ControllerRecord {
  std::string model, serial, software;
  std::string kinematics_checksum;  // "" when the controller has no kinematics to tell
  std::string kinematics_json;
  bool operator==(const ControllerRecord&) const = default;
};

// The controller as it identified itself when `session` began (or was resumed).
void SetSessionController(Database& db, int64_t session_id, const ControllerRecord& record);
// nullopt when the session stored none (a controller that cannot say, imported poses).
std::optional<ControllerRecord> SessionController(Database& db, int64_t session_id);

// The robot's: the model and serial number are set by its first identified session and
// never changed (they are the arm's identity); the kinematics follow its newest session.
void RecordRobotController(Database& db, int64_t robot_id, const ControllerRecord& record);
// nullopt when no session of the robot was captured from an identified controller.
std::optional<ControllerRecord> RobotControllerRecord(Database& db, int64_t robot_id);

// The controller's kinematics checksum of each session of the robot that stored one,
// oldest first (aborted sessions included: the controller's calibration is a fact of the
// arm, whatever became of the session's points).
struct SessionKinematics {
  int64_t session = 0;
  std::string started_at;
  std::string checksum;
};
std::vector<SessionKinematics> KinematicsHistory(Database& db, int64_t robot_id);

}  // namespace armsig::db
