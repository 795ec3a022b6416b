#include "calibration/estimation.h"

#include <Eigen/Cholesky>
#include <Eigen/Geometry>
#include <Eigen/SVD>
#include <algorithm>
#include <cmath>
#include <limits>
#include <set>
#include <sstream>
#include <stdexcept>

#include "calibration/compensation.h"
#include "calibration/statistics.h"

namespace armsig::calibration {

std::vector<int> ParseParameterSpec(const RobotModel& model, const std::string& spec) {
  std::set<int> chosen;
  const auto names = model.ParameterNames();
  std::stringstream stream(spec);
  std::string token;
  bool any = false;
  while (std::getline(stream, token, ',')) {
    token.erase(0, token.find_first_not_of(" \t"));
    token.erase(token.find_last_not_of(" \t") + 1);
    if (token.empty()) continue;
    any = true;
    if (token == "geometric") {
      for (int i = 0; i < model.num_geometric(); ++i) chosen.insert(i);
    } else if (token == "all") {
      for (int i = 0; i < model.num_parameters(); ++i) chosen.insert(i);
    } else if (int index = model.IndexOf(token); index >= 0) {
      chosen.insert(index);
    } else {
      std::string known = "geometric, all";
      for (size_t i = model.num_geometric(); i < names.size(); ++i) known += ", " + names[i];
      throw std::invalid_argument("unknown parameter '" + token + "' (expected geometric, all, " +
                                  "a parameter name such as a1 … c" +
                                  std::to_string(model.num_joints() + 1) + ", or one of: " + known +
                                  ")");
    }
  }
  if (!any) throw std::invalid_argument("empty parameter list");
  return {chosen.begin(), chosen.end()};
}

ErrorStats Summarise(const std::vector<double>& distances_mm) {
  ErrorStats s;
  s.poses = static_cast<int>(distances_mm.size());
  if (distances_mm.empty()) return s;
  double sum = 0.0, sum_sq = 0.0;
  for (double d : distances_mm) {
    sum += d;
    sum_sq += d * d;
    s.max_mm = std::max(s.max_mm, d);
  }
  s.mean_mm = sum / s.poses;
  s.rms_mm = std::sqrt(sum_sq / s.poses);
  return s;
}

std::optional<Eigen::Isometry3d> AlignBase(const RobotModel& model,
                                           const std::vector<MeasuredPose>& poses) {
  return AlignBaseWithParams(model, Eigen::VectorXd::Zero(model.num_parameters()), poses);
}

std::vector<Eigen::Vector3d> Residuals(const RobotModel& model,
                                       const Eigen::Isometry3d& world_from_base,
                                       const Eigen::VectorXd& params,
                                       const std::vector<MeasuredPose>& poses) {
  Kinematics kin(model);
  std::vector<Eigen::Vector3d> out;
  out.reserve(poses.size());
  for (const auto& pose : poses) {
    out.push_back(kin.Position(world_from_base, params, pose.joints_rad.data()) -
                  pose.target_in_world);
  }
  return out;
}

std::vector<double> Distances(const std::vector<Eigen::Vector3d>& residuals) {
  std::vector<double> d;
  d.reserve(residuals.size());
  for (const auto& r : residuals) d.push_back(r.norm());
  return d;
}

namespace {
// Joint motion (rad, over all joints) below which a set of poses is one configuration.
constexpr double kNoMotionRad = 1e-9;
}  // namespace

void EstimationOptions::Check() const {
  identifiability.Check();
  if (max_iterations < 1) throw std::invalid_argument("max_iterations must be ≥ 1");
  if (!(robust_threshold_mm >= 0.0)) throw std::invalid_argument("robust threshold must be ≥ 0");
}

namespace {

// Per-pose weights of the Huber loss on the error distance (1 inside the threshold), from
// the stacked residual vector (3 per pose).
void HuberWeights(const Eigen::VectorXd& residual, double threshold, std::vector<double>& weights) {
  const int m = static_cast<int>(residual.size() / 3);
  weights.assign(m, 1.0);
  if (threshold <= 0.0) return;
  for (int i = 0; i < m; ++i) {
    const double d = residual.segment<3>(3 * i).norm();
    if (d > threshold) weights[i] = threshold / d;
  }
}

// Huber cost: ρ(d) = d² inside, 2kd − k² outside.
double RobustCost(const Eigen::VectorXd& residual, double threshold) {
  if (threshold <= 0.0) return residual.squaredNorm();
  double cost = 0.0;
  for (Eigen::Index i = 0; i + 2 < residual.size(); i += 3) {
    const double d2 = residual.segment<3>(i).squaredNorm();
    cost +=
        d2 > threshold * threshold ? 2.0 * threshold * std::sqrt(d2) - threshold * threshold : d2;
  }
  return cost;
}

}  // namespace

EstimationResult Estimate(const RobotModel& model, const std::vector<MeasuredPose>& poses,
                          const EstimationOptions& options) {
  options.Check();
  EstimationResult result;
  const int np = model.num_parameters();
  const int m = static_cast<int>(poses.size());
  result.params = Eigen::VectorXd::Zero(np);
  result.sigmas = Eigen::VectorXd::Constant(np, std::numeric_limits<double>::quiet_NaN());

  // Poses that do not move the robot determine nothing about its joints: refused, whatever
  // the targets (a fit would "converge" with σ0 of the targets' scatter and mean nothing).
  if (m >= 2) {
    double motion = 0.0;
    for (const auto& p : poses)
      motion = std::max(motion, (p.joints_rad - poses[0].joints_rad).norm());
    if (!(motion > kNoMotionRad)) {
      result.status.code = SolveCode::kDegenerate;
      result.status.message = "all " + std::to_string(m) +
                              " poses have the same joint angles: the robot never moved, so the "
                              "poses cannot determine its parameters (measure configurations "
                              "that move every joint)";
      return result;
    }
  }

  // N1: given, or the rigid best fit of the nominal model (paper: "N1 has to be
  // established before the estimation process begins").
  if (model.base) {
    result.world_from_base = *model.base;
  } else if (auto base = AlignBase(model, poses)) {
    result.world_from_base = *base;
  } else {
    result.status.code = SolveCode::kDegenerate;
    result.status.message =
        "base: auto needs at least 3 poses whose nominal target positions are not on "
        "one line (got " +
        std::to_string(m) + ")";
    return result;
  }

  std::vector<int> candidates = options.parameters;
  if (candidates.empty()) {
    for (int i = 0; i < np; ++i) candidates.push_back(i);
  }
  std::vector<Eigen::VectorXd> joints;
  joints.reserve(m);
  for (const auto& p : poses) joints.push_back(p.joints_rad);

  // The identifiable subset is chosen once, at the nominal model, and kept: re-deciding
  // it at every iteration makes Gauss–Newton wander on real data. It is decided in the
  // robot's own frame: the base rotation multiplies every pose's rows by one orthogonal
  // matrix, which leaves JᵀJ — hence the subset — unchanged in exact arithmetic, while the
  // base aligned on noisy data would let rounding pick between exactly dependent
  // parameters differently from one data set of the same poses to the next.
  result.identifiability = AnalyseIdentifiability(model, Eigen::Isometry3d::Identity(), joints,
                                                  candidates, options.identifiability);
  // Poses that identify far fewer parameters than configurations spread over the joint
  // limits do (the model's structural rank) cannot determine the signature: a joint barely
  // moved, every pose on one path. Refused, naming the joints that never moved.
  if (const int structural = result.identifiability.structural_rank;
      structural > 0 && 2 * result.identifiability.rank < structural) {
    std::string frozen;
    for (const auto& f : result.identifiability.frozen_joints) {
      frozen += (frozen.empty() ? "" : ", ") + std::to_string(f.joint + 1);
    }
    result.status.code = SolveCode::kDegenerate;
    result.status.message =
        "the poses determine only " + std::to_string(result.identifiability.rank) + " of the " +
        std::to_string(structural) +
        " parameters that configurations spread over the joint limits determine" +
        (frozen.empty() ? std::string(": the robot barely moves between them")
                        : "; joints that never move: " + frozen) +
        " (measure configurations that move every joint)";
    return result;
  }
  const std::vector<int>& subset = result.identifiability.identified;
  const int k = static_cast<int>(subset.size());
  const int needed = std::max(k, result.identifiability.structural_rank);
  if (3 * m <= needed) {
    result.status.code = SolveCode::kTooFewObservations;
    result.status.message =
        std::to_string(m) + " poses give " + std::to_string(3 * m) + " equations; the model has " +
        std::to_string(needed) +
        " identifiable parameters and needs more equations than that: at least " +
        std::to_string(needed / 3 + 1) + " poses";
    return result;
  }

  // Levenberg–Marquardt on the subset with Marquardt's diagonal scaling. One stacked
  // Jacobian per evaluation; the trial point's Jacobian is reused when it is accepted.
  struct Evaluation {
    Eigen::MatrixXd jacobian;  // 3m × k, columns of the identified subset
    Eigen::VectorXd residual;  // 3m, model − measured
    double cost = 0.0;
  };
  Kinematics kin(model);
  Eigen::Matrix<double, 3, Eigen::Dynamic> block(3, np);
  const double threshold = options.robust_threshold_mm;
  auto evaluate = [&](const Eigen::VectorXd& params, Evaluation& e) {
    e.jacobian.resize(3 * m, k);
    e.residual.resize(3 * m);
    for (int i = 0; i < m; ++i) {
      const Eigen::Vector3d x = kin.PositionAndJacobian(result.world_from_base, params,
                                                        poses[i].joints_rad.data(), block);
      e.residual.segment<3>(3 * i) = x - poses[i].target_in_world;
      for (int c = 0; c < k; ++c) e.jacobian.block<3, 1>(3 * i, c) = block.col(subset[c]);
    }
    e.cost = RobustCost(e.residual, threshold);
  };
  auto residual_vectors = [&](const Evaluation& e) {
    std::vector<Eigen::Vector3d> r(m);
    for (int i = 0; i < m; ++i) r[i] = e.residual.segment<3>(3 * i);
    return r;
  };

  Evaluation current, trial;
  evaluate(result.params, current);
  result.nominal_residuals = residual_vectors(current);
  result.nominal = Summarise(Distances(result.nominal_residuals));

  Eigen::MatrixXd normal(k, k), weighted(3 * m, k);
  Eigen::VectorXd gradient(k);
  std::vector<double> weights;
  auto build_normal_equations = [&](const Evaluation& e) {
    HuberWeights(e.residual, threshold, weights);
    for (int i = 0; i < m; ++i) {
      weighted.middleRows<3>(3 * i) = std::sqrt(weights[i]) * e.jacobian.middleRows<3>(3 * i);
    }
    normal.setZero();
    normal.selfadjointView<Eigen::Lower>().rankUpdate(weighted.transpose());
    normal.triangularView<Eigen::Upper>() = normal.transpose();
    Eigen::VectorXd wr = e.residual;
    for (int i = 0; i < m; ++i) wr.segment<3>(3 * i) *= weights[i];
    gradient.noalias() = e.jacobian.transpose() * wr;
  };

  double lambda = 1e-6;
  bool converged = false;
  int iteration = 0;
  for (; iteration < options.max_iterations && !converged; ++iteration) {
    build_normal_equations(current);
    const Eigen::VectorXd diag = normal.diagonal().cwiseMax(1e-30);
    bool accepted = false;
    for (int attempt = 0; attempt < 30 && !accepted; ++attempt) {
      Eigen::MatrixXd damped = normal;
      damped.diagonal() += lambda * diag;
      const Eigen::VectorXd step = -damped.llt().solve(gradient);
      Eigen::VectorXd trial_params = result.params;
      for (int c = 0; c < k; ++c) trial_params(subset[c]) += step(c);
      evaluate(trial_params, trial);
      if (std::isfinite(trial.cost) && trial.cost <= current.cost) {
        const double relative_decrease =
            (current.cost - trial.cost) / std::max(current.cost, 1e-300);
        const double relative_step =
            step.norm() / (result.params.norm() + options.parameter_tolerance);
        result.params = trial_params;
        std::swap(current, trial);
        lambda = std::max(lambda / 10.0, 1e-12);
        accepted = true;
        if (relative_decrease < options.function_tolerance ||
            relative_step < options.parameter_tolerance || current.cost == 0.0) {
          converged = true;
        }
      } else {
        lambda *= 10.0;
      }
    }
    if (!accepted) {
      converged = true;  // no step lowers the cost: at the minimum to working precision
    }
  }
  result.iterations = iteration;
  result.status.code = converged ? SolveCode::kOk : SolveCode::kNotConverged;
  if (!converged) {
    result.status.message = "no convergence after " + std::to_string(iteration) + " iterations";
  }

  // Covariance of the identified parameters: σ0² (Jᵀ W J)⁻¹ at the solution.
  build_normal_equations(current);
  result.cost = current.cost;
  result.redundancy = 3 * m - k;
  result.fit_residuals = residual_vectors(current);
  double weighted_sq = 0.0;
  for (int i = 0; i < m; ++i) weighted_sq += weights[i] * result.fit_residuals[i].squaredNorm();
  result.sigma0_mm = std::sqrt(weighted_sq / result.redundancy);
  if (k > 0) {
    const Eigen::MatrixXd normal_inverse = normal.ldlt().solve(Eigen::MatrixXd::Identity(k, k));
    if (model.base) {
      result.covariance = result.sigma0_mm * result.sigma0_mm * normal_inverse;
    } else {
      // The base was aligned on these same measurements, then held: a two-stage estimate.
      // To first order the alignment moves the base by db = (BᵀB)⁻¹Bᵀ dy, with B the
      // 3m × 6 derivative of the world positions by a small rotation and translation of
      // the base, and the parameters answer the rest: dp = N⁻¹JᵀW (I − B(BᵀB)⁻¹Bᵀ) dy.
      // Hence Cov(p) = σ0² N⁻¹ Cᵀ W⁻¹ C N⁻¹ with C = (I − P_B) W J. Without this, the
      // parameters the base alignment already explains (the first joint's) would be
      // reported two to three times less certain than repeated fits show them to be.
      Eigen::MatrixXd base_jacobian(3 * m, 6);
      const Eigen::Vector3d origin = result.world_from_base.translation();
      for (int i = 0; i < m; ++i) {
        const Eigen::Vector3d x = poses[i].target_in_world + result.fit_residuals[i] - origin;
        base_jacobian.block<3, 3>(3 * i, 0) << 0, x.z(), -x.y(), -x.z(), 0, x.x(), x.y(), -x.x(), 0;
        base_jacobian.block<3, 3>(3 * i, 3).setIdentity();
      }
      Eigen::MatrixXd c = current.jacobian;
      for (int i = 0; i < m; ++i) c.middleRows<3>(3 * i) *= weights[i];
      const Eigen::Matrix<double, 6, 6> base_normal = base_jacobian.transpose() * base_jacobian;
      c -= base_jacobian * base_normal.ldlt().solve(base_jacobian.transpose() * c);
      for (int i = 0; i < m; ++i) c.middleRows<3>(3 * i) /= std::sqrt(std::max(weights[i], 1e-12));
      result.covariance = result.sigma0_mm * result.sigma0_mm * normal_inverse *
                          (c.transpose() * c) * normal_inverse;
    }
    for (int c = 0; c < k; ++c) result.sigmas(subset[c]) = std::sqrt(result.covariance(c, c));
  }
  result.fit = Summarise(Distances(result.fit_residuals));
  if (threshold > 0.0) {
    for (int i = 0; i < m; ++i) {
      if (result.fit_residuals[i].norm() > threshold) result.downweighted.push_back(i);
    }
  }
  // A fit whose numbers are not numbers is no result, whatever the iterations said.
  bool finite = std::isfinite(result.sigma0_mm) && std::isfinite(result.cost) &&
                result.params.allFinite() && result.covariance.allFinite() &&
                result.world_from_base.matrix().allFinite();
  for (int c = 0; c < k; ++c) finite = finite && std::isfinite(result.sigmas(subset[c]));
  for (const auto& r : result.nominal_residuals) finite = finite && r.allFinite();
  for (const auto& r : result.fit_residuals) finite = finite && r.allFinite();
  if (!finite) {
    result.status.code = SolveCode::kNonFinite;
    result.status.message =
        "the fit produced values that are not finite numbers (inf or NaN): check the poses' "
        "coordinates and the model's lengths";
  }
  return result;
}

FTest CompareNested(const EstimationResult& reduced, const EstimationResult& full,
                    const std::string& added, double alpha) {
  FTest t;
  t.added = added;
  t.rss_reduced = reduced.cost;
  t.rss_full = full.cost;
  t.df_added = static_cast<int>(full.identifiability.identified.size()) -
               static_cast<int>(reduced.identifiability.identified.size());
  t.df_residual = full.redundancy;
  if (t.df_added <= 0 || t.df_residual <= 0 || !(t.rss_full > 0.0)) {
    t.f = 0.0;
    t.p_value = 1.0;
    t.significant = false;
    return t;
  }
  t.f = ((t.rss_reduced - t.rss_full) / t.df_added) / (t.rss_full / t.df_residual);
  t.p_value = FisherFSurvival(t.f, t.df_added, t.df_residual);
  t.significant = t.p_value < alpha;
  return t;
}

AutoSelection SelectTermsByFTest(const RobotModel& model, const std::vector<MeasuredPose>& poses,
                                 const EstimationOptions& options, double alpha) {
  AutoSelection selection;
  EstimationOptions opts = options;
  for (int i = 0; i < model.num_geometric(); ++i) selection.parameters.push_back(i);
  opts.parameters = selection.parameters;
  EstimationResult current = Estimate(model, poses, opts);
  std::vector<int> remaining;
  for (int i = model.num_geometric(); i < model.num_parameters(); ++i) remaining.push_back(i);
  const auto names = model.ParameterNames();
  while (current.usable() && !remaining.empty()) {
    int best = -1;
    FTest best_test;
    EstimationResult best_result;
    for (int term : remaining) {
      opts.parameters = selection.parameters;
      opts.parameters.push_back(term);
      std::sort(opts.parameters.begin(), opts.parameters.end());
      EstimationResult trial = Estimate(model, poses, opts);
      if (!trial.usable()) continue;
      FTest test = CompareNested(current, trial, names[term], alpha);
      selection.tests.push_back(test);
      if (test.significant && (best < 0 || test.f > best_test.f)) {
        best = term;
        best_test = test;
        best_result = std::move(trial);
      }
    }
    if (best < 0) break;
    selection.parameters.push_back(best);
    std::sort(selection.parameters.begin(), selection.parameters.end());
    remaining.erase(std::find(remaining.begin(), remaining.end(), best));
    current = std::move(best_result);
  }
  return selection;
}

}  // namespace armsig::calibration
