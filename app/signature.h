// A robot's stored arm signature, in the model's parameter order.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <optional>
#include <string>

#include "calibration/model.h"
#include "db/database.h"
#include "db/store.h"

namespace armsig::app {

struct Signature {
  int version = 0;
  Eigen::VectorXd params, sigmas;
  std::optional<Eigen::Isometry3d> world_from_base;  // the measuring frame of its data
};

Signature SignatureOf(const calibration::RobotModel& model, const db::StoredCalibration& stored);

struct ActiveSignature {
  calibration::RobotModel model;
  Signature signature;
};
// Throws InputError naming the robot when it is unknown or has no active set.
ActiveSignature LoadActiveSignature(db::Database& database, const std::string& robot);

}  // namespace armsig::app
