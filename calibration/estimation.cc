#include "calibration/estimation.h"

#include "core/text.h"

#include <Eigen/Cholesky>
#include <Eigen/Geometry>
#include <Eigen/SVD>
#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <set>
#include <sstream>
#include <stdexcept>

#include "calibration/compensation.h"
#include "calibration/cross_validation.h"
#include "calibration/statistics.h"
#include "calibration/terms.h"

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
    } else if (const auto family = TermFamilyFromName(token)) {
      bool found = false;
      for (size_t k = 0; k < model.nongeometric.size(); ++k) {
        if (model.nongeometric[k].family != *family) continue;
        chosen.insert(model.num_geometric() + static_cast<int>(k));
        found = true;
      }
      if (!found) {
        throw std::invalid_argument("the model has no " + token +
                                    " terms (generate them: 'generated_terms: [" + token +
                                    "]' in the model file)");
      }
    } else if (int index = model.IndexOf(token); index >= 0) {
      chosen.insert(index);
    } else {
      std::vector<std::string> words = {"geometric", "all", "compliance", "harmonics"};
      words.insert(words.end(), names.begin(), names.end());
      const auto nearest = NearestKey(token, words);
      std::string terms;
      for (size_t i = model.num_geometric(); i < names.size(); ++i)
        terms += (terms.empty() ? "" : ", ") + names[i];
      throw std::invalid_argument(
          "unknown parameter " + Quoted(token) +
          (nearest ? " (did you mean " + Quoted(*nearest) + "?)" : std::string()) +
          "; expected geometric, all, compliance, harmonics or parameter names (a1 … c" +
          std::to_string(model.num_joints() + 1) +
          (terms.empty() ? std::string() : ", " + terms) + ")");
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
  // One base for every pose, whatever frame it names.
  FrameBases one;
  for (int64_t frame : FramesOf(poses)) one.emplace(frame, world_from_base);
  return Residuals(model, one, params, poses);
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

std::vector<int64_t> FramesOf(const std::vector<MeasuredPose>& poses) {
  std::set<int64_t> frames;
  for (const auto& p : poses) frames.insert(p.frame);
  return {frames.begin(), frames.end()};
}

std::vector<Eigen::Vector3d> Residuals(const RobotModel& model, const FrameBases& bases,
                                       const Eigen::VectorXd& params,
                                       const std::vector<MeasuredPose>& poses) {
  Kinematics kin(model);
  std::vector<Eigen::Vector3d> out;
  out.reserve(poses.size());
  for (const auto& pose : poses) {
    const auto base = bases.find(pose.frame);
    if (base == bases.end()) {
      throw std::invalid_argument("Residuals: no base for measurement frame " +
                                  std::to_string(pose.frame) + " (pose " + pose.id + ")");
    }
    out.push_back(kin.Position(base->second, params, pose.joints_rad.data()) -
                  pose.target_in_world);
  }
  return out;
}

FrameBases AlignFrameBases(const RobotModel& model, const Eigen::VectorXd& params,
                           const std::vector<MeasuredPose>& poses) {
  std::map<int64_t, std::vector<MeasuredPose>> by_frame;
  for (const auto& p : poses) by_frame[p.frame].push_back(p);
  FrameBases bases;
  for (const auto& [frame, frame_poses] : by_frame) {
    if (const auto base = AlignBaseWithParams(model, params, frame_poses)) bases[frame] = *base;
  }
  return bases;
}

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

  // Measurement frames: the reference (the latest) is the datum; every other one gets a
  // base of its own among the unknowns. `extra[i]`: the index of pose i's frame among the
  // others, −1 for the reference frame.
  const std::vector<int64_t> frames = FramesOf(poses);
  result.reference_frame = frames.empty() ? 0 : frames.back();
  std::map<int64_t, int> extra_index;
  for (size_t f = 0; f + 1 < frames.size(); ++f) extra_index[frames[f]] = static_cast<int>(f);
  const int extra_frames = static_cast<int>(extra_index.size());
  std::vector<int> extra(m, -1);
  std::vector<std::vector<MeasuredPose>> poses_of(extra_frames);
  std::vector<MeasuredPose> reference_poses;
  for (int i = 0; i < m; ++i) {
    const auto it = extra_index.find(poses[i].frame);
    if (it == extra_index.end()) {
      reference_poses.push_back(poses[i]);
    } else {
      extra[i] = it->second;
      poses_of[it->second].push_back(poses[i]);
    }
  }
  auto degenerate = [&](int64_t frame, size_t count) {
    result.status.code = SolveCode::kDegenerate;
    result.status.message =
        (frames.size() > 1 ? "measurement frame " + std::to_string(frame) + ": " : std::string()) +
        "base: auto needs at least 3 poses whose nominal target positions are not on "
        "one line (got " +
        std::to_string(count) + ")";
    return result;
  };

  // N1: given, or the rigid best fit of the nominal model (paper: "N1 has to be
  // established before the estimation process begins").
  if (model.base) {
    result.world_from_base = *model.base;
  } else if (auto base = AlignBase(model, reference_poses)) {
    result.world_from_base = *base;
  } else {
    return degenerate(result.reference_frame, reference_poses.size());
  }
  // The other frames' bases start from the nominal model's best fit to their poses.
  std::vector<Eigen::Isometry3d> extra_bases(extra_frames);
  std::vector<Eigen::Vector3d> extra_centres(extra_frames, Eigen::Vector3d::Zero());
  for (int e = 0; e < extra_frames; ++e) {
    const auto base = AlignBase(model, poses_of[e]);
    if (!base) return degenerate(frames[e], poses_of[e].size());
    extra_bases[e] = *base;
    for (const auto& p : poses_of[e]) extra_centres[e] += p.target_in_world / poses_of[e].size();
  }
  auto base_of = [&](int i, const std::vector<Eigen::Isometry3d>& bases) -> const Eigen::Isometry3d& {
    return extra[i] < 0 ? result.world_from_base : bases[extra[i]];
  };

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
  // parameters differently from one data set of the same poses to the next. The bases of
  // further frames do not change it: each absorbs the same six rigid motions the
  // reference frame's alignment does, in its own poses only.
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
  const int unknowns = k + 6 * extra_frames;  // parameters, then six per further base
  const int needed =
      std::max(k, result.identifiability.structural_rank) + 6 * extra_frames;
  if (3 * m <= needed) {
    result.status.code = SolveCode::kTooFewObservations;
    result.status.message =
        std::to_string(m) + " poses give " + std::to_string(3 * m) + " equations; the model has " +
        std::to_string(needed - 6 * extra_frames) + " identifiable parameters" +
        (extra_frames > 0
             ? " and " + std::to_string(extra_frames) + " further measurement frames add " +
                   std::to_string(6 * extra_frames) + " base unknowns"
             : std::string()) +
        " and needs more equations than that: at least " + std::to_string(needed / 3 + 1) +
        " poses";
    return result;
  }

  // Levenberg–Marquardt on the subset (and the further frames' bases) with Marquardt's
  // diagonal scaling. One stacked Jacobian per evaluation; the trial point's Jacobian is
  // reused when it is accepted.
  struct Evaluation {
    Eigen::MatrixXd jacobian;  // 3m × unknowns: the identified subset, then the bases
    Eigen::VectorXd residual;  // 3m, model − measured
    double cost = 0.0;
  };
  Kinematics kin(model);
  Eigen::Matrix<double, 3, Eigen::Dynamic> block(3, np);
  const double threshold = options.robust_threshold_mm;
  auto evaluate = [&](const Eigen::VectorXd& params, const std::vector<Eigen::Isometry3d>& bases,
                      Evaluation& e) {
    e.jacobian.setZero(3 * m, unknowns);
    e.residual.resize(3 * m);
    for (int i = 0; i < m; ++i) {
      const Eigen::Vector3d x =
          kin.PositionAndJacobian(base_of(i, bases), params, poses[i].joints_rad.data(), block);
      e.residual.segment<3>(3 * i) = x - poses[i].target_in_world;
      for (int c = 0; c < k; ++c) e.jacobian.block<3, 1>(3 * i, c) = block.col(subset[c]);
      if (extra[i] >= 0) {
        // A small motion of the frame's base, world-side: rotation ω about the frame's
        // centre c, then translation t, moves the target by ω × (x − c) + t.
        const Eigen::Vector3d v = x - extra_centres[extra[i]];
        auto b = e.jacobian.block<3, 6>(3 * i, k + 6 * extra[i]);
        b.leftCols<3>() << 0, v.z(), -v.y(), -v.z(), 0, v.x(), v.y(), -v.x(), 0;
        b.rightCols<3>().setIdentity();
      }
    }
    e.cost = RobustCost(e.residual, threshold);
  };
  auto moved_bases = [&](const std::vector<Eigen::Isometry3d>& bases,
                         const Eigen::VectorXd& step) {
    std::vector<Eigen::Isometry3d> out = bases;
    for (int f = 0; f < extra_frames; ++f) {
      const Eigen::Vector3d w = step.segment<3>(k + 6 * f), t = step.segment<3>(k + 6 * f + 3);
      const Eigen::Vector3d& c = extra_centres[f];
      Eigen::Isometry3d motion = Eigen::Isometry3d::Identity();
      motion.translate(c + t);
      if (w.norm() > 0) motion.rotate(Eigen::AngleAxisd(w.norm(), w.normalized()));
      motion.translate(-c);
      out[f] = motion * bases[f];
    }
    return out;
  };
  auto residual_vectors = [&](const Evaluation& e) {
    std::vector<Eigen::Vector3d> r(m);
    for (int i = 0; i < m; ++i) r[i] = e.residual.segment<3>(3 * i);
    return r;
  };

  Evaluation current, trial;
  evaluate(result.params, extra_bases, current);
  result.nominal_residuals = residual_vectors(current);
  result.nominal = Summarise(Distances(result.nominal_residuals));

  Eigen::MatrixXd normal(unknowns, unknowns), weighted(3 * m, unknowns);
  Eigen::VectorXd gradient(unknowns);
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
      std::vector<Eigen::Isometry3d> trial_bases = moved_bases(extra_bases, step);
      evaluate(trial_params, trial_bases, trial);
      if (std::isfinite(trial.cost) && trial.cost <= current.cost) {
        const double relative_decrease =
            (current.cost - trial.cost) / std::max(current.cost, 1e-300);
        const double relative_step =
            step.norm() / (result.params.norm() + options.parameter_tolerance);
        result.params = trial_params;
        extra_bases = std::move(trial_bases);
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
  result.bases[result.reference_frame] = result.world_from_base;
  for (int f = 0; f < extra_frames; ++f) result.bases[frames[f]] = extra_bases[f];

  // Covariance of the identified parameters: σ0² (Jᵀ W J)⁻¹ at the solution (the further
  // frames' bases are unknowns of the same adjustment: their block is marginalised).
  build_normal_equations(current);
  result.cost = current.cost;
  result.redundancy = 3 * m - unknowns;
  result.fit_residuals = residual_vectors(current);
  double weighted_sq = 0.0;
  for (int i = 0; i < m; ++i) weighted_sq += weights[i] * result.fit_residuals[i].squaredNorm();
  result.sigma0_mm = std::sqrt(weighted_sq / result.redundancy);
  if (k > 0) {
    const Eigen::MatrixXd normal_inverse =
        normal.ldlt().solve(Eigen::MatrixXd::Identity(unknowns, unknowns));
    Eigen::MatrixXd covariance;
    if (model.base) {
      covariance = result.sigma0_mm * result.sigma0_mm * normal_inverse;
    } else {
      // The reference base was aligned on its frame's measurements, then held: a two-stage
      // estimate. To first order the alignment moves the base by db = (BᵀB)⁻¹Bᵀ dy, with B
      // the 3m × 6 derivative of the world positions by a small rotation and translation of
      // the base (zero in the rows of other frames), and the unknowns answer the rest:
      // du = N⁻¹JᵀW (I − B(BᵀB)⁻¹Bᵀ) dy. Hence Cov(u) = σ0² N⁻¹ Cᵀ W⁻¹ C N⁻¹ with
      // C = (I − P_B) W J. Without this, the parameters the base alignment already explains
      // (the first joint's) would be reported two to three times less certain than repeated
      // fits show them to be.
      Eigen::MatrixXd base_jacobian = Eigen::MatrixXd::Zero(3 * m, 6);
      const Eigen::Vector3d origin = result.world_from_base.translation();
      for (int i = 0; i < m; ++i) {
        if (extra[i] >= 0) continue;
        const Eigen::Vector3d x = poses[i].target_in_world + result.fit_residuals[i] - origin;
        base_jacobian.block<3, 3>(3 * i, 0) << 0, x.z(), -x.y(), -x.z(), 0, x.x(), x.y(), -x.x(), 0;
        base_jacobian.block<3, 3>(3 * i, 3).setIdentity();
      }
      Eigen::MatrixXd c = current.jacobian;
      for (int i = 0; i < m; ++i) c.middleRows<3>(3 * i) *= weights[i];
      const Eigen::Matrix<double, 6, 6> base_normal = base_jacobian.transpose() * base_jacobian;
      c -= base_jacobian * base_normal.ldlt().solve(base_jacobian.transpose() * c);
      for (int i = 0; i < m; ++i) c.middleRows<3>(3 * i) /= std::sqrt(std::max(weights[i], 1e-12));
      covariance = result.sigma0_mm * result.sigma0_mm * normal_inverse * (c.transpose() * c) *
                   normal_inverse;
    }
    result.covariance = covariance.topLeftCorner(k, k);
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
                result.params.allFinite() && result.covariance.allFinite();
  for (const auto& [frame, base] : result.bases) finite = finite && base.matrix().allFinite();
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

void TermSelectionOptions::Check() const {
  if (!(alpha > 0 && alpha < 1)) throw std::invalid_argument("F-test alpha must be in (0, 1)");
  if (folds < 2) throw std::invalid_argument("cross-validation needs at least 2 folds");
  if (!(min_cv_gain >= 0 && min_cv_gain < 1)) {
    throw std::invalid_argument("minimum cross-validation gain must be in [0, 1)");
  }
}

AutoSelection SelectTerms(const RobotModel& model, const std::vector<MeasuredPose>& poses,
                          const EstimationOptions& options,
                          const TermSelectionOptions& selection_options) {
  selection_options.Check();
  AutoSelection selection;
  EstimationOptions opts = options;
  for (int i = 0; i < model.num_geometric(); ++i) selection.parameters.push_back(i);
  opts.parameters = selection.parameters;
  EstimationResult current = Estimate(model, poses, opts);
  std::vector<int> remaining;
  for (int i = model.num_geometric(); i < model.num_parameters(); ++i) {
    if (options.parameters.empty() ||
        std::find(options.parameters.begin(), options.parameters.end(), i) !=
            options.parameters.end()) {
      remaining.push_back(i);
    }
  }
  const auto names = model.ParameterNames();
  const int m = static_cast<int>(poses.size());
  const bool cross_validate = selection_options.cross_validate && m >= 2 * selection_options.folds;
  const std::vector<int> folds =
      cross_validate ? AssignFolds(m, selection_options.folds, selection_options.seed)
                     : std::vector<int>(m, 0);
  // A candidate is identifiable next to the current set when its unit-scaled column keeps
  // a part orthogonal to theirs above the rank tolerance (the QR's criterion).
  const double tolerance = std::max(options.identifiability.relative_tolerance, 1e-6);
  Kinematics kin(model);
  Eigen::Matrix<double, 3, Eigen::Dynamic> block(3, model.num_parameters());
  bool first = true;
  // One round per added term; the first also measures the geometric model's CV error, even
  // when there is nothing to add.
  while (current.usable() && (first || !remaining.empty())) {
    // Linearise at the current fit: columns of the identified subset, then the candidates.
    const std::vector<int>& kept = current.identifiability.identified;
    const int k = static_cast<int>(kept.size());
    const int c = static_cast<int>(remaining.size());
    Eigen::MatrixXd jacobian(3 * m, k + c);
    Eigen::VectorXd residual(3 * m);
    for (int i = 0; i < m; ++i) {
      // Each pose in its own measurement frame's base (held at the fit's value).
      const Eigen::Vector3d x =
          kin.PositionAndJacobian(current.base_of(poses[i].frame), current.params, poses[i].joints_rad.data(), block);
      residual.segment<3>(3 * i) = x - poses[i].target_in_world;
      for (int a = 0; a < k; ++a) jacobian.block<3, 1>(3 * i, a) = block.col(kept[a]);
      for (int a = 0; a < c; ++a) jacobian.block<3, 1>(3 * i, k + a) = block.col(remaining[a]);
    }
    const LinearisedCrossValidation cv(jacobian, residual, folds,
                                       cross_validate ? selection_options.folds : 1);
    std::vector<int> base(k);
    for (int a = 0; a < k; ++a) base[a] = a;
    if (first) {
      if (cross_validate)
        selection.cv_mean_mm_geometric = selection.cv_mean_mm = cv.HeldOutMeanMm(base);
      first = false;
    }
    if (remaining.empty()) break;
    const double rss_base = cv.ResidualSumOfSquares(base);
    // Projections onto the kept columns, for the identifiability check and the RSS drop.
    Eigen::MatrixXd normal = jacobian.transpose() * jacobian;
    const Eigen::LDLT<Eigen::MatrixXd> kept_normal(normal.topLeftCorner(k, k));
    int best = -1, best_record = -1;
    double best_cv = std::numeric_limits<double>::infinity(), best_f = 0.0;
    for (int a = 0; a < c; ++a) {
      const int col = k + a;
      const Eigen::VectorXd cross = normal.block(0, col, k, 1);
      const double schur = normal(col, col) - cross.dot(kept_normal.solve(cross));
      if (!(normal(col, col) > 0) || !(schur > tolerance * tolerance * normal(col, col))) continue;
      std::vector<int> with = base;
      with.push_back(col);
      FTest test;
      test.added = names[remaining[a]];
      test.rss_reduced = rss_base;
      test.rss_full = cv.ResidualSumOfSquares(with);
      test.df_added = 1;
      test.df_residual = current.redundancy - 1;  // 3m − rank − 6 per extra frame − 1
      if (test.df_residual > 0 && test.rss_full > 0) {
        test.f =
            std::max(0.0, (test.rss_reduced - test.rss_full) / (test.rss_full / test.df_residual));
        test.p_value = FisherFSurvival(test.f, 1, test.df_residual);
        test.significant = test.p_value < selection_options.alpha;
      }
      if (test.significant && cross_validate) test.cv_mean_mm = cv.HeldOutMeanMm(with);
      const bool better = cross_validate ? test.significant && test.cv_mean_mm < best_cv
                                         : test.significant && test.f > best_f;
      if (better) {
        best = a;
        best_record = static_cast<int>(selection.tests.size());
        best_cv = test.cv_mean_mm;
        best_f = test.f;
      }
      selection.tests.push_back(test);
    }
    if (best < 0) break;
    if (cross_validate && best_cv > (1.0 - selection_options.min_cv_gain) * selection.cv_mean_mm) {
      break;
    }
    // Add it: refit both ways and redo its F-test on the fitted models.
    std::vector<int> trial_parameters = selection.parameters;
    trial_parameters.push_back(remaining[best]);
    std::sort(trial_parameters.begin(), trial_parameters.end());
    opts.parameters = trial_parameters;
    EstimationResult trial = Estimate(model, poses, opts);
    if (!trial.usable()) break;
    FTest exact = CompareNested(current, trial, names[remaining[best]], selection_options.alpha);
    if (!exact.significant) break;
    exact.cv_mean_mm = selection.tests[best_record].cv_mean_mm;
    exact.accepted = true;
    selection.tests[best_record] = exact;  // the fitted models' test replaces the linearised one
    selection.parameters = trial_parameters;
    if (cross_validate) selection.cv_mean_mm = best_cv;
    remaining.erase(remaining.begin() + best);
    current = std::move(trial);
  }
  return selection;
}

AutoSelection SelectTermsByFTest(const RobotModel& model, const std::vector<MeasuredPose>& poses,
                                 const EstimationOptions& options, double alpha) {
  TermSelectionOptions selection;
  selection.alpha = alpha;
  return SelectTerms(model, poses, options, selection);
}

}  // namespace armsig::calibration
