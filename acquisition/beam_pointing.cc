#include "acquisition/beam_pointing.h"

#include <fmt/format.h>

#include <Eigen/SVD>
#include <cmath>

#include "core/spread.h"

namespace armsig::acquisition {

TargetPredictor::TargetPredictor(const calibration::RobotModel& model, Eigen::VectorXd params,
                                 std::optional<Eigen::Isometry3d> lab_base, Options options)
    : model_(model),
      params_(params.size() == model.num_parameters()
                  ? std::move(params)
                  : Eigen::VectorXd::Zero(model.num_parameters())),
      lab_base_(lab_base),
      options_(options),
      kinematics_(model_),
      base_(lab_base) {}

void TargetPredictor::Add(const Eigen::VectorXd& joints_rad,
                          const Eigen::Vector3d& target_in_world) {
  if (joints_rad.size() != model_.num_joints() || !joints_rad.allFinite() ||
      !target_in_world.allFinite())
    return;
  model_positions_.push_back(
      kinematics_.Position(Eigen::Isometry3d::Identity(), params_, joints_rad.data()));
  measured_.push_back(target_in_world);
  Refit();
}

void TargetPredictor::Refit() {
  const int n = static_cast<int>(measured_.size());
  if (n < std::max(3, options_.min_points)) return;
  Eigen::Matrix3Xd from(3, n), to(3, n);
  for (int i = 0; i < n; ++i) {
    from.col(i) = model_positions_[i];
    to.col(i) = measured_[i];
  }
  if (PrincipalSpread(from)(1) / std::sqrt(n) < options_.min_spread_mm)
    return;  // (nearly) on one line: the rotation about it is not determined yet
  Eigen::Isometry3d base = Eigen::Isometry3d::Identity();
  base.matrix() = Eigen::umeyama(from, to, false);  // rigid: rotation and translation
  if (!base.matrix().allFinite()) return;
  double sum = 0.0;
  for (int i = 0; i < n; ++i) sum += (base * from.col(i) - to.col(i)).squaredNorm();
  fitted_ = base;
  base_ = base;
  fit_rms_mm_ = std::sqrt(sum / n);
}

std::optional<Eigen::Vector3d> TargetPredictor::Predict(const Eigen::VectorXd& joints_rad) {
  if (!base_ || joints_rad.size() != model_.num_joints() || !joints_rad.allFinite())
    return std::nullopt;
  return kinematics_.Position(*base_, params_, joints_rad.data());
}

namespace {

// RMS distance of points from their centroid, mm.
double Spread(const std::vector<Eigen::Vector3d>& points) {
  if (points.empty()) return 0.0;
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (const auto& p : points) mean += p;
  mean /= static_cast<double>(points.size());
  double sum = 0.0;
  for (const auto& p : points) sum += (p - mean).squaredNorm();
  return std::sqrt(sum / static_cast<double>(points.size()));
}

}  // namespace

std::optional<std::string> TargetPredictor::FollowProblem(double max_fit_rms_mm) const {
  if (!fitted_ || !fit_rms_mm_) return std::nullopt;
  const double model_spread = Spread(model_positions_);
  const double measured_spread = Spread(measured_);
  if (measured_spread < 0.1 * model_spread) {
    return fmt::format(
        "the measured target does not follow the robot: over {} configurations it stays within "
        "{:.1f} mm (rms about its mean) while the model moves it over {:.0f} mm; is the "
        "reflector on the robot's flange (in its nest), are the instruments aimed at the robot "
        "and not at a fixed point, and are the model's lengths in mm?",
        points(), measured_spread, model_spread);
  }
  if (*fit_rms_mm_ > max_fit_rms_mm) {
    return fmt::format(
        "the measured points do not follow the robot model: the best rigid robot base leaves "
        "{:.1f} mm rms over {} configurations, more than the {:.1f} mm an uncalibrated robot may "
        "miss by (lab file tolerances: max_base_fit_rms_mm); check the lab file's robot target "
        "(tool offset), the model file, and the controller's joint zeros and units",
        *fit_rms_mm_, points(), max_fit_rms_mm);
  }
  return std::nullopt;
}

std::string TargetPredictor::Describe() const {
  if (fitted_) {
    return fmt::format("base fitted to {} measured points (rms {:.2f} mm)", points(),
                       fit_rms_mm_.value_or(0.0));
  }
  if (lab_base_) return "the lab file's robot base";
  return fmt::format("no base yet ({} of {} points measured, not on one line)", points(),
                     std::max(3, options_.min_points));
}

}  // namespace armsig::acquisition
