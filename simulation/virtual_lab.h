// The truth behind the virtual instruments: a robot with hidden errors, station poses,
// per-station instrument errors and noise, and named fixed points (station centres,
// scale-bar ends). Thread-safe: simulators on several threads read it.
#pragma once

#include <map>
#include <mutex>
#include <random>
#include <string>
#include <vector>

#include "calibration/model.h"
#include "core/types.h"
#include "reduction/instrument_errors.h"
#include "simulation/joint_errors.h"

namespace armsig::simulation {

struct VirtualStation {
  StationPose pose;
  reduction::InstrumentErrors errors;
  double sigma_angle_rad = 0.0;
  double sigma_distance_mm = 0.0;
};

class VirtualLab {
 public:
  VirtualLab(calibration::RobotModel model, Eigen::VectorXd true_params,
             Eigen::Isometry3d world_from_base, unsigned seed = 1);

  int AddStation(const VirtualStation& station);
  void AddPoint(const std::string& id, const Eigen::Vector3d& position_mm);

  // What each station is aimed at: "robot" (the target on the robot) or a point id.
  void Aim(int station, const std::string& target);
  std::string AimedAt(int station) const;
  void SetFace(int station, int face);
  int Face(int station) const;
  // The robot's own repeatability, distinct from the instruments' noise: every move
  // (SetJoints) lands N(0, σ²) per axis off the true kinematics, and stays there while the
  // robot stands, whatever the instruments read. 0 (the default): the robot lands exactly.
  // Drawn from a stream of its own, so the instruments' noise does not change with it.
  void SetRepeatability(double sigma_mm);
  void SetJoints(const Eigen::VectorXd& joints_rad);
  Eigen::VectorXd Joints() const;
  // Joint-angle errors periodic in each joint's own angle (simulation/joint_errors.h): the
  // robot's true joint angles are the encoders' (SetJoints) plus them. None by default.
  void SetJointErrors(JointAngleErrors errors);
  const JointAngleErrors& joint_errors() const { return joint_errors_; }

  // A noisy reading of what the station is aimed at, in its current face, with its
  // instrument errors; distance if asked.
  AngleReading Read(int station, double* distance_mm = nullptr);
  Eigen::Vector3d TruePosition(const std::string& target) const;
  // Where the robot's target truly is (world frame, mm) with the encoders at `joints_rad`:
  // the true kinematics, joint-angle errors and the current move's repeatability offset.
  // Side-effect free: an instrument that samples the arm on its own clock asks for the
  // joints of that instant.
  Eigen::Vector3d RobotTargetAt(const Eigen::VectorXd& joints_rad) const;

  const calibration::RobotModel& model() const { return model_; }
  const Eigen::VectorXd& true_params() const { return true_params_; }
  const Eigen::Isometry3d& world_from_base() const { return world_from_base_; }
  const VirtualStation& station(int i) const { return stations_.at(i); }
  int station_count() const { return static_cast<int>(stations_.size()); }

 private:
  Eigen::Vector3d TruePositionLocked(const std::string& target) const;
  mutable std::mutex mutex_;
  calibration::RobotModel model_;
  Eigen::VectorXd true_params_;
  Eigen::Isometry3d world_from_base_;
  std::vector<VirtualStation> stations_;
  std::vector<std::string> aim_;
  std::vector<int> face_;
  std::map<std::string, Eigen::Vector3d> points_;
  Eigen::VectorXd joints_;
  JointAngleErrors joint_errors_;
  double repeatability_mm_ = 0.0;
  Eigen::Vector3d landed_off_ = Eigen::Vector3d::Zero();  // this move's repeatability error
  std::mt19937 robot_rng_;
  // One noise stream per station (seeded by the lab's seed and the station's index): the
  // noise of a run does not depend on the order the instruments' threads happen to read
  // in, so a seed repeats a run exactly.
  unsigned seed_;
  std::vector<std::mt19937> rng_;
};

}  // namespace armsig::simulation
