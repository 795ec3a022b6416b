// A virtual robot controller running a program's motions, as a real one does with the same
// numbers: a joint target's joints are commanded as written; a Cartesian target is turned
// into joints by the controller's inverse kinematics on ITS model (programs/controller.h), in
// the configuration the target states (KUKA S/T, ABB cf) or nearest the joints the arm
// stands at (a UR, or qnear when the program gives it); the true robot then lands where its
// own kinematics — hidden errors and all — put the TCP.
//
// The motions run once each in the order they are written: the program's control flow
// (loops, branches, calls) is not interpreted. A motion whose target or tool is not known is
// skipped and named, as the compensation names it.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <string>
#include <vector>

#include "calibration/model.h"
#include "programs/controller.h"
#include "programs/program.h"
#include "simulation/emscon_simulator.h"
#include "simulation/joint_errors.h"

namespace armsig::simulation {

// The robot as it really is: a model, its true parameters and its joints' true angles off the
// encoders' (a virtual robot's, simulation/virtual_robots.h; none by default). The TCP of a
// tool hangs from the flange of the true chain, which the parameters' calibration-point
// offset shifts (the probe sits where the model says: that offset is the flange's own).
struct TrueRobot {
  calibration::RobotModel model;
  Eigen::VectorXd params;
  JointAngleErrors joint_errors;
};
Eigen::Isometry3d TrueTcp(const TrueRobot& robot, const Eigen::Isometry3d& tool, const Eigen::VectorXd& joints_rad);

struct ExecutedTarget {
  programs::TextPlace motion;    // the motion statement
  std::string instruction;
  int target = -1;               // index into Program::targets
  Eigen::Isometry3d tool = Eigen::Isometry3d::Identity();
  Eigen::Isometry3d commanded = Eigen::Isometry3d::Identity();  // the TCP pose its numbers state, robot base
  Eigen::VectorXd joints_rad;    // where the controller sent the arm
};

struct Execution {
  std::vector<ExecutedTarget> targets;      // every target reached, in order (via points too)
  std::vector<programs::NamedPlace> skipped;  // motions not run, and why
};

// Runs the motions from `start_rad` (the joints the arm stands at).
Execution RunProgram(const programs::Program& program, const programs::ControllerModel& controller,
                     const Eigen::VectorXd& start_rad);

// A robot in a lab with a laser tracker at the lab frame's origin: where each executed
// target's TCP really lands (the robot's repeatability drawn per arrival), as the tracker
// measures it (its noise model: the virtual emScon tracker's, TrackerSigmaMm), lab frame.
struct VirtualCell {
  TrueRobot robot;
  Eigen::Isometry3d lab_from_base = Eigen::Isometry3d::Identity();
  EmsconSimulatorOptions tracker;
  double repeatability_mm = 0.0;  // σ per axis of each arrival
  unsigned seed = 1;
};
std::vector<Eigen::Vector3d> MeasureLandings(const VirtualCell& cell, const Execution& run);

}  // namespace armsig::simulation
