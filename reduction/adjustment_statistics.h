// Statistics of a least-squares adjustment from its whitened Jacobian A and cofactor
// matrix Q = (AᵀA)⁻¹ at the solution: redundancy numbers r_i = 1 − a_i Q a_iᵀ,
// standardised residuals w_i = v_i / √r_i and minimal detectable biases
// MDB_i = σ_i δ0 / √r_i (Baarda), variance components per group, and the
// S-transformation of Q to an inner-constraint (free network) datum.
#pragma once

#include <Eigen/Core>
#include <Eigen/SparseCore>
#include <map>
#include <set>
#include <span>
#include <string>
#include <vector>

#include "reduction/orientation.h"

namespace armsig::reduction {

// What one row of the whitened Jacobian is.
struct ResidualRow {
  ResidualReport::Kind kind;
  int source;
  std::string label;
  double sigma;  // a priori, report units (arcsec or mm): whitened residual × sigma = residual
  std::string group;
};

struct ResidualStatistics {
  std::vector<ResidualReport> residuals;  // one per row
  std::vector<GroupVariance> groups;      // by group name
};

// `whitened_residuals` and the rows of `jacobian` in the order of `rows`.
ResidualStatistics ResidualStatisticsOf(const Eigen::SparseMatrix<double>& jacobian,
                                        std::span<const double> whitened_residuals,
                                        const Eigen::MatrixXd& q, std::span<const ResidualRow> rows,
                                        double delta0);

// One parameter block of the adjustment, for the S-transformation.
struct DatumBlock {
  const double* data;  // current values
  int size;
  enum class Kind { kPosition, kAzimuth, kAngleAxis } kind;
  std::string id;
};

// S-transformation of the cofactor matrix `q` (columns of the free blocks given by
// `column_of`; constant blocks have none) to the inner-constraint datum over the positions
// in `datum_ids` (empty: every position): 3 translations and a rotation about z.
// On success `q` and `column_of` cover every block of `blocks` and the number of datum
// positions is returned; with fewer than 2 of them nothing changes and 0 is returned.
int InnerConstraintCovariance(std::span<const DatumBlock> blocks,
                              const std::set<std::string>& datum_ids, Eigen::MatrixXd& q,
                              std::map<const double*, int>& column_of);

}  // namespace armsig::reduction
