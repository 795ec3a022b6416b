#include "simulation/virtual_lab.h"

#include <stdexcept>

#include "core/units.h"
#include "reduction/intersection.h"

namespace armsig::simulation {

VirtualLab::VirtualLab(calibration::RobotModel model, Eigen::VectorXd true_params,
                       Eigen::Isometry3d world_from_base, unsigned seed)
    : model_(std::move(model)),
      true_params_(std::move(true_params)),
      world_from_base_(world_from_base),
      joints_(Eigen::VectorXd::Zero(model_.num_joints())),
      seed_(seed) {
  // The robot's stream: its own seed sequence, apart from every station's.
  std::seed_seq robot_stream{seed_, 0x726f626fu};
  robot_rng_.seed(robot_stream);
}

void VirtualLab::SetRepeatability(double sigma_mm) {
  if (!(sigma_mm >= 0.0)) throw std::invalid_argument("virtual lab: repeatability must be >= 0");
  std::lock_guard lock(mutex_);
  repeatability_mm_ = sigma_mm;
}

int VirtualLab::AddStation(const VirtualStation& station) {
  std::lock_guard lock(mutex_);
  stations_.push_back(station);
  std::seed_seq stream{seed_, static_cast<unsigned>(stations_.size())};
  rng_.emplace_back(stream);
  aim_.push_back("robot");
  face_.push_back(1);
  return static_cast<int>(stations_.size()) - 1;
}

void VirtualLab::AddPoint(const std::string& id, const Eigen::Vector3d& position_mm) {
  std::lock_guard lock(mutex_);
  points_[id] = position_mm;
}

void VirtualLab::Aim(int station, const std::string& target) {
  std::lock_guard lock(mutex_);
  aim_.at(station) = target;
}

std::string VirtualLab::AimedAt(int station) const {
  std::lock_guard lock(mutex_);
  return aim_.at(station);
}

void VirtualLab::SetFace(int station, int face) {
  std::lock_guard lock(mutex_);
  face_.at(station) = face;
}

int VirtualLab::Face(int station) const {
  std::lock_guard lock(mutex_);
  return face_.at(station);
}

void VirtualLab::SetJoints(const Eigen::VectorXd& joints_rad) {
  std::lock_guard lock(mutex_);
  joints_ = joints_rad;
  if (repeatability_mm_ > 0.0) {
    std::normal_distribution<double> off(0.0, repeatability_mm_);
    landed_off_ = Eigen::Vector3d(off(robot_rng_), off(robot_rng_), off(robot_rng_));
  }
}

void VirtualLab::SetJointErrors(JointAngleErrors errors) {
  std::lock_guard lock(mutex_);
  joint_errors_ = std::move(errors);
}

Eigen::VectorXd VirtualLab::Joints() const {
  std::lock_guard lock(mutex_);
  return joints_;
}

Eigen::Vector3d VirtualLab::TruePositionLocked(const std::string& target) const {
  if (target == "robot") {
    calibration::Kinematics kin(model_);
    const Eigen::VectorXd q = joint_errors_.TrueAngles(joints_);
    return kin.Position(world_from_base_, true_params_, q.data()) + landed_off_;
  }
  if (auto it = points_.find(target); it != points_.end()) return it->second;
  for (const auto& s : stations_) {
    if (s.pose.id == target) return s.pose.position_mm;
  }
  throw std::invalid_argument("virtual lab: unknown target '" + target + "'");
}

Eigen::Vector3d VirtualLab::RobotTargetAt(const Eigen::VectorXd& joints_rad) const {
  std::lock_guard lock(mutex_);
  calibration::Kinematics kin(model_);
  const Eigen::VectorXd q = joint_errors_.TrueAngles(joints_rad);
  return kin.Position(world_from_base_, true_params_, q.data()) + landed_off_;
}

Eigen::Vector3d VirtualLab::TruePosition(const std::string& target) const {
  std::lock_guard lock(mutex_);
  return TruePositionLocked(target);
}

AngleReading VirtualLab::Read(int station, double* distance_mm) {
  std::lock_guard lock(mutex_);
  const VirtualStation& s = stations_.at(station);
  const Eigen::Vector3d x = TruePositionLocked(aim_.at(station));
  const AngleReading truth =
      reduction::PredictReading(s.pose.position_mm, s.pose.world_from_station, x);
  AngleReading r = reduction::ApplyInstrumentErrors(truth, face_.at(station), s.errors);
  std::mt19937& rng = rng_.at(station);
  std::normal_distribution<double> angle(0.0, s.sigma_angle_rad);
  r.hz_rad = WrapTwoPi(r.hz_rad + angle(rng));
  r.v_rad += angle(rng);
  if (distance_mm) {
    std::normal_distribution<double> d(0.0, s.sigma_distance_mm);
    *distance_mm = (x - s.pose.position_mm).norm() + d(rng);
  }
  return r;
}

}  // namespace armsig::simulation
