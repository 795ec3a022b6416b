// The virtual robots of `armsig demo --robot NAME` and the controller simulators: on the
// nominal model the caller reads (io/builtin_models.h has their files), hidden errors of the kind the real arm shows — geometric
// (link lengths, axis directions and joint zeros off by tenths of a millimetre and of a
// milliradian) and joint-angle errors periodic in each joint's own angle, a few arc-seconds
// (simulation/joint_errors.h) — where it stands in a tracker lab, and what its controller
// says it is, with its own factory kinematics (UR KinematicsInfo). Adding a robot is one
// entry in virtual_robots.cc.
#pragma once

#include <Eigen/Geometry>
#include <string>
#include <vector>

#include "calibration/model.h"
#include "instruments/device.h"
#include "simulation/joint_errors.h"

namespace armsig::simulation {

struct VirtualRobot {
  std::string name;         // ur10
  std::string description;  // "a Universal Robots UR10"
  calibration::RobotModel model;  // nominal
  Eigen::VectorXd true_params;  // hidden errors, the model's parameter vector (mm, rad)
  JointAngleErrors joint_errors;
  Eigen::VectorXd home_rad;
  Eigen::Isometry3d world_from_base = Eigen::Isometry3d::Identity();  // tracker at the origin
  instruments::ControllerIdentity identity;     // model, serial (software: the controller's)
  instruments::ControllerKinematics kinematics;  // the controller's own (factory) DH table
};

// The robot `name` on its nominal `model`, with errors drawn from `seed`. A model with a known
// tool mounting (calibration::ToolMounting) opts in to a physically consistent truth for it:
// the probe exactly where the file says and a planted turn of the flange (1 mrad), the arm's
// other errors those of the fitted-mounting robot. std::invalid_argument for a name VirtualRobotNames() has not, or a model of another joint
// count.
VirtualRobot MakeVirtualRobot(const std::string& name, const calibration::RobotModel& model,
                              unsigned seed);
std::vector<std::string> VirtualRobotNames();

}  // namespace armsig::simulation
