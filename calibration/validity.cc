#include "calibration/validity.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <numbers>

#include "calibration/cross_validation.h"
#include "calibration/transfer_folds.h"

namespace armsig::calibration {

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

struct HeldOutScale {
  double sigma_mm = kNaN;  // s per coordinate
  double coverage = kNaN;
};

// s from held-out error distances e_i and the parameters' own σ_i at those poses: the
// smallest s with 95 % of the poses within kCoverageRadius √(σ_i² + s²). Not from the mean
// square: a model's leftovers are not isotropic (a joint's angle error moves the tool along
// one direction), and a σ fitted to the mean square of a one-dimensional error covers 89 %
// at the 3-D 95 % radius. The share actually within (ties, few poses) is returned with it.
HeldOutScale ScaleOf(const std::vector<double>& distances, const std::vector<double>& sigma_param) {
  HeldOutScale out;
  const size_t n = distances.size();
  if (n == 0) return out;
  auto param = [&](size_t i) {
    return sigma_param.empty() || !std::isfinite(sigma_param[i]) ? 0.0 : sigma_param[i];
  };
  auto share_within = [&](double s) {
    size_t within = 0;
    for (size_t i = 0; i < n; ++i) {
      within += distances[i] <= kCoverageRadius * std::sqrt(param(i) * param(i) + s * s);
    }
    return static_cast<double>(within) / static_cast<double>(n);
  };
  // The share grows with s: bisection between 0 and the largest distance over the radius.
  double lo = 0.0, hi = 0.0;
  for (double d : distances) hi = std::max(hi, d / kCoverageRadius);
  if (share_within(lo) >= 0.95) {
    hi = lo;
  } else {
    for (int iteration = 0; iteration < 60; ++iteration) {
      const double mid = 0.5 * (lo + hi);
      (share_within(mid) >= 0.95 ? hi : lo) = mid;
    }
  }
  out.sigma_mm = hi;
  out.coverage = share_within(hi);
  return out;
}

std::vector<double> Norms(const std::vector<Eigen::Vector3d>& v) {
  std::vector<double> out;
  out.reserve(v.size());
  for (const auto& r : v) out.push_back(r.norm());
  return out;
}

}  // namespace

double ParametricSigmaMm(const RobotModel& model, const Eigen::VectorXd& params,
                         const std::vector<int>& identified, const Eigen::MatrixXd& covariance,
                         const Eigen::VectorXd& joints_rad) {
  if (identified.empty() || covariance.rows() != static_cast<int>(identified.size()))
    return kNaN;
  Kinematics kin(model);
  Eigen::Matrix<double, 3, Eigen::Dynamic> all(3, model.num_parameters());
  kin.PositionAndJacobian(Eigen::Isometry3d::Identity(), params, joints_rad.data(), all);
  Eigen::Matrix<double, 3, Eigen::Dynamic> j(3, identified.size());
  for (size_t c = 0; c < identified.size(); ++c) j.col(c) = all.col(identified[c]);
  return std::sqrt(std::max((j * covariance * j.transpose()).trace() / 3.0, 0.0));
}

SetValidity EstimateValidity(const RobotModel& model, const EstimationResult& fit,
                             const std::vector<MeasuredPose>& fit_poses, const ResidualMapFit* map,
                             unsigned seed) {
  SetValidity v;
  std::vector<Eigen::VectorXd> joints;
  for (const auto& p : fit_poses) joints.push_back(p.joints_rad);
  v.term_arcs = ArcsCovering(joints, model.num_joints());
  constexpr int kFolds = 5;
  const int m = static_cast<int>(fit_poses.size());
  if (!fit.usable() || m < 2 * kFolds) return v;
  std::vector<double> sigma_param(m);
  for (int i = 0; i < m; ++i) {
    sigma_param[i] = ParametricSigmaMm(model, fit.params, fit.identifiability.identified,
                                       fit.covariance, fit_poses[i].joints_rad);
  }
  std::vector<double> inside, outside, sp_inside, sp_outside;
  const bool with_map = map && map->used && !map->cv_distances_mm.empty();
  if (with_map) {
    inside = map->cv_distances_mm;
    for (int i : map->cv_poses) sp_inside.push_back(sigma_param[i]);
    if (!map->transfer_distances_mm.empty()) {
      outside = map->transfer_distances_mm;
      sp_outside = sp_inside;
      v.outside_folds = map->transfer_folds;
    }
  }
  const std::vector<int>& kept = fit.identifiability.identified;
  if (inside.empty()) {
    const LinearisedCrossValidation cv =
        CrossValidationAtFit(model, fit, fit_poses, kept, {}, AssignFolds(m, kFolds, seed), kFolds);
    std::vector<int> all(cv.jacobian().cols());
    for (size_t c = 0; c < all.size(); ++c) all[c] = static_cast<int>(c);
    inside = Norms(cv.HeldOut(all));
    sp_inside = sigma_param;
  }
  if (outside.empty()) {
    const TransferFolds folds = AssignTransferFolds(model, fit_poses, kFolds, seed);
    if (folds.folds >= 2) {
      const LinearisedCrossValidation cv =
          CrossValidationAtFit(model, fit, fit_poses, kept, {}, folds.fold_of_pose, folds.folds);
      std::vector<int> all(cv.jacobian().cols());
      for (size_t c = 0; c < all.size(); ++c) all[c] = static_cast<int>(c);
      outside = Norms(cv.HeldOut(all));
      sp_outside = sigma_param;
      v.outside_folds = folds.Describe();
    }
  }
  const HeldOutScale in = ScaleOf(inside, sp_inside);
  v.sigma_inside_mm = in.sigma_mm;
  v.coverage_inside = in.coverage;
  const HeldOutScale out = ScaleOf(outside, sp_outside);
  // Beside the fit poses a prediction is never better than among them.
  v.sigma_outside_mm = std::isfinite(out.sigma_mm) ? std::max(out.sigma_mm, in.sigma_mm) : kNaN;
  v.coverage_outside = out.coverage;
  return v;
}

Support SupportAt(const RobotModel& model, const Eigen::VectorXd& params,
                  const SetValidity& validity, const Eigen::VectorXd& joints_rad,
                  bool map_outside) {
  Support s;
  s.map_outside = map_outside;
  if (!validity.term_arcs.empty() &&
      static_cast<int>(validity.term_arcs.size()) == model.num_joints()) {
    RobotModel held = model;
    held.term_support = validity.term_arcs;
    const HeldTerms h = TermsHeldAtSupport(held, joints_rad.data());
    s.joints_outside = h.joints;
    for (int k : h.terms) {
      if (params(model.num_geometric() + k) != 0.0) s.held_terms.push_back(model.nongeometric[k].name);
    }
    // A joint outside its arc that no fitted term depends on: the geometric model holds there.
    if (s.held_terms.empty()) s.joints_outside.clear();
  }
  s.inside = s.joints_outside.empty() && !map_outside;
  return s;
}

std::string Support::Describe(const Eigen::VectorXd& joints_rad,
                              const SetValidity& validity) const {
  if (inside) return "inside";
  std::string text;
  constexpr double kDeg = 180.0 / std::numbers::pi;
  for (int j : joints_outside) {
    const JointArc& a = validity.term_arcs[j];
    text += fmt::format("{}joint {} at {:.1f}° outside {:.1f}°…{:.1f}°", text.empty() ? "" : "; ",
                        j + 1, joints_rad(j) * kDeg, a.start_rad * kDeg,
                        (a.start_rad + a.length_rad) * kDeg);
  }
  if (!held_terms.empty()) {
    text += " (";
    for (size_t k = 0; k < held_terms.size(); ++k) text += (k ? ", " : "") + held_terms[k];
    text += " held at the edge)";
  }
  if (map_outside) text += std::string(text.empty() ? "" : "; ") + "outside the residual map";
  return text;
}

double PredictionSigmaMm(double parametric_sigma_mm, const SetValidity& validity, bool inside) {
  // Beside the fit poses a prediction is never better than among them: without a held-out
  // figure beside them (too few regions to hold out), the one among them.
  const double s = inside || !std::isfinite(validity.sigma_outside_mm) ? validity.sigma_inside_mm
                                                                       : validity.sigma_outside_mm;
  const bool p_ok = std::isfinite(parametric_sigma_mm), s_ok = std::isfinite(s);
  if (!p_ok && !s_ok) return kNaN;
  const double p = p_ok ? parametric_sigma_mm : 0.0, r = s_ok ? s : 0.0;
  return std::sqrt(p * p + r * r);
}

}  // namespace armsig::calibration
