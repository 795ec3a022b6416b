#include "simulation/joint_errors.h"

#include <cmath>

namespace armsig::simulation {

double JointAngleErrors::At(int joint, double theta) const {
  if (joint < 0 || joint >= static_cast<int>(harmonics.size())) return 0.0;
  double e = 0.0;
  for (size_t k = 0; k < harmonics[joint].size(); ++k) {
    const double order = static_cast<double>(k + 1);
    e += harmonics[joint][k].sin_rad * std::sin(order * theta) +
         harmonics[joint][k].cos_rad * std::cos(order * theta);
  }
  return e;
}

Eigen::VectorXd JointAngleErrors::TrueAngles(const Eigen::VectorXd& encoder) const {
  Eigen::VectorXd out = encoder;
  for (Eigen::Index j = 0; j < encoder.size(); ++j) out(j) += At(static_cast<int>(j), encoder(j));
  return out;
}

double JointAngleErrors::MaxRad() const {
  double most = 0.0;
  for (const auto& joint : harmonics) {
    double sum = 0.0;
    for (const auto& h : joint) sum += std::hypot(h.sin_rad, h.cos_rad);
    most = std::max(most, sum);
  }
  return most;
}

JointAngleErrors JointAngleErrors::Random(int joints, int orders, double amplitude,
                                          std::mt19937& rng) {
  JointAngleErrors e;
  e.harmonics.resize(joints);
  for (auto& joint : e.harmonics) {
    for (int k = 1; k <= orders; ++k) {
      std::normal_distribution<double> size(0.0, amplitude / k);
      joint.push_back({size(rng), size(rng)});
    }
  }
  return e;
}

}  // namespace armsig::simulation
