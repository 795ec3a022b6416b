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
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "calibration/model.h"
#include "programs/controller.h"
#include "programs/program.h"
#include "simulation/emscon_simulator.h"
#include "simulation/joint_errors.h"
#include "simulation/virtual_arm.h"

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

// What a controller does when it runs a program, in the order written: each executed
// target a move to its joints, each wait (programs::Wait: WaitTime, WAIT SEC, sleep) the arm
// standing that long.
struct ProgramStep {
  int line = 0;
  std::optional<Eigen::VectorXd> joints_rad;  // a target, else a wait
  double wait_s = 0.0;
};
std::vector<ProgramStep> StepsOf(const Execution& run, const std::vector<programs::Wait>& waits);

// Plays steps on a virtual arm, one at a time as the arm gets there (call Tick from the
// controller's cycle): `move` starts the joint move of a target, a wait runs in physical time.
// A stop of the arm (protective, emergency, power off) ends the program.
class ProgramPlayer {
 public:
  enum class Status { kRunning, kFinished, kStopped };
  explicit ProgramPlayer(std::vector<ProgramStep> steps) : steps_(std::move(steps)) {}
  Status Tick(VirtualArm& arm, const std::function<void(const Eigen::VectorXd&)>& move);
  std::size_t next() const { return next_; }
  std::size_t size() const { return steps_.size(); }

 private:
  std::vector<ProgramStep> steps_;
  std::size_t next_ = 0;
  double wait_until_ = -1.0;  // physical time
};

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
