// One adjustment of the orientation: the unknowns (shifted to the first station's start so
// that large coordinates, 1e7 mm, keep their precision), the Ceres problem of every
// observation data snooping has not removed, its solution, and the whitened Jacobian and
// cofactor matrix at the solution that the statistics need. Internal to Orient.
#pragma once

#include <ceres/ceres.h>

#include <Eigen/Core>
#include <Eigen/SparseCore>
#include <map>
#include <memory>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "core/error.h"
#include "reduction/adjustment_statistics.h"
#include "reduction/orientation.h"
#include "reduction/orientation_initial.h"
#include "reduction/orientation_network.h"

namespace armsig::reduction {

// One tested observation of the orientation: an Hz or V reading, a distance, a scale bar or
// a weighted control point (its three coordinates together).
struct ObservationKey {
  ResidualReport::Kind kind;
  int index;  // into problem.observations, scale_bars or control
  auto operator<=>(const ObservationKey&) const = default;
};

struct BundleUnknowns {
  Eigen::Vector3d offset = Eigen::Vector3d::Zero();  // world = unknown + offset
  std::vector<bool> levelled;
  std::vector<Eigen::Vector3d> station_pos;
  std::vector<Eigen::Vector3d> station_rot;  // levelled: the azimuth in [0]; else angle-axis
  std::vector<std::string> point_ids;
  std::map<std::string, int> point_index;
  std::vector<Eigen::Vector3d> point_pos;
};

// The unknowns at the initial values; points left out (one ray, or no approximate
// position) are named in `excluded` with the reason.
BundleUnknowns UnknownsFrom(const IndexedNetwork& network, const InitialValues& initial,
                            std::vector<std::pair<std::string, std::string>>& excluded);

struct Bundle {
  std::unique_ptr<ceres::Problem> problem;
  std::vector<ceres::ResidualBlockId> blocks;
  std::vector<ResidualRow> rows;  // one per residual, in block order
  std::string datum;              // what fixes it
};

// The least-squares problem of every observation not in `removed`, over `unknowns` (which
// must outlive it); the datum fixed by the control points, else by the first station.
// robust_scale > 0: each observation's squared whitened residual s enters through Cauchy's
// loss c² log(1 + s / c²), c = robust_scale, which a blunder cannot dominate.
Bundle BuildBundle(const OrientationProblem& problem, const IndexedNetwork& network,
                   BundleUnknowns& unknowns, const std::set<ObservationKey>& removed,
                   double robust_scale = 0.0);

struct BundleSolve {
  int iterations = 0;
  bool converged = false;
  std::string failure;  // non-empty: the solve failed or an estimate is not finite
};
// `tolerance`: Ceres's relative function, gradient and parameter tolerances (a start needs
// less than a result).
BundleSolve SolveBundle(Bundle& bundle, const BundleUnknowns& unknowns, int max_iterations,
                        double tolerance = 1e-14);

// The adjustment linearised at its solution.
struct Linearisation {
  Eigen::SparseMatrix<double> jacobian;  // whitened; rows as bundle.rows, the free columns
  std::vector<double> residuals;         // whitened, computed − observed
  Eigen::MatrixXd q;                     // (JᵀJ)⁻¹
  std::map<const double*, int> column_of;
};

// nullopt with `failure` when the residuals or derivatives are not finite (kNonFinite), the
// network is singular (kDegenerate, the message says why: a refusal) or a solve that ran
// out of iterations ended on a singular network (kNotConverged).
std::optional<Linearisation> Linearise(Bundle& bundle, BundleUnknowns& unknowns,
                                       const IndexedNetwork& network, const BundleSolve& solve,
                                       SolveStatus& failure);

// The observation's estimated error at the current unknowns: observed − predicted, in
// arcsec for angles and mm for lengths (a control point: the length of its discrepancy).
double ObservedMinusPredicted(const OrientationProblem& problem, const IndexedNetwork& network,
                              BundleUnknowns& unknowns, const ObservationKey& key);

// The test of an observation left out of the adjustment, from its predicted residual (what
// the adjustment without it predicts, minus what was read): w = v̄ / √(1 + a Q aᵀ)
// (whitened), which equals the w it would have in the adjustment with it, and its
// redundancy number there, r = 1 / (1 + a Q aᵀ).
struct PredictedTest {
  double w = 0.0;
  double redundancy = 0.0;
  double error = 0.0;  // observed − predicted, arcsec or mm
};
// nullopt for a control point or a sighting of a point left out of the adjustment.
std::optional<PredictedTest> PredictedTestOf(const OrientationProblem& problem,
                                             const IndexedNetwork& network,
                                             BundleUnknowns& unknowns, const Linearisation& lin,
                                             const ObservationKey& key);

}  // namespace armsig::reduction
