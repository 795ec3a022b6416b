#include "calibration/identifiability.h"

#include <Eigen/Eigenvalues>
#include <Eigen/QR>
#include <Eigen/SVD>
#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <numbers>
#include <random>
#include <stdexcept>

#include "calibration/synthetic.h"

namespace armsig::calibration {

void IdentifiabilityOptions::Check() const {
  if (!(relative_tolerance > 0.0 && relative_tolerance < 1.0)) {
    throw std::invalid_argument("identifiability tolerance must be in (0, 1)");
  }
}

Eigen::MatrixXd StackedJacobian(const RobotModel& model, const Eigen::Isometry3d& world_from_base,
                                const Eigen::VectorXd& params,
                                const std::vector<Eigen::VectorXd>& joints_rad,
                                const OrientationRows* orientation) {
  const int m = static_cast<int>(joints_rad.size());
  const int np = model.num_parameters();
  Kinematics kin(model);
  if (!orientation) {
    Eigen::MatrixXd j(3 * m, np);
    Eigen::Matrix<double, 3, Eigen::Dynamic> block(3, np);
    for (int i = 0; i < m; ++i) {
      kin.PositionAndJacobian(world_from_base, params, joints_rad[i].data(), block);
      j.middleRows(3 * i, 3) = block;
    }
    return j;
  }
  if (static_cast<int>(orientation->setup.size()) != m) {
    throw std::invalid_argument("StackedJacobian: one set-up per configuration expected");
  }
  int oriented = 0;
  for (int s : orientation->setup) oriented += s >= 0;
  Eigen::MatrixXd j(3 * m + 3 * oriented, np);
  Eigen::Matrix<double, 6, Eigen::Dynamic> block(6, np);
  // Rotation rows in the last link's own frame: the frame the tool rotation turns in.
  std::map<int, std::pair<Eigen::MatrixXd, int>> setup_sum;  // per set-up: Σ rows, count
  std::vector<int> row_of(m, -1);
  int o = 0;
  for (int i = 0; i < m; ++i) {
    kin.PoseAndJacobian(world_from_base, params, joints_rad[i].data(), block);
    j.middleRows(3 * i, 3) = block.topRows<3>();
    const int setup = orientation->setup[i];
    if (setup < 0) continue;
    row_of[i] = 3 * m + 3 * o++;
    j.middleRows(row_of[i], 3) =
        orientation->weight_mm_per_rad * kin.LastRotation().transpose() * block.bottomRows<3>();
    auto& [sum, count] = setup_sum[setup];
    if (count == 0) sum = Eigen::MatrixXd::Zero(3, np);
    sum += j.middleRows(row_of[i], 3);
    ++count;
  }
  for (int i = 0; i < m; ++i) {
    if (row_of[i] < 0) continue;
    const auto& [sum, count] = setup_sum[orientation->setup[i]];
    j.middleRows(row_of[i], 3) -= sum / count;
  }
  return j;
}

namespace {

constexpr double kNegligibleColumn = 1e-10;

// Columns of `jacobian` for `candidates`, each scaled to unit norm (zero columns stay zero).
Eigen::MatrixXd ScaledColumns(const Eigen::MatrixXd& jacobian, const std::vector<int>& candidates) {
  Eigen::MatrixXd a(jacobian.rows(), candidates.size());
  double largest = 0.0;
  for (size_t k = 0; k < candidates.size(); ++k) {
    largest = std::max(largest, jacobian.col(candidates[k]).norm());
  }
  for (size_t k = 0; k < candidates.size(); ++k) {
    a.col(k) = jacobian.col(candidates[k]);
    const double norm = a.col(k).norm();
    // A column that is rounding noise against the largest one (γ6 with the target on the
    // joint-6 axis: 1e-14 instead of 0) is zero; scaling it to unit norm would turn
    // noise into a spurious "identifiable" parameter.
    if (norm > kNegligibleColumn * largest) {
      a.col(k) /= norm;
    } else {
      a.col(k).setZero();
    }
  }
  return a;
}

// Orthonormal basis of the numerical null space of `a` (columns).
Eigen::MatrixXd NullSpace(const Eigen::MatrixXd& a, double tolerance) {
  Eigen::JacobiSVD<Eigen::MatrixXd> svd(a, Eigen::ComputeFullV);
  const Eigen::VectorXd& s = svd.singularValues();
  const double limit = s.size() > 0 ? s(0) * tolerance : 0.0;
  int rank = 0;
  while (rank < s.size() && s(rank) > limit) ++rank;
  return svd.matrixV().rightCols(a.cols() - rank);
}

}  // namespace

IdentifiabilityReport AnalyseJacobian(const Eigen::MatrixXd& jacobian,
                                      const std::vector<int>& candidates,
                                      const IdentifiabilityOptions& options) {
  options.Check();
  IdentifiabilityReport report;
  report.candidates = candidates;
  if (candidates.empty() || jacobian.rows() == 0) {
    report.unidentified = candidates;
    return report;
  }
  const Eigen::MatrixXd a = ScaledColumns(jacobian, candidates);
  Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr(a);
  qr.setThreshold(options.relative_tolerance);
  report.rank = static_cast<int>(qr.rank());
  const auto& perm = qr.colsPermutation().indices();
  std::vector<int> chosen, dropped;  // positions in `candidates`
  for (int k = 0; k < perm.size(); ++k) (k < report.rank ? chosen : dropped).push_back(perm(k));
  std::sort(chosen.begin(), chosen.end());
  std::sort(dropped.begin(), dropped.end());
  for (int k : chosen) report.identified.push_back(candidates[k]);
  for (int k : dropped) report.unidentified.push_back(candidates[k]);

  const int r = report.rank;
  if (r > 0) {
    // A·P = Q·[R11 R12; 0 R22]: the kept columns are Q1·R11, so their singular values are
    // those of R11 (r × r), and each left-out column is kept·(R11⁻¹ R12) + Q2·R22.
    const Eigen::MatrixXd rr =
        qr.matrixR()
            .topLeftCorner(std::min<Eigen::Index>(a.rows(), a.cols()), a.cols())
            .template triangularView<Eigen::Upper>();
    const Eigen::MatrixXd r11 = rr.topLeftCorner(r, r);
    // Singular values of R11 from the eigenvalues of R11ᵀR11 (r × r, cheap; the squared
    // condition is harmless for a figure reported to three digits).
    const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eigen(r11.transpose() * r11,
                                                               Eigen::EigenvaluesOnly);
    const Eigen::VectorXd& ev = eigen.eigenvalues();  // ascending
    report.condition_number = ev(0) > 0 ? std::sqrt(ev(ev.size() - 1) / ev(0)) : INFINITY;
    const int dropped_count = static_cast<int>(a.cols()) - r;
    if (dropped_count > 0) {
      const Eigen::MatrixXd r12 = rr.block(0, r, r, dropped_count);
      const Eigen::MatrixXd coefficients =
          r11.triangularView<Eigen::Upper>().solve(r12);  // r × dropped, in pivot order
      for (int d = 0; d < dropped_count; ++d) {
        Dependency dep;
        const int column = perm(r + d);
        dep.parameter = candidates[column];
        dep.residual = rr.rows() > r ? rr.block(r, r + d, rr.rows() - r, 1).norm() : 0.0;
        const Eigen::VectorXd c = coefficients.col(d);
        const double largest = c.size() ? c.cwiseAbs().maxCoeff() : 0.0;
        for (int i = 0; i < c.size(); ++i) {
          if (std::abs(c(i)) > 0.05 * largest && std::abs(c(i)) > 1e-9) {
            dep.on.push_back({candidates[perm(i)], c(i)});
          }
        }
        std::sort(dep.on.begin(), dep.on.end(), [](const auto& x, const auto& y) {
          return std::abs(x.second) > std::abs(y.second);
        });
        report.dependencies.push_back(std::move(dep));
      }
      std::sort(report.dependencies.begin(), report.dependencies.end(),
                [](const Dependency& x, const Dependency& y) { return x.parameter < y.parameter; });
    }
  }
  return report;
}

std::vector<Eigen::VectorXd> SpreadConfigurations(const RobotModel& model, int count,
                                                  unsigned seed) {
  std::mt19937 rng(seed);
  // Within the joint limits when the model has them, else within ±π.
  const bool limited = static_cast<int>(model.joint_min_rad.size()) == model.num_joints();
  return RandomConfigurations(model, count, rng,
                              limited ? std::numeric_limits<double>::infinity() : std::numbers::pi);
}

IdentifiabilityReport AnalyseIdentifiability(const RobotModel& model,
                                             const Eigen::Isometry3d& world_from_base,
                                             const std::vector<Eigen::VectorXd>& joints_rad,
                                             const std::vector<int>& asked,
                                             const IdentifiabilityOptions& options,
                                             const OrientationRows* orientation) {
  // The model's held parameters are never candidates (RobotModel::HeldParameters).
  std::vector<int> candidates;
  for (int k : asked) {
    if (!model.IsHeld(k)) candidates.push_back(k);
  }
  const Eigen::VectorXd zero = Eigen::VectorXd::Zero(model.num_parameters());
  const int spread_count = std::max(20, static_cast<int>(candidates.size()));
  const auto spread = SpreadConfigurations(model, spread_count);
  bool any_orientation = false;
  if (orientation) {
    for (int s : orientation->setup) any_orientation |= s >= 0;
  }
  OrientationRows spread_rows;
  if (any_orientation) {
    spread_rows.setup.assign(spread.size(), 0);
    spread_rows.weight_mm_per_rad = orientation->weight_mm_per_rad;
  }
  const OrientationRows* spread_orientation = any_orientation ? &spread_rows : nullptr;
  if (!any_orientation) orientation = nullptr;
  const Eigen::MatrixXd spread_jacobian =
      StackedJacobian(model, world_from_base, zero, spread, spread_orientation);
  const int structural_rank = AnalyseJacobian(spread_jacobian, candidates, options).rank;

  // Large data: decide on an evenly spaced subsample first. Data can never identify more
  // than the model's structural rank, so a subsample that reaches it decides exactly;
  // otherwise the whole Jacobian is factorised.
  IdentifiabilityReport report;
  const size_t kSubsample = 1000;
  bool decided = false;
  if (joints_rad.size() > 2 * kSubsample) {
    std::vector<Eigen::VectorXd> subset;
    OrientationRows subset_rows;
    if (orientation) subset_rows.weight_mm_per_rad = orientation->weight_mm_per_rad;
    const double stride = static_cast<double>(joints_rad.size()) / kSubsample;
    for (size_t i = 0; i < kSubsample; ++i) {
      subset.push_back(joints_rad[static_cast<size_t>(i * stride)]);
      if (orientation) subset_rows.setup.push_back(orientation->setup[static_cast<size_t>(i * stride)]);
    }
    report = AnalyseJacobian(
        StackedJacobian(model, world_from_base, zero, subset, orientation ? &subset_rows : nullptr),
        candidates, options);
    decided = report.rank == structural_rank;
  }
  Eigen::MatrixXd jacobian;
  if (!decided) {
    jacobian = StackedJacobian(model, world_from_base, zero, joints_rad, orientation);
    report = AnalyseJacobian(jacobian, candidates, options);
  }
  report.structural_rank = structural_rank;
  report.held = model.HeldParameters();

  // A joint whose encoder angle never changes cannot separate the parameters around it.
  const int n = model.num_joints();
  if (joints_rad.empty()) return report;
  for (int j = 0; j < n; ++j) {
    double lo = joints_rad[0](j), hi = lo;
    for (const auto& q : joints_rad) {
      lo = std::min(lo, q(j));
      hi = std::max(hi, q(j));
    }
    if (hi - lo > 1e-6) continue;
    FrozenJoint frozen;
    frozen.joint = j;
    frozen.range_rad = hi - lo;
    if (jacobian.size() == 0)
      jacobian = StackedJacobian(model, world_from_base, zero, joints_rad, orientation);
    // Null-space directions of the data that are not null directions of the model:
    // the parameters with weight in them are the ones this joint's motion would separate.
    const Eigen::MatrixXd structural_null =
        NullSpace(ScaledColumns(spread_jacobian, candidates), options.relative_tolerance);
    const Eigen::MatrixXd data_null =
        NullSpace(ScaledColumns(jacobian, candidates), options.relative_tolerance);
    Eigen::MatrixXd extra = data_null;
    if (structural_null.cols() > 0) {
      extra -= structural_null * (structural_null.transpose() * data_null);
    }
    const Eigen::VectorXd weight = extra.rowwise().norm();
    for (int k = 0; k < weight.size(); ++k) {
      if (weight(k) > 0.1) frozen.affected.push_back(candidates[k]);
    }
    report.frozen_joints.push_back(std::move(frozen));
  }
  return report;
}

}  // namespace armsig::calibration
