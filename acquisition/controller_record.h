// What a robot controller says it is, asked once when a capture begins or resumes, checked
// against the lab and the store, and kept with the session and the robot (db/controllers.h):
// a controller of another model than the lab's robot model, or of another model or serial
// number than the robot as registered, is refused before anything is measured; so is one
// whose own kinematics (UR KinematicsInfo) changed since the session it resumes began.
#pragma once

#include <optional>
#include <string>

#include "db/controllers.h"
#include "db/stored_json.h"
#include "instruments/device.h"
#include "io/lab_file.h"

namespace armsig::acquisition {

struct ControllerFacts {
  std::optional<instruments::ControllerIdentity> identity;
  std::optional<instruments::ControllerKinematics> kinematics;
  // As the store keeps them (empty when the controller cannot say who it is).
  db::ControllerRecord Record() const;
  // "UR10 serial 2017301234, URSoftware 3.15.7 (kinematics 1a2b3c4d-…)"
  std::string Describe() const;
};

// Asks the controller who it is and for its own kinematics (both nullopt for a controller
// that cannot say). Controller and transport errors pass through.
ControllerFacts AskController(instruments::RobotController& controller);

// The kinematics as JSON ({"checksum", "dh_theta_rad", "dh_a_mm", "dh_d_mm",
// "dh_alpha_rad", "calibration_status", "calibration_state"}) and back (InputError naming the
// cell when it is not that).
std::string KinematicsJson(const instruments::ControllerKinematics& kinematics);
instruments::ControllerKinematics KinematicsFromJson(const std::string& text,
                                                     const db::JsonCell& cell);

// Whether the controller's model names the lab's robot model: both compared as lower-case
// letters and digits, the controller's name must begin the model's and not be followed by a
// digit ("UR10" fits ur10 and ur10e, not ur5 nor ur100). nullopt when the names cannot be
// compared (their leading letters differ: a model file named after the lab's own cell).
std::optional<bool> ModelFits(const std::string& controller_model, const std::string& model_name);

// Refuses (InputError naming the lab file, saying what to do) a controller that is not the
// lab's robot: another model than the lab's robot model; another model or serial than the
// robot `robot` as registered (when it is, and was captured from an identified controller);
// when resuming `session` (> 0), another identity or other kinematics than the session's.
void CheckControllerFacts(db::Database& db, const io::LabConfig& lab, const std::string& robot,
                          int64_t session, const ControllerFacts& facts);

// The controller's own calibration changed since the robot's previous session: the newest
// session's KinematicsInfo checksum differs from the one of the session before it (of those
// that stored one). "the controller's own calibration changed (KinematicsInfo checksum A in
// session 4, B in session 5)"; "" when it did not or the controller cannot say.
std::string ControllerCalibrationChange(db::Database& db, int64_t robot_id);

}  // namespace armsig::acquisition
