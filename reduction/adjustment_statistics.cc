#include "reduction/adjustment_statistics.h"

#include <Eigen/Cholesky>
#include <algorithm>
#include <cmath>
#include <limits>

namespace armsig::reduction {

ResidualStatistics ResidualStatisticsOf(const Eigen::SparseMatrix<double>& jacobian,
                                        std::span<const double> residuals, const Eigen::MatrixXd& q,
                                        std::span<const ResidualRow> rows, double delta0) {
  ResidualStatistics out;
  const Eigen::SparseMatrix<double, Eigen::RowMajor> jr(jacobian);
  std::map<std::string, GroupVariance> groups;
  for (int row = 0; row < static_cast<int>(rows.size()); ++row) {
    const ResidualRow& meta = rows[row];
    // r_i = 1 − a_i Q a_iᵀ over the few columns a_i touches.
    double aqa = 0.0;
    for (Eigen::SparseMatrix<double, Eigen::RowMajor>::InnerIterator a(jr, row); a; ++a) {
      for (Eigen::SparseMatrix<double, Eigen::RowMajor>::InnerIterator c(jr, row); c; ++c) {
        aqa += a.value() * q(a.col(), c.col()) * c.value();
      }
    }
    const double redundancy = std::max(0.0, 1.0 - aqa);
    ResidualReport rep;
    rep.kind = meta.kind;
    rep.observation = meta.source;
    rep.label = meta.label;
    rep.residual = residuals[row] * meta.sigma;
    rep.sigma = meta.sigma;
    rep.redundancy = redundancy;
    rep.w = redundancy > 1e-6 ? residuals[row] / std::sqrt(redundancy) : 0.0;
    // Without redundancy a bias cannot be detected at all.
    rep.mdb = redundancy > 1e-6 ? meta.sigma * delta0 / std::sqrt(redundancy)
                                : std::numeric_limits<double>::infinity();
    out.residuals.push_back(rep);
    auto& g = groups[meta.group];
    g.group = meta.group;
    ++g.count;
    g.redundancy += redundancy;
    g.sigma0 += residuals[row] * residuals[row];  // Σv² for now
  }
  for (auto& [name, g] : groups) {
    g.sigma0 = g.redundancy > 1e-9 ? std::sqrt(g.sigma0 / g.redundancy) : 0.0;
    out.groups.push_back(g);
  }
  return out;
}

int InnerConstraintCovariance(std::span<const DatumBlock> all,
                              const std::set<std::string>& datum_ids, Eigen::MatrixXd& q,
                              std::map<const double*, int>& column_of) {
  std::map<const double*, int> full_of;
  int nf = 0;
  for (const auto& b : all) {
    full_of[b.data] = nf;
    nf += b.size;
  }
  auto in_datum = [&](const DatumBlock& b) {
    return b.kind == DatumBlock::Kind::kPosition && (datum_ids.empty() || datum_ids.count(b.id));
  };
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
  int count = 0;
  for (const auto& b : all) {
    if (in_datum(b)) {
      centroid += Eigen::Map<const Eigen::Vector3d>(b.data);
      ++count;
    }
  }
  if (count < 2) return 0;
  centroid /= count;
  Eigen::MatrixXd qf = Eigen::MatrixXd::Zero(nf, nf);
  for (const auto& a : all) {
    auto ia = column_of.find(a.data);
    if (ia == column_of.end()) continue;
    for (const auto& b : all) {
      auto ib = column_of.find(b.data);
      if (ib == column_of.end()) continue;
      qf.block(full_of[a.data], full_of[b.data], a.size, b.size) =
          q.block(ia->second, ib->second, a.size, b.size);
    }
  }
  // G: how a translation (x, y, z) and a rotation about z move every unknown.
  Eigen::MatrixXd g = Eigen::MatrixXd::Zero(nf, 4);
  Eigen::VectorXd e = Eigen::VectorXd::Zero(nf);
  for (const auto& b : all) {
    const int i = full_of[b.data];
    if (b.kind == DatumBlock::Kind::kPosition) {
      const Eigen::Vector3d x = Eigen::Map<const Eigen::Vector3d>(b.data) - centroid;
      g.block<3, 3>(i, 0).setIdentity();
      g(i, 3) = -x.y();
      g(i + 1, 3) = x.x();
      if (in_datum(b)) e.segment<3>(i).setOnes();
    } else if (b.kind == DatumBlock::Kind::kAzimuth) {
      g(i, 3) = -1.0;  // turning the frame by ω about z lowers every azimuth by ω
    } else {
      g(i + 2, 3) = 1.0;  // small-angle approximation for a free rotation
    }
  }
  // S = I − G (Gᵀ E G)⁻¹ Gᵀ E, Q_datum = S Q Sᵀ.
  const Eigen::MatrixXd ge = e.asDiagonal() * g;
  const Eigen::Matrix4d m = g.transpose() * ge;
  const Eigen::MatrixXd sm = Eigen::MatrixXd::Identity(nf, nf) - g * m.ldlt().solve(ge.transpose());
  q = sm * qf * sm.transpose();
  column_of = std::move(full_of);
  return count;
}

}  // namespace armsig::reduction
