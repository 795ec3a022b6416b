#include "calibration/drift.h"

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <Eigen/QR>
#include <Eigen/SVD>
#include <algorithm>
#include <boost/math/distributions/chi_squared.hpp>
#include <cmath>

#include "calibration/identifiability.h"

namespace armsig::calibration {

namespace {

// Relative singular value below which a combination of (unit-scaled) parameters is taken
// not to change the arm's shape at all.
constexpr double kShapeRankTolerance = 1e-7;

// Orthonormal basis (3m × r) of the shape changes the `identified` parameters make: the
// columns of `jacobian` for them, less their rigid-motion part (`rigid`, orthonormal),
// each scaled to unit length (mm and rad mixed), to rank by kShapeRankTolerance.
Eigen::MatrixXd ShapeSpace(const Eigen::MatrixXd& jacobian, const std::vector<int>& identified,
                           const Eigen::MatrixXd& rigid) {
  Eigen::MatrixXd columns = jacobian(Eigen::all, identified);
  const Eigen::VectorXd norms = columns.colwise().norm().transpose();
  columns -= rigid * (rigid.transpose() * columns);
  columns = columns * norms.cwiseMax(1e-300).cwiseInverse().asDiagonal();
  Eigen::JacobiSVD<Eigen::MatrixXd> svd(columns, Eigen::ComputeThinU);
  const Eigen::VectorXd& s = svd.singularValues();
  int rank = 0;
  for (int c = 0; c < s.size(); ++c) rank += s(c) > kShapeRankTolerance * s(0);
  return svd.matrixU().leftCols(rank);
}

// Positions (3 × m) in the robot's own frame, and their Jacobian with respect to every
// parameter (3m × np) when asked.
Eigen::Matrix3Xd Positions(const RobotModel& model, const Eigen::VectorXd& params,
                           const std::vector<Eigen::VectorXd>& configurations,
                           Eigen::MatrixXd* jacobian) {
  const int m = static_cast<int>(configurations.size());
  Kinematics kin(model);
  Eigen::Matrix<double, 3, Eigen::Dynamic> block(3, model.num_parameters());
  Eigen::Matrix3Xd positions(3, m);
  if (jacobian) jacobian->resize(3 * m, model.num_parameters());
  for (int i = 0; i < m; ++i) {
    positions.col(i) = kin.PositionAndJacobian(Eigen::Isometry3d::Identity(), params,
                                               configurations[i].data(), block);
    if (jacobian) jacobian->middleRows<3>(3 * i) = block;
  }
  return positions;
}

// The set's covariance in the space of every parameter (zero where not identified).
void AddCovariance(const FittedSet& set, Eigen::MatrixXd& sum) {
  const int k = static_cast<int>(set.identified.size());
  for (int r = 0; r < k; ++r)
    for (int c = 0; c < k; ++c) sum(set.identified[r], set.identified[c]) += set.covariance(r, c);
}

// Orthonormal basis (3m × 6) of the six small rigid motions of `positions` (linearised
// about them): what a rigid alignment of one set of positions onto another absorbs.
Eigen::MatrixXd RigidMotionBasis(const Eigen::Matrix3Xd& positions) {
  const int m = static_cast<int>(positions.cols());
  Eigen::MatrixXd rigid(3 * m, 6);
  const Eigen::Vector3d centre = positions.rowwise().mean();
  for (int i = 0; i < m; ++i) {
    const Eigen::Vector3d x = positions.col(i) - centre;
    rigid.block<3, 3>(3 * i, 0) << 0, x.z(), -x.y(), -x.z(), 0, x.x(), x.y(), -x.x(), 0;
    rigid.block<3, 3>(3 * i, 3).setIdentity();
  }
  const Eigen::HouseholderQR<Eigen::MatrixXd> qr(rigid);
  return qr.householderQ() * Eigen::MatrixXd::Identity(3 * m, 6);
}

}  // namespace

PredictedDifference PredictDifference(const RobotModel& model, const FittedSet& a,
                                      const FittedSet& b,
                                      const std::vector<Eigen::VectorXd>& configurations) {
  PredictedDifference out;
  const int m = static_cast<int>(configurations.size());
  out.positions_a = Positions(model, a.params, configurations, &out.jacobian);
  const Eigen::Matrix3Xd xb = Positions(model, b.params, configurations, nullptr);
  // b's positions rigidly onto a's (no scale): what is left is the change of the arm.
  const Eigen::Matrix4d align = m >= 3 ? Eigen::Matrix4d(Eigen::umeyama(xb, out.positions_a, false))
                                       : Eigen::Matrix4d::Identity();
  const Eigen::Matrix3Xd aligned =
      (align.topLeftCorner<3, 3>() * xb).colwise() + align.topRightCorner<3, 1>();
  const Eigen::Matrix3Xd delta = aligned - out.positions_a;
  out.change = Eigen::Map<const Eigen::VectorXd>(delta.data(), 3 * m);
  // Var(Δ) = J (Σ_a + Σ_b) Jᵀ (one Jacobian: the sets differ by far less than the
  // linearisation cares about), written G Gᵀ with G = J V diag(√λ) from the
  // eigen-decomposition of Σ_a + Σ_b.
  const int np = model.num_parameters();
  out.covariance_sum = Eigen::MatrixXd::Zero(np, np);
  AddCovariance(a, out.covariance_sum);
  AddCovariance(b, out.covariance_sum);
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eigen(out.covariance_sum);
  out.noise_factor = out.jacobian * eigen.eigenvectors() *
                     eigen.eigenvalues().cwiseMax(0.0).cwiseSqrt().asDiagonal();
  return out;
}

DifferenceProfile ProfileDifference(const RobotModel& model, const FittedSet& a, const FittedSet& b,
                                    const std::vector<Eigen::VectorXd>& configurations) {
  DifferenceProfile out;
  const int m = static_cast<int>(configurations.size());
  if (m == 0) return out;
  const PredictedDifference predicted = PredictDifference(model, a, b, configurations);
  Eigen::MatrixXd g = predicted.noise_factor;
  if (m >= 3) {
    const Eigen::MatrixXd basis = RigidMotionBasis(predicted.positions_a);
    g -= basis * (basis.transpose() * g);
  }
  for (int i = 0; i < m; ++i) {
    const Eigen::Vector3d delta = predicted.change.segment<3>(3 * i);
    const double distance = delta.norm();
    // Var(|Δ|) ≈ uᵀ C u along u = Δ/|Δ| (linearised); at Δ = 0, the largest direction's.
    const Eigen::Matrix3d c = g.middleRows<3>(3 * i) * g.middleRows<3>(3 * i).transpose();
    const double variance =
        distance > 0.0 ? (delta / distance).dot(c * (delta / distance))
                       : Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(c).eigenvalues()(2);
    out.distance_mm.push_back(distance);
    out.sigma_mm.push_back(std::sqrt(std::max(variance, 0.0)));
    if (out.worst < 0 || distance > out.distance_mm[out.worst]) out.worst = i;
  }
  return out;
}

ModelComparison CompareModels(const RobotModel& model, const FittedSet& a, const FittedSet& b,
                              const std::vector<Eigen::VectorXd>& configurations) {
  ModelComparison out;
  const int m = static_cast<int>(configurations.size());
  out.configurations = m;
  if (m == 0) return out;
  const PredictedDifference predicted = PredictDifference(model, a, b, configurations);
  const Eigen::Matrix3Xd& xa = predicted.positions_a;
  const Eigen::MatrixXd& jacobian = predicted.jacobian;
  const Eigen::MatrixXd& both = predicted.covariance_sum;
  double sum = 0.0, sum_sq = 0.0;
  for (int i = 0; i < m; ++i) {
    const double d = predicted.change.segment<3>(3 * i).norm();
    sum += d;
    sum_sq += d * d;
    if (d > out.max_mm) {
      out.max_mm = d;
      out.worst = i;
    }
  }
  out.mean_mm = sum / m;
  out.rms_mm = std::sqrt(sum_sq / m);

  // Δᵀ C⁺ Δ = ‖G⁺ Δ‖² for Δ in the range of G (PredictDifference's factor).
  // Models are compared modulo a rigid motion, so both Δ and G lose their components along
  // the six small rigid motions of the positions (linearised at a's positions) first:
  // otherwise a residual rigid part of Δ meets the near-zero variance the base alignment
  // leaves in those directions.
  Eigen::MatrixXd g = predicted.noise_factor;
  if (a.identified.empty() && b.identified.empty()) return out;
  const Eigen::MatrixXd basis = RigidMotionBasis(xa);
  const Eigen::VectorXd& stacked = predicted.change;
  Eigen::VectorXd d = stacked - basis * (basis.transpose() * stacked);
  g -= basis * (basis.transpose() * g);
  // Sets stored before a robot's subset was fixed may have identified different subsets
  // (alpha5, gamma5 in one; gamma4, b6 in the other). Each then spans a shape change the
  // other cannot make, held at nominal there; along it the two differ by that bias, not
  // by noise, and Σ_a + Σ_b has next to no variance: noise would read as a huge χ². They
  // are compared on the shape changes both can make (the intersection of their spaces,
  // from the principal angles); with equal subsets that is everything.
  if (a.identified != b.identified && !a.identified.empty() && !b.identified.empty()) {
    const Eigen::MatrixXd qa = ShapeSpace(jacobian, a.identified, basis);
    const Eigen::MatrixXd qb = ShapeSpace(jacobian, b.identified, basis);
    Eigen::MatrixXd both_spaces(qa.rows(), qa.cols() + qb.cols());
    both_spaces << qa, qb;
    const Eigen::VectorXd su = Eigen::JacobiSVD<Eigen::MatrixXd>(both_spaces).singularValues();
    int union_rank = 0;
    for (int c = 0; c < su.size(); ++c) union_rank += su(c) > kShapeRankTolerance * su(0);
    const int shared = static_cast<int>(qa.cols() + qb.cols()) - union_rank;
    Eigen::JacobiSVD<Eigen::MatrixXd> angles(qa.transpose() * qb, Eigen::ComputeThinU);
    const Eigen::MatrixXd common = qa * angles.matrixU().leftCols(std::max(shared, 0));
    d = common * (common.transpose() * d);
    g = common * (common.transpose() * g);
    out.shared_shape_space = false;
  }
  Eigen::JacobiSVD<Eigen::MatrixXd> svd(g, Eigen::ComputeThinU | Eigen::ComputeThinV);
  const Eigen::VectorXd& s = svd.singularValues();
  const double threshold = s.size() ? 1e-8 * s(0) : 0.0;
  const Eigen::VectorXd projected = svd.matrixU().transpose() * d;
  for (int c = 0; c < s.size(); ++c) {
    if (s(c) <= threshold) continue;
    ++out.dof;
    out.chi2 += (projected(c) / s(c)) * (projected(c) / s(c));
  }
  if (out.dof > 0) {
    boost::math::chi_squared distribution(out.dof);
    out.p_value = boost::math::cdf(boost::math::complement(distribution, out.chi2));
  }

  // Per parameter, on the common subset, with the rigid-motion (gauge) part removed.
  std::vector<int> common;
  for (int k : a.identified) {
    if (std::find(b.identified.begin(), b.identified.end(), k) != b.identified.end())
      common.push_back(k);
  }
  std::sort(common.begin(), common.end());
  const int nc = static_cast<int>(common.size());
  if (nc == 0) return out;
  Eigen::MatrixXd jc(3 * m, nc), sc(nc, nc);
  Eigen::VectorXd delta_p(nc), weight(nc);
  for (int c = 0; c < nc; ++c) {
    jc.col(c) = jacobian.col(common[c]);
    delta_p(c) = b.params(common[c]) - a.params(common[c]);
    for (int r = 0; r < nc; ++r) sc(r, c) = both(common[r], common[c]);
  }
  jc -= basis * (basis.transpose() * jc);  // what each parameter does beyond a rigid motion
  // Parameter combinations that only move the arm rigidly: the null space of jc, found on
  // unit-length columns (mm and rad mixed).
  const Eigen::VectorXd norms = jacobian(Eigen::all, common).colwise().norm().transpose();
  Eigen::JacobiSVD<Eigen::MatrixXd> shape(jc * norms.cwiseMax(1e-300).cwiseInverse().asDiagonal(),
                                          Eigen::ComputeFullV);
  const Eigen::VectorXd& sv = shape.singularValues();
  int rigid_count = 0;
  for (int c = 0; c < sv.size(); ++c) rigid_count += sv(c) <= kShapeRankTolerance * sv(0);
  rigid_count += nc - static_cast<int>(sv.size());
  Eigen::MatrixXd q = Eigen::MatrixXd::Identity(nc, nc);
  if (rigid_count > 0) {
    const Eigen::MatrixXd n =
        norms.cwiseMax(1e-300).cwiseInverse().asDiagonal() * shape.matrixV().rightCols(rigid_count);
    for (int c = 0; c < nc; ++c) weight(c) = sc(c, c) > 0 ? 1.0 / sc(c, c) : 1.0;
    // δ' = Q δ, Q = I − N (Nᵀ W N)⁻¹ Nᵀ W: the change less its W-closest rigid combination.
    const Eigen::MatrixXd wn = weight.asDiagonal() * n;
    q -= n * (n.transpose() * wn).ldlt().solve(wn.transpose());
  }
  const Eigen::VectorXd shape_change = q * delta_p;
  const Eigen::MatrixXd shape_covariance = q * sc * q.transpose();
  for (int c = 0; c < nc; ++c) {
    ParameterDrift d;
    d.parameter = common[c];
    d.change = shape_change(c);
    d.sigma = std::sqrt(std::max(shape_covariance(c, c), 0.0));
    // A combination that is wholly rigid leaves nothing to judge.
    d.z = d.sigma > 1e-12 * std::sqrt(std::max(sc(c, c), 1e-300)) ? d.change / d.sigma : 0.0;
    out.parameters.push_back(d);
  }
  std::sort(out.parameters.begin(), out.parameters.end(),
            [](const auto& x, const auto& y) { return std::abs(x.z) > std::abs(y.z); });
  return out;
}

IdentifiabilityReport ModelIdentifiability(const RobotModel& model,
                                           const std::vector<int>& candidates,
                                           double relative_tolerance, bool orientation) {
  IdentifiabilityOptions options;
  options.relative_tolerance = relative_tolerance;
  const int count = std::max(100, 3 * static_cast<int>(candidates.size()));
  const std::vector<Eigen::VectorXd> configurations = SpreadConfigurations(model, count);
  OrientationRows rows;  // one set-up: one unknown tool rotation, as the fit estimates it
  rows.setup.assign(configurations.size(), 0);
  return AnalyseIdentifiability(model, Eigen::Isometry3d::Identity(), configurations, candidates,
                                options, orientation ? &rows : nullptr);
}

std::vector<int> ModelIdentifiableSubset(const RobotModel& model,
                                         const std::vector<int>& candidates,
                                         double relative_tolerance) {
  return ModelIdentifiability(model, candidates, relative_tolerance).identified;
}

}  // namespace armsig::calibration
