// Joint-angle errors periodic in each joint's own angle, the kind the real UR10 shows (its
// residual after the geometric fit: docs/explanation/residual-map.md, joint curves): gear
// transmission and encoder eccentricity make a joint's true angle differ from its encoder's
// by a few arc-seconds, repeating every turn:
//   θ_true = θ + Σ_k (s_k sin kθ + c_k cos kθ)   (k = 1 … orders, per joint)
// A virtual robot carries them beside its geometric errors (VirtualLab::SetJointErrors), so
// that its calibration has the real work to do. Pure.
#pragma once

#include <Eigen/Core>
#include <random>
#include <vector>

namespace armsig::simulation {

struct JointAngleErrors {
  // harmonics[j][k]: the sine and cosine amplitude (rad) of order k + 1 of joint j.
  struct Harmonic {
    double sin_rad = 0.0, cos_rad = 0.0;
  };
  std::vector<std::vector<Harmonic>> harmonics;

  bool empty() const { return harmonics.empty(); }
  // The error of joint `joint` at encoder angle `theta_rad`.
  double At(int joint, double theta_rad) const;
  // True angles for encoder angles (unchanged beyond the joints it has).
  Eigen::VectorXd TrueAngles(const Eigen::VectorXd& encoder_rad) const;
  // The largest error any joint can reach (the sum of its amplitudes), rad.
  double MaxRad() const;

  // Random amplitudes for `joints` joints and orders 1 … `orders`: order k's sine and cosine
  // each N(0, (amplitude / k)²), a joint's first order of the size `amplitude_rad`.
  static JointAngleErrors Random(int joints, int orders, double amplitude_rad, std::mt19937& rng);
};

}  // namespace armsig::simulation
