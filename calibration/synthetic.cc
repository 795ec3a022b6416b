#include "calibration/synthetic.h"

#include <string>

namespace armsig::calibration {

Eigen::VectorXd PaperTable3Parameters() {
  // Columns i = 1…7 of Table 3: a, b, c (mm); α, β, γ (1e-3 rad); then h1…h4 (1e-3 rad).
  const double a[7] = {-0.748, 0, -0.754, 0.887, 0, 0, 0.015};
  const double b[7] = {0.705, -0.039, 0, 0, 0.339, 0, -0.177};
  const double c[7] = {0, 0, 0, 0.455, 0, 0, -0.0133};
  const double alpha[6] = {0.140, -0.166, 5.336, -1.376, 0, 0};
  const double beta[6] = {-0.210, -0.530, 0.497, 1.320, -1.345, 6.348};
  const double gamma[6] = {-1.897, 7.876, -8.942, -15.161, -5.458, 0};
  const double h[4] = {-0.181, -1.437, -1.686, 0.235};
  Eigen::VectorXd p(43);
  for (int i = 0; i < 6; ++i) {
    p(6 * i + 0) = a[i];
    p(6 * i + 1) = b[i];
    p(6 * i + 2) = c[i];
    p(6 * i + 3) = alpha[i] * 1e-3;
    p(6 * i + 4) = beta[i] * 1e-3;
    p(6 * i + 5) = gamma[i] * 1e-3;
  }
  p(36) = a[6];
  p(37) = b[6];
  p(38) = c[6];
  for (int k = 0; k < 4; ++k) p(39 + k) = h[k] * 1e-3;
  return p;
}

Eigen::VectorXd RandomParameters(const RobotModel& model, double sigma_mm, double sigma_rad,
                                 double sigma_h_rad, std::mt19937& rng) {
  std::normal_distribution<double> normal(0.0, 1.0);
  Eigen::VectorXd p(model.num_parameters());
  for (int k = 0; k < model.num_parameters(); ++k) {
    const double s = k >= model.num_geometric()              ? sigma_h_rad
                     : model.UnitOf(k) == ParameterUnit::kMm ? sigma_mm
                                                             : sigma_rad;
    p(k) = s * normal(rng);
  }
  return p;
}

std::vector<Eigen::VectorXd> RandomConfigurations(const RobotModel& model, int count,
                                                  std::mt19937& rng, double range_rad) {
  const int n = model.num_joints();
  std::vector<Eigen::VectorXd> out;
  out.reserve(count);
  for (int m = 0; m < count; ++m) {
    Eigen::VectorXd q(n);
    for (int i = 0; i < n; ++i) {
      double lo = -range_rad, hi = range_rad;
      if (static_cast<int>(model.joint_min_rad.size()) == n) {
        lo = std::max(lo, model.joint_min_rad[i]);
        hi = std::min(hi, model.joint_max_rad[i]);
      }
      q(i) = std::uniform_real_distribution<double>(lo, hi)(rng);
    }
    out.push_back(q);
  }
  return out;
}

std::vector<Eigen::VectorXd> LabTestConfigurations(const RobotModel& model, std::mt19937& rng,
                                                   double range_rad) {
  const int n = model.num_joints();
  std::vector<Eigen::VectorXd> out;
  // Single-joint rotation tests: 3 postures per joint, 8 angles of that joint each.
  for (int j = 0; j < n; ++j) {
    for (const auto& posture : RandomConfigurations(model, 3, rng, range_rad)) {
      for (int k = 0; k < 8; ++k) {
        Eigen::VectorXd q = posture;
        q(j) = -range_rad + (2.0 * range_rad) * (k + 0.5) / 8.0;
        out.push_back(q);
      }
    }
  }
  // Line and circle tests: 4 short paths of 12 configurations with every joint moving a bit.
  std::uniform_real_distribution<double> step(-0.05, 0.05);
  for (const auto& start : RandomConfigurations(model, 4, rng, 0.7 * range_rad)) {
    Eigen::VectorXd direction(n);
    for (int i = 0; i < n; ++i) direction(i) = step(rng);
    for (int k = 0; k < 12; ++k) out.push_back(start + k * direction);
  }
  return out;
}

namespace {

// Configuration i measured at its true position plus N(0, noise_mm) per coordinate (no
// draw when the noise is 0); `kin` is left at that configuration.
MeasuredPose MeasuredPosition(Kinematics& kin, const Eigen::Isometry3d& world_from_base,
                              const Eigen::VectorXd& true_params, const Eigen::VectorXd& joints,
                              size_t i, double noise_mm, std::normal_distribution<double>& noise,
                              std::mt19937& rng) {
  MeasuredPose pose;
  pose.id = "P" + std::to_string(i + 1);
  pose.joints_rad = joints;
  pose.target_in_world = kin.Position(world_from_base, true_params, joints.data());
  if (noise_mm > 0.0) {
    for (int k = 0; k < 3; ++k) pose.target_in_world(k) += noise(rng);
  }
  return pose;
}

}  // namespace

std::vector<MeasuredPose> SimulatePoses(const RobotModel& model,
                                        const Eigen::Isometry3d& world_from_base,
                                        const Eigen::VectorXd& true_params,
                                        const std::vector<Eigen::VectorXd>& joints_rad,
                                        double noise_mm, std::mt19937& rng) {
  Kinematics kin(model);
  std::normal_distribution<double> noise(0.0, noise_mm);
  std::vector<MeasuredPose> poses;
  poses.reserve(joints_rad.size());
  for (size_t i = 0; i < joints_rad.size(); ++i) {
    poses.push_back(
        MeasuredPosition(kin, world_from_base, true_params, joints_rad[i], i, noise_mm, noise, rng));
  }
  return poses;
}

std::vector<MeasuredPose> SimulateSixDofPoses(const RobotModel& model,
                                              const Eigen::Isometry3d& world_from_base,
                                              const Eigen::VectorXd& true_params,
                                              const Eigen::Matrix3d& tool_rotation,
                                              const std::vector<Eigen::VectorXd>& joints_rad,
                                              double noise_mm, double noise_rad,
                                              std::mt19937& rng) {
  Kinematics kin(model);
  std::normal_distribution<double> position_noise(0.0, noise_mm), angle_noise(0.0, noise_rad);
  std::vector<MeasuredPose> poses;
  poses.reserve(joints_rad.size());
  for (size_t i = 0; i < joints_rad.size(); ++i) {
    MeasuredPose pose = MeasuredPosition(kin, world_from_base, true_params, joints_rad[i], i,
                                         noise_mm, position_noise, rng);
    Eigen::Vector3d turn = Eigen::Vector3d::Zero();
    if (noise_rad > 0.0) {
      for (int k = 0; k < 3; ++k) turn(k) = angle_noise(rng);
    }
    Eigen::Matrix3d noise = Eigen::Matrix3d::Identity();
    if (turn.norm() > 0) noise = Eigen::AngleAxisd(turn.norm(), turn.normalized()).toRotationMatrix();
    pose.orientation = MeasuredOrientation{kin.LastRotation() * tool_rotation * noise, std::nullopt};
    poses.push_back(std::move(pose));
  }
  return poses;
}

}  // namespace armsig::calibration
