#include "calibration/change.h"

#include <fmt/format.h>

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <Eigen/QR>
#include <Eigen/SVD>
#include <algorithm>
#include <boost/math/distributions/chi_squared.hpp>
#include <cmath>
#include <map>
#include <optional>
#include <stdexcept>

#include "calibration/signature_limits.h"

namespace armsig::calibration {

namespace {

// A cause whose column keeps less than this share of its length once the free rigid
// motions are taken out is one a moved measuring frame makes.
constexpr double kFrameOnly = 1e-6;
// Causes whose columns point the same way to within this cosine cannot be told apart.
constexpr double kEquivalentCosine = 0.9995;
// Causes this alike whose fits differ by less than the noise can tell are not told apart.
constexpr double kSimilarCosine = 0.95;
constexpr double kChi2Tell = 3.84;  // χ²₁ at 95 %

Eigen::VectorXd Unit(int size, int index) {
  Eigen::VectorXd d = Eigen::VectorXd::Zero(size);
  d(index) = 1.0;
  return d;
}

// Orthonormal basis (3m × 6g) of the small rigid motions of each group of positions
// (rotations about the group's centroid, translations).
Eigen::MatrixXd RigidBasis(const std::vector<Eigen::Vector3d>& positions,
                           const std::vector<int>& group) {
  const int m = static_cast<int>(positions.size());
  const int groups = m ? *std::max_element(group.begin(), group.end()) + 1 : 0;
  std::vector<Eigen::Vector3d> centre(groups, Eigen::Vector3d::Zero());
  std::vector<int> count(groups, 0);
  for (int i = 0; i < m; ++i) {
    centre[group[i]] += positions[i];
    ++count[group[i]];
  }
  for (int g = 0; g < groups; ++g) centre[g] /= std::max(count[g], 1);
  Eigen::MatrixXd rigid = Eigen::MatrixXd::Zero(3 * m, 6 * groups);
  for (int i = 0; i < m; ++i) {
    const Eigen::Vector3d x = positions[i] - centre[group[i]];
    rigid.block<3, 3>(3 * i, 6 * group[i]) << 0, x.z(), -x.y(), -x.z(), 0, x.x(), x.y(), -x.x(),
        0;
    rigid.block<3, 3>(3 * i, 6 * group[i] + 3).setIdentity();
  }
  const Eigen::HouseholderQR<Eigen::MatrixXd> qr(rigid);
  return qr.householderQ() * Eigen::MatrixXd::Identity(3 * m, rigid.cols());
}

Eigen::VectorXd RemoveRigid(const Eigen::MatrixXd& basis, const Eigen::VectorXd& v) {
  return v - basis * (basis.transpose() * v);
}

// Positions (and, when asked, each cause's column) at configurations in their frames.
struct Columns {
  std::vector<Eigen::Vector3d> positions;
  Eigen::MatrixXd causes;  // 3m × causes
};

Columns CauseColumns(const RobotModel& model, const Eigen::VectorXd& params,
                     const std::vector<Eigen::VectorXd>& configurations,
                     const std::vector<Eigen::Isometry3d>& world_from_base,
                     const std::vector<int>& group, const std::vector<Cause>& causes) {
  const int m = static_cast<int>(configurations.size());
  Kinematics kin(model);
  Eigen::Matrix<double, 3, Eigen::Dynamic> jacobian(3, model.num_parameters());
  Columns out;
  out.positions.resize(m);
  Eigen::MatrixXd parameter_columns(3 * m, model.num_parameters());
  for (int i = 0; i < m; ++i) {
    out.positions[i] = kin.PositionAndJacobian(world_from_base[i], params,
                                               configurations[i].data(), jacobian);
    parameter_columns.middleRows<3>(3 * i) = jacobian;
  }
  const int groups = m ? *std::max_element(group.begin(), group.end()) + 1 : 0;
  std::vector<Eigen::Vector3d> centre(groups, Eigen::Vector3d::Zero());
  std::vector<int> count(groups, 0);
  for (int i = 0; i < m; ++i) {
    centre[group[i]] += out.positions[i];
    ++count[group[i]];
  }
  for (int g = 0; g < groups; ++g) centre[g] /= std::max(count[g], 1);
  out.causes.resize(3 * m, static_cast<int>(causes.size()));
  for (size_t c = 0; c < causes.size(); ++c) {
    if (causes[c].scale) {
      // The instrument reads every length (1 + s) times: positions move away from the
      // group's centre (its translation is free) in proportion to their distance.
      for (int i = 0; i < m; ++i)
        out.causes.col(c).segment<3>(3 * i) = out.positions[i] - centre[group[i]];
    } else {
      out.causes.col(c) = parameter_columns * causes[c].direction;
    }
  }
  return out;
}

double ChiSquareSurvival(double chi2, int dof) {
  if (dof <= 0 || !(chi2 > 0.0)) return 1.0;
  if (!std::isfinite(chi2)) return 0.0;
  boost::math::chi_squared distribution(dof);
  return boost::math::cdf(boost::math::complement(distribution, chi2));
}

}  // namespace

std::vector<Cause> CandidateCauses(const RobotModel& model,
                                   const std::optional<std::vector<int>>& terms) {
  const int n = model.num_joints();
  const int np = model.num_parameters();
  const auto names = model.ParameterNames();
  std::vector<Cause> causes;
  auto single = [&](const std::string& name, int index, bool angle, int priority) {
    causes.push_back({name, names[index], angle, false, Unit(np, index), priority});
  };
  for (int i = 0; i < n; ++i) {
    const int joint = i + 1, at = 6 * i;
    if (!model.IsHeld(at + 5)) single(fmt::format("joint {} zero", joint), at + 5, true, 0);
    single(fmt::format("joint {} axis tilt about x", joint), at + 3, true, 1);
    single(fmt::format("joint {} axis tilt about y", joint), at + 4, true, 1);
    static constexpr const char* kAxis[3] = {"x", "y", "z"};
    for (int k = 0; k < 3; ++k)
      single(fmt::format("joint {} offset along {}", joint, kAxis[k]), at + k, false, 2);
    if (i == 0) continue;
    // Link i runs from joint i to joint i + 1: its nominal transform N_{i+1} (links[i-1]).
    // A longer link moves joint i + 1 along N's translation t, in N's parent frame:
    // Trans(δ t̂) N = N Trans(δ Rᵀ t̂), so H_{i+1}'s translation takes δ Rᵀ t̂.
    const Eigen::Isometry3d& link = model.links[i - 1];
    const Eigen::Vector3d t = link.translation();
    if (t.norm() <= 1.0) continue;
    Eigen::VectorXd direction = Eigen::VectorXd::Zero(np);
    direction.segment<3>(at) = link.rotation().transpose() * t.normalized();
    causes.push_back({fmt::format("link {} length (joint {} to joint {}, {:.0f} mm)", i, i,
                                  joint, t.norm()),
                      "", false, false, direction, 0});
  }
  const int tool = model.tool_index();
  static constexpr const char* kToolAxis[3] = {"x", "y", "z"};
  if (model.known_mounting()) {
    // The target's place is known: what moves it there is the flange's turn.
    for (int k = 0; k < 2; ++k)
      single(fmt::format("flange turn about axis u{} across the lever", k + 1),
             model.flange_turn_index() + k, true, 0);
  } else {
    for (int k = 0; k < 3; ++k)
      single(fmt::format("tool offset along {}", kToolAxis[k]), tool + k, false, 0);
  }
  if (!model.known_mounting() && model.tool_mm.norm() > 1.0) {
    Eigen::VectorXd direction = Eigen::VectorXd::Zero(np);
    direction.segment<3>(tool) = model.tool_mm.normalized();
    causes.push_back({fmt::format("tool length ({:.0f} mm)", model.tool_mm.norm()), "", false,
                      false, direction, 0});
  }
  for (size_t k = 0; k < model.nongeometric.size(); ++k) {
    const int index = model.num_geometric() + static_cast<int>(k);
    if (terms && std::find(terms->begin(), terms->end(), index) == terms->end()) continue;
    single(fmt::format("joint {} term {}", model.nongeometric[k].joint + 1,
                       model.nongeometric[k].name),
           index, true, 0);
  }
  causes.push_back({"instrument scale", "", false, true, {}, 0});
  return causes;
}

Explanation ExplainDifference(const RobotModel& model, const Eigen::VectorXd& params,
                              const Difference& difference, int best,
                              const std::optional<std::vector<int>>& terms) {
  const int m = static_cast<int>(difference.configurations.size());
  if (difference.world_from_base.size() != static_cast<size_t>(m) ||
      difference.group.size() != static_cast<size_t>(m) || difference.change.size() != 3 * m) {
    throw std::invalid_argument("ExplainDifference: configurations, frames, groups and the "
                                "change differ in size");
  }
  Explanation out;
  const std::vector<Cause> all = CandidateCauses(model, terms);
  if (m == 0) return out;
  const Columns columns =
      CauseColumns(model, params, difference.configurations, difference.world_from_base,
                   difference.group, all);
  const Eigen::MatrixXd rigid = RigidBasis(columns.positions, difference.group);
  const Eigen::VectorXd d = RemoveRigid(rigid, difference.change);
  out.sum_squares = d.squaredNorm();

  // Each cause's column less what a moved frame does.
  std::vector<int> kept;
  Eigen::MatrixXd projected(3 * m, static_cast<int>(all.size()));
  for (size_t c = 0; c < all.size(); ++c) {
    const Eigen::VectorXd raw = columns.causes.col(c);
    projected.col(c) = RemoveRigid(rigid, raw);
    if (raw.norm() == 0.0) continue;  // no effect at all on these configurations
    if (projected.col(c).norm() <= kFrameOnly * raw.norm()) {
      out.indistinguishable_from_frame.push_back(all[c].name);
      continue;
    }
    kept.push_back(static_cast<int>(c));
  }
  out.candidates = static_cast<int>(kept.size());
  if (kept.empty()) return out;

  // All causes at once: what they can explain together (d projected on the span of their
  // unit columns, to a relative singular value of 1e-10).
  {
    Eigen::MatrixXd a = projected(Eigen::all, kept);
    // The norms first: a product with a diagonal is assigned coefficient by coefficient, so a
    // diagonal taken from `a` itself was a column's norm recomputed at each entry, on a column
    // partly rescaled already (columns bent out of their span, at rows² × causes operations).
    const Eigen::RowVectorXd norms = a.colwise().norm();
    a = a * norms.cwiseInverse().asDiagonal();
    const Eigen::BDCSVD<Eigen::MatrixXd> svd(a, Eigen::ComputeThinU);
    const Eigen::VectorXd& sv = svd.singularValues();
    double explained = 0.0;
    for (int c = 0; c < sv.size(); ++c) {
      if (sv(c) > 1e-10 * sv(0)) explained += std::pow(svd.matrixU().col(c).dot(d), 2);
    }
    out.explainable_sum_squares = std::min(explained, out.sum_squares);
  }

  std::vector<ExplainedCause> ranked;
  std::vector<double> reduction_of;  // what each explains alone, uncapped: the ranking
  std::vector<int> column_of;        // each ranked cause's column in `projected`
  for (int c : kept) {
    const Eigen::VectorXd& col = projected.col(c);
    const double norm2 = col.squaredNorm();
    ExplainedCause e;
    e.cause = all[c];
    e.size = col.dot(d) / norm2;
    double variance = difference.sigma_mm * difference.sigma_mm / norm2;
    if (difference.noise_factor.size())
      variance += (difference.noise_factor.transpose() * col).squaredNorm() / (norm2 * norm2);
    e.sigma = std::sqrt(std::max(variance, 0.0));
    e.chi2 = e.sigma > 0 ? (e.size / e.sigma) * (e.size / e.sigma)
                         : std::numeric_limits<double>::infinity();
    // A size no robot shows (a tilt of degrees, a link centimetres longer) is not a cause
    // but a sign that these data are not this robot's, or not in its units: never named.
    if (!PlausibleCauseSize(e.size, e.cause.angle, e.cause.scale)) {
      out.implausible.push_back(e.cause.name);
      continue;
    }
    const double reduction = e.size * e.size * norm2;
    reduction_of.push_back(reduction);
    column_of.push_back(c);
    e.explained = out.explainable_sum_squares > 0
                      ? std::min(reduction / out.explainable_sum_squares, 1.0)
                      : 0.0;
    // Its effect where it was measured: the cause's column (each frame's rigid motion
    // already out) at its size.
    double sum = 0.0;
    for (int i = 0; i < m; ++i) {
      const double v = std::abs(e.size) * col.segment<3>(3 * i).norm();
      e.effect_max_mm = std::max(e.effect_max_mm, v);
      sum += v;
    }
    e.effect_mean_mm = sum / m;
    ranked.push_back(std::move(e));
  }
  std::vector<int> order(ranked.size());
  for (size_t k = 0; k < order.size(); ++k) order[k] = static_cast<int>(k);
  std::stable_sort(order.begin(), order.end(),
                   [&](int x, int y) { return reduction_of[x] > reduction_of[y]; });
  // The best distinct causes; a cause that looks the same as one already listed on these
  // data is named beside it.
  // The best distinct causes; a cause that looks the same as one already listed on these
  // data is named beside it (the name a lab uses first: a link's length before the offset
  // of the joint at its end).
  std::vector<int> listed;  // column of each listed cause
  std::vector<Eigen::VectorXd> unit(all.size());  // each ranked cause's column normalised, once
  for (int c : column_of) unit[c] = projected.col(c).normalized();
  for (int r : order) {
    const int column = column_of[r];
    const Eigen::VectorXd& u = unit[column];
    bool equivalent = false;
    for (size_t l = 0; l < listed.size(); ++l) {
      const Eigen::VectorXd& v = unit[listed[l]];
      ExplainedCause& shown = out.causes[l];
      // The same shape, or nearly the same and fitting the data no worse than the noise
      // can tell (a likelihood-ratio difference below χ²₁(95 %) = 3.84).
      const double cosine = std::abs(u.dot(v));
      const bool same = cosine > kEquivalentCosine ||
                        (cosine > kSimilarCosine && shown.chi2 - ranked[r].chi2 < kChi2Tell);
      if (!same) continue;
      if (ranked[r].cause.priority < shown.cause.priority) {
        ExplainedCause preferred = ranked[r];
        preferred.equivalent = shown.equivalent;
        preferred.equivalent.insert(preferred.equivalent.begin(), shown.cause.name);
        shown = std::move(preferred);
        listed[l] = column;
      } else {
        shown.equivalent.push_back(ranked[r].cause.name);
      }
      equivalent = true;
      break;
    }
    // Past `best`, only equivalents of what is listed are still collected.
    if (equivalent || (best >= 0 && static_cast<int>(out.causes.size()) >= best)) continue;
    listed.push_back(column);
    out.causes.push_back(ranked[r]);
  }
  return out;
}

Difference SetDifference(const RobotModel& model, const FittedSet& a, const FittedSet& b,
                         const std::vector<Eigen::VectorXd>& spread) {
  const PredictedDifference p = PredictDifference(model, a, b, spread);
  Difference out;
  out.configurations = spread;
  out.world_from_base.assign(spread.size(), Eigen::Isometry3d::Identity());
  out.group.assign(spread.size(), 0);
  out.change = p.change;
  out.noise_factor = p.noise_factor;
  return out;
}

void ChangeTestOptions::Check() const {
  if (!(significance > 0.0 && significance < 1.0))
    throw std::invalid_argument("the significance of a change test must be in (0, 1)");
  if (!(tolerance_mm >= 0.0)) throw std::invalid_argument("a change tolerance must be ≥ 0 mm");
}

namespace {

// The set's identified parameters refitted on the poses by one linearised least-squares
// step, each frame's base free (placed first on its own poses): the set the poses alone
// give, with the covariance their own scatter gives it. nullopt without redundancy.
std::optional<FittedSet> Refit(const RobotModel& model, const FittedSet& set,
                               const std::vector<MeasuredPose>& poses) {
  const int k = static_cast<int>(set.identified.size());
  const FrameBases bases = AlignFrameBases(model, set.params, poses);
  std::vector<MeasuredPose> placed;
  for (const auto& p : poses) {
    if (bases.count(p.frame)) placed.push_back(p);
  }
  const int m = static_cast<int>(placed.size());
  std::map<int64_t, int> group_of;
  for (const auto& p : placed) group_of.emplace(p.frame, 0);
  int groups = 0;
  for (auto& [frame, g] : group_of) g = groups++;
  if (k == 0 || 3 * m - k - 6 * groups < std::max(10, k)) return std::nullopt;
  Kinematics kin(model);
  Eigen::Matrix<double, 3, Eigen::Dynamic> jacobian(3, model.num_parameters());
  std::vector<Eigen::Vector3d> positions(m);
  std::vector<int> group(m);
  Eigen::VectorXd change(3 * m);
  Eigen::MatrixXd a(3 * m, k + 6 * groups);
  for (int i = 0; i < m; ++i) {
    positions[i] = kin.PositionAndJacobian(bases.at(placed[i].frame), set.params,
                                           placed[i].joints_rad.data(), jacobian);
    a.block(3 * i, 0, 3, k) = jacobian(Eigen::all, set.identified);
    change.segment<3>(3 * i) = placed[i].target_in_world - positions[i];
    group[i] = group_of.at(placed[i].frame);
  }
  a.rightCols(6 * groups) = RigidBasis(positions, group);
  const Eigen::VectorXd norms = a.colwise().norm().transpose().cwiseMax(1e-300);
  const Eigen::MatrixXd scaled = a * norms.cwiseInverse().asDiagonal();
  const Eigen::BDCSVD<Eigen::MatrixXd> svd(scaled, Eigen::ComputeThinU | Eigen::ComputeThinV);
  const Eigen::VectorXd& sv = svd.singularValues();
  Eigen::VectorXd inverse = Eigen::VectorXd::Zero(sv.size());
  int rank = 0;
  for (int c = 0; c < sv.size(); ++c) {
    if (sv(c) > 1e-10 * sv(0)) {
      inverse(c) = 1.0 / sv(c);
      ++rank;
    }
  }
  const int dof = 3 * m - rank;
  if (dof < 10) return std::nullopt;
  const Eigen::VectorXd x =
      svd.matrixV() * (inverse.asDiagonal() * (svd.matrixU().transpose() * change));
  const double sigma2 = (change - scaled * x).squaredNorm() / dof;
  // Cov(x) = σ² V S⁻² Vᵀ on the scaled columns; the parameters' block, unscaled.
  const Eigen::MatrixXd vs = svd.matrixV() * inverse.asDiagonal();
  const Eigen::MatrixXd covariance_scaled = sigma2 * vs * vs.transpose();
  FittedSet out;
  out.identified = set.identified;
  out.params = set.params;
  for (int c = 0; c < k; ++c) out.params(set.identified[c]) += x(c) / norms(c);
  const Eigen::VectorXd inv = norms.head(k).cwiseInverse();
  out.covariance = inv.asDiagonal() * covariance_scaled.topLeftCorner(k, k) * inv.asDiagonal();
  return out;
}

// J Σ^½ at the poses in their frames (3m × k): the set's prediction uncertainty there.
Eigen::MatrixXd PredictionFactor(const RobotModel& model, const FittedSet& set,
                                 const std::vector<MeasuredPose>& poses, const FrameBases& bases) {
  const int k = static_cast<int>(set.identified.size());
  if (k == 0 || set.covariance.rows() != k) return {};
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eigen(set.covariance);
  const Eigen::MatrixXd root =
      eigen.eigenvectors() * eigen.eigenvalues().cwiseMax(0.0).cwiseSqrt().asDiagonal();
  Kinematics kin(model);
  Eigen::Matrix<double, 3, Eigen::Dynamic> jacobian(3, model.num_parameters());
  Eigen::MatrixXd out(3 * poses.size(), k);
  for (size_t i = 0; i < poses.size(); ++i) {
    kin.PositionAndJacobian(bases.at(poses[i].frame), set.params, poses[i].joints_rad.data(),
                            jacobian);
    out.middleRows<3>(3 * i) = jacobian(Eigen::all, set.identified) * root;
  }
  return out;
}

// The poses' residuals under the reference, each frame placed on its own poses, as a
// difference of every cause to explain (all of them, ranked).
SessionTest Explain(const RobotModel& model, const ChangeReference& reference,
                    const std::vector<MeasuredPose>& poses) {
  SessionTest out;
  const FrameBases bases = AlignFrameBases(model, reference.set.params, poses);
  std::vector<MeasuredPose> placed;
  for (const auto& p : poses) {
    if (bases.count(p.frame)) placed.push_back(p);
  }
  std::map<int64_t, int> group_of;
  for (const auto& p : placed) group_of.emplace(p.frame, 0);
  for (auto& [frame, g] : group_of) {
    g = static_cast<int>(out.frames.size());
    out.frames.push_back(frame);
  }
  out.poses = static_cast<int>(placed.size());
  if (placed.empty()) return out;
  const auto residuals = Residuals(model, bases, reference.set.params, placed);
  Difference difference;
  difference.change.resize(3 * out.poses);
  double sum = 0.0, sum2 = 0.0;
  for (int i = 0; i < out.poses; ++i) {
    difference.configurations.push_back(placed[i].joints_rad);
    difference.world_from_base.push_back(bases.at(placed[i].frame));
    difference.group.push_back(group_of.at(placed[i].frame));
    // What the robot does now beyond what the reference predicts: measured − model.
    difference.change.segment<3>(3 * i) = -residuals[i];
    const double e = residuals[i].norm();
    sum += e;
    sum2 += e * e;
  }
  out.mean_mm = sum / out.poses;
  out.rms_mm = std::sqrt(sum2 / out.poses);
  // The measurements' noise: the reference's, or the session's own when it shows more (a
  // worse set-up must not read as a changed robot); and the uncertainty of the reference's
  // predictions at these configurations (a set fitted on few poses extrapolates poorly:
  // that is not the robot changing).
  difference.sigma_mm = reference.sigma_mm;
  difference.noise_factor = PredictionFactor(model, reference.set, placed, bases);
  out.explanation = ExplainDifference(model, reference.set.params, difference, -1, reference.terms);
  const int dof = 3 * out.poses - 6 * static_cast<int>(out.frames.size()) -
                  out.explanation.candidates;
  if (dof >= 10) {
    const double own = std::sqrt(
        std::max(out.explanation.sum_squares - out.explanation.explainable_sum_squares, 0.0) / dof);
    if (own > reference.sigma_mm) {
      difference.sigma_mm = own;
      out.explanation =
          ExplainDifference(model, reference.set.params, difference, -1, reference.terms);
    }
  }
  return out;
}

}  // namespace

ChangeReference MakeChangeReference(const RobotModel& model, const FittedSet& set,
                                    double sigma_mm, const std::vector<MeasuredPose>& poses,
                                    const std::optional<std::vector<int>>& terms) {
  ChangeReference out;
  out.set = set;
  out.sigma_mm = sigma_mm;
  out.terms = terms;
  if (const auto refit = Refit(model, set, poses)) out.set = *refit;
  std::map<int64_t, std::vector<MeasuredPose>> by_frame;
  for (const auto& p : poses) by_frame[p.frame].push_back(p);
  out.sessions = static_cast<int>(by_frame.size());
  // The overdispersion: how much more the single-cause estimates of the reference's own
  // sessions scatter than their noise says — the mean of every cause's χ² over every
  // session (≈ 1 for white residuals; more where the model leaves systematic residuals).
  // From two sessions on (one session's estimates are its own fit's).
  if (by_frame.size() >= 2) {
    double sum = 0.0;
    int count = 0;
    for (const auto& [frame, session] : by_frame) {
      for (const auto& c : Explain(model, out, session).explanation.causes) {
        if (!std::isfinite(c.chi2)) continue;
        sum += c.chi2;
        ++count;
      }
    }
    if (count > 0) out.overdispersion = std::max(1.0, sum / count);
  }
  return out;
}

SessionTest TestAgainstReference(const RobotModel& model, const ChangeReference& reference,
                                 const std::vector<MeasuredPose>& poses,
                                 const ChangeTestOptions& options) {
  options.Check();
  SessionTest out = Explain(model, reference, poses);
  const auto& causes = out.explanation.causes;
  if (causes.empty()) return out;
  // The most significant cause, judged against the reference's own scatter; Bonferroni
  // over all of them.
  const ExplainedCause* top = &causes.front();
  for (const auto& c : causes) {
    if (c.chi2 > top->chi2) top = &c;
  }
  out.chi2 = top->chi2 / reference.overdispersion;
  const int k = std::max(out.explanation.candidates, 1);
  out.p_value = std::min(1.0, k * ChiSquareSurvival(out.chi2, 1));
  out.effect_max_mm = top->effect_max_mm;
  out.disagrees = out.p_value < options.significance && out.effect_max_mm > options.tolerance_mm;
  return out;
}

ChangePoint LocateChange(const std::vector<bool>& disagrees) {
  ChangePoint out;
  int k = static_cast<int>(disagrees.size());
  while (k > 0 && disagrees[k - 1]) --k;
  if (k < static_cast<int>(disagrees.size())) out.first_changed = k;
  for (int i = 0; i < k; ++i) {
    if (disagrees[i]) out.outliers.push_back(i);
  }
  return out;
}

}  // namespace armsig::calibration
