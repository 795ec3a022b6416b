// Using an arm signature: predicted positions, compensated joint angles (what makes
// offline programs land), corrected nominal transforms, and the comparison of two
// parameter sets.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <optional>
#include <string>
#include <vector>

#include "calibration/model.h"
#include "core/error.h"
#include "core/types.h"

namespace armsig::calibration {

class ResidualMap;

// Rigid best fit (Umeyama) of the model's positions under `params` to measured poses:
// the measuring frame of new data for an existing parameter set. nullopt if degenerate.
std::optional<Eigen::Isometry3d> AlignBaseWithParams(const RobotModel& model,
                                                     const Eigen::VectorXd& params,
                                                     const std::vector<MeasuredPose>& poses);

struct JointSolveOptions {
  double tolerance_mm = 1e-6;
  int max_iterations = 100;
  double damping_mm = 1.0;    // λ of the damped least squares, in mm
  double max_step_rad = 0.2;  // per iteration and joint
  void Check() const;
};

struct JointSolution {
  // kOk; kNotConverged: no joint angles reach the target (it is out of reach, or the
  // iteration stalled); kOutOfRange: the solution leaves a joint's limits; kNonFinite:
  // a non-finite seed, target or model gave no number at all.
  SolveStatus status;
  Eigen::VectorXd joints_rad;
  double residual_mm = 0.0;
  int iterations = 0;
  bool map_extrapolated = false;  // the residual map was not applied: outside its support
};

// Encoder angles for which the model (with `params`) puts the target at `target_mm`,
// by damped least squares from `seed` with minimum-norm steps (the redundant degrees
// of freedom stay near the seed: the tool keeps its orientation for small corrections).
// With a residual map (calibration/residual_map.h) the position is the parametric one
// plus the map's correction, and the iteration uses the map's derivative by the joint
// angles; `map_extrapolated` is set when the solution lies outside the map's support
// (there the parametric model alone was used).
JointSolution SolveJoints(const RobotModel& model, const Eigen::Isometry3d& world_from_base,
                          const Eigen::VectorXd& params, const Eigen::Vector3d& target_mm,
                          const Eigen::VectorXd& seed_rad, const JointSolveOptions& options = {},
                          const ResidualMap* map = nullptr);

// kOk, or kOutOfRange naming the first joint outside the model's limits (when it has them).
SolveStatus JointLimitStatus(const RobotModel& model, const Eigen::VectorXd& joints_rad);

// The model with the parameters folded in: N_i' = N_i·H_i (N_1' = base·H_1), tool
// x̄' = x̄ + [a b c], h-terms kept as fixed values. Its nominal is the calibrated robot.
RobotModel CorrectedModel(const RobotModel& model, const Eigen::VectorXd& params,
                          const std::optional<Eigen::Isometry3d>& world_from_base);

struct ParameterChange {
  int parameter = -1;
  double change = 0.0;  // new − old (mm or rad)
  double z = 0.0;       // change / √(σ_old² + σ_new²); 0 when neither has a sigma
};
std::vector<ParameterChange> CompareParameters(const Eigen::VectorXd& old_params,
                                               const Eigen::VectorXd& old_sigmas,
                                               const Eigen::VectorXd& new_params,
                                               const Eigen::VectorXd& new_sigmas);

}  // namespace armsig::calibration
