#include "calibration/compensation.h"

#include <fmt/format.h>

#include <Eigen/Cholesky>
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "calibration/damped_step.h"
#include "calibration/residual_map.h"
#include "core/plausibility.h"
#include "core/spread.h"
#include "core/text.h"
#include "core/units.h"

namespace armsig::calibration {

std::optional<Eigen::Isometry3d> AlignBaseWithParams(const RobotModel& model,
                                                     const Eigen::VectorXd& params,
                                                     const std::vector<MeasuredPose>& poses) {
  const int m = static_cast<int>(poses.size());
  if (m < 3) return std::nullopt;
  Kinematics kin(model);
  Eigen::Matrix3Xd from(3, m), to(3, m);
  for (int i = 0; i < m; ++i) {
    from.col(i) = kin.Position(Eigen::Isometry3d::Identity(), params, poses[i].joints_rad.data());
    to.col(i) = poses[i].target_in_world;
  }
  // Not on one line, and not all in one point either (every value 0: "0 < 0" let poses that
  // never move the robot through).
  const Eigen::Vector3d spread = PrincipalSpread(from);
  if (!(spread(1) > 1e-6 * spread(0))) return std::nullopt;
  Eigen::Isometry3d base = Eigen::Isometry3d::Identity();
  const bool weighted = std::any_of(poses.begin(), poses.end(), [](const MeasuredPose& p) { return p.weight != 1.0; });
  if (!weighted) {
    base.matrix() = Eigen::umeyama(from, to, false);
    return base;
  }
  // Poses of their own weight (paired on the move): the weighted rigid fit, as the
  // weighted least squares of the estimation that follows it.
  double total = 0.0;
  Eigen::Vector3d mean_from = Eigen::Vector3d::Zero(), mean_to = Eigen::Vector3d::Zero();
  for (int i = 0; i < m; ++i) {
    total += poses[i].weight;
    mean_from += poses[i].weight * from.col(i);
    mean_to += poses[i].weight * to.col(i);
  }
  mean_from /= total;
  mean_to /= total;
  Eigen::Matrix3d cross = Eigen::Matrix3d::Zero();
  for (int i = 0; i < m; ++i)
    cross += poses[i].weight * (to.col(i) - mean_to) * (from.col(i) - mean_from).transpose();
  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(cross, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d d = Eigen::Matrix3d::Identity();
  if ((svd.matrixU() * svd.matrixV().transpose()).determinant() < 0.0) d(2, 2) = -1.0;
  base.linear() = svd.matrixU() * d * svd.matrixV().transpose();
  base.translation() = mean_to - base.linear() * mean_from;
  return base;
}

void JointSolveOptions::Check() const {
  if (!(tolerance_mm > 0) || max_iterations < 1 || !(damping_mm >= 0) || !(max_step_rad > 0)) {
    throw std::invalid_argument("invalid joint solver options");
  }
}

JointSolution SolveJoints(const RobotModel& model, const Eigen::Isometry3d& world_from_base,
                          const Eigen::VectorXd& params, const Eigen::Vector3d& target_mm,
                          const Eigen::VectorXd& seed_rad, const JointSolveOptions& options,
                          const ResidualMap* map) {
  options.Check();
  const int n = model.num_joints();
  Kinematics kin(model);
  JointSolution s;
  s.joints_rad = seed_rad;
  Eigen::Matrix<double, 3, Eigen::Dynamic> jp(3, model.num_parameters());
  Eigen::Matrix<double, 3, Eigen::Dynamic> map_jacobian(3, n);
  // Position (parametric + the map's correction in the measuring frame) and ∂x/∂θ̄.
  Eigen::VectorXd corrected(n);
  auto position = [&](const Eigen::VectorXd& q, Eigen::MatrixXd* jacobian) {
    // The map's joint curves correct the angles the parametric model sees.
    const bool curves_inside = !map || map->CorrectJoints(q.data(), corrected.data());
    Eigen::Vector3d x =
        kin.PositionAndJacobian(world_from_base, params, map ? corrected.data() : q.data(), jp);
    // ∂x/∂θ̄ (encoder angles): the joint Jacobian; the terms' and the curves' own dependence
    // on the angles is second order (a coefficient times a basis's slope) and left to the
    // iteration.
    if (jacobian) {
      jacobian->resize(3, n);
      kin.WriteJointJacobian(*jacobian);
    }
    if (map) {
      const MapPrediction p = map->PredictWithJacobian(q.data(), map_jacobian);
      s.map_extrapolated = !(p.supported && curves_inside);
      x += world_from_base.linear() * p.correction_in_base_mm;
      if (jacobian) *jacobian += world_from_base.linear() * map_jacobian;
    }
    return x;
  };
  Eigen::MatrixXd j;
  StallWatch watch;
  DampedStepper stepper;
  for (; s.iterations < options.max_iterations; ++s.iterations) {
    const Eigen::Vector3d x = position(s.joints_rad, &j);
    const Eigen::Vector3d e = target_mm - x;
    s.residual_mm = e.norm();
    if (s.residual_mm < options.tolerance_mm) break;
    s.joints_rad += stepper.Step(j, e, s.residual_mm, options);
    if (watch.Stalled(s.residual_mm)) break;
  }
  s.residual_mm = (target_mm - position(s.joints_rad, nullptr)).norm();
  if (!std::isfinite(s.residual_mm) || !s.joints_rad.allFinite()) {
    s.status = {SolveCode::kNonFinite,
                "the solution is not a finite number (seed, target or "
                "parameters not finite)"};
    return s;
  }
  if (s.residual_mm > options.tolerance_mm * 10) {
    s.status = {SolveCode::kNotConverged,
                fmt::format("no joint angles reach the target (closest {:.3f} mm)", s.residual_mm)};
    return s;
  }
  s.status = JointLimitStatus(model, s.joints_rad);
  return s;
}

SolveStatus JointLimitStatus(const RobotModel& model, const Eigen::VectorXd& q) {
  const int n = model.num_joints();
  if (static_cast<int>(model.joint_min_rad.size()) != n ||
      static_cast<int>(model.joint_max_rad.size()) != n || q.size() != n) {
    return {};
  }
  for (int i = 0; i < n; ++i) {
    if (q(i) < model.joint_min_rad[i] || q(i) > model.joint_max_rad[i]) {
      return {SolveCode::kOutOfRange,
              fmt::format("joint {} at {:.2f} deg, outside its limits [{:.2f}, {:.2f}]", i + 1,
                          q(i) / kRadPerDeg, model.joint_min_rad[i] / kRadPerDeg,
                          model.joint_max_rad[i] / kRadPerDeg)};
    }
  }
  return {};
}

RobotModel CorrectedModel(const RobotModel& model, const Eigen::VectorXd& params,
                          const std::optional<Eigen::Isometry3d>& world_from_base) {
  RobotModel out = model;
  const int n = model.num_joints();
  auto h = [&](int i) {
    const double* p = params.data() + 6 * i;
    return ErrorTransform(p[0], p[1], p[2], p[3], p[4], p[5]);
  };
  const Eigen::Isometry3d base =
      world_from_base.value_or(model.base.value_or(Eigen::Isometry3d::Identity()));
  out.base = base * h(0);
  for (int i = 1; i < n; ++i) out.links[i - 1] = model.links[i - 1] * h(i);
  // A known mounting's flange turn moves the target and the flange alike; the exported model
  // carries it in both (its own turn parameters start at zero again).
  const Eigen::Matrix3d turn = FlangeTurn(model, params);
  out.tool_mm = turn * (model.tool_mm + params.segment<3>(model.tool_index()));
  out.flange.linear() = turn * model.flange.linear();
  out.flange.translation() = turn * model.flange.translation();
  for (size_t k = 0; k < out.nongeometric.size(); ++k) {
    out.nongeometric[k].fixed_rad += params(model.num_geometric() + static_cast<int>(k));
  }
  // The exported model must load again: its name stays within the name limit, the model's
  // own name cut (at a character boundary) to make room for the suffix.
  static constexpr std::string_view kSuffix = "-calibrated";
  out.name = std::string(TruncateUtf8(model.name, plausible::kMaxNameLength - kSuffix.size())) +
             std::string(kSuffix);
  return out;
}

std::vector<ParameterChange> CompareParameters(const Eigen::VectorXd& old_params,
                                               const Eigen::VectorXd& old_sigmas,
                                               const Eigen::VectorXd& new_params,
                                               const Eigen::VectorXd& new_sigmas) {
  std::vector<ParameterChange> out;
  for (int k = 0; k < old_params.size(); ++k) {
    ParameterChange c;
    c.parameter = k;
    c.change = new_params(k) - old_params(k);
    const double so = std::isfinite(old_sigmas(k)) ? old_sigmas(k) : 0.0;
    const double sn = std::isfinite(new_sigmas(k)) ? new_sigmas(k) : 0.0;
    const double s = std::sqrt(so * so + sn * sn);
    c.z = s > 0 ? c.change / s : 0.0;
    out.push_back(c);
  }
  return out;
}

}  // namespace armsig::calibration
