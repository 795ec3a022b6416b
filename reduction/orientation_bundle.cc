#include "reduction/orientation_bundle.h"

#include <Eigen/Eigenvalues>
#include <Eigen/SparseCholesky>
#include <algorithm>
#include <cmath>

#include "core/units.h"
#include "reduction/observation.h"
#include "reduction/orientation_costs.h"

namespace armsig::reduction {

namespace {

constexpr double kArcsecPerRad = 1.0 / kRadPerArcsec;
using Kind = ResidualReport::Kind;

// The unknown a sighting points at: another station's centre or a target point (nullptr for a
// point left out of the adjustment).
double* TargetOf(const IndexedObservation& o, BundleUnknowns& u) {
  if (o.target_station >= 0) return u.station_pos[o.target_station].data();
  auto it = u.point_index.find(o.point);
  return it == u.point_index.end() ? nullptr : u.point_pos[it->second].data();
}

// The Hz and V rows of one sighting (either may have been removed) and its distance.
// Cauchy's loss for a robust adjustment, else none (least squares). Ceres owns it.
ceres::LossFunction* Loss(double robust_scale) {
  return robust_scale > 0 ? new ceres::CauchyLoss(robust_scale) : nullptr;
}

void AddSighting(const IndexedObservation& o, const IndexedNetwork& network, BundleUnknowns& u,
                 const std::set<ObservationKey>& removed, double robust_scale, Bundle& bundle) {
  double* point = TargetOf(o, u);
  if (!point) return;  // one-ray point: reported, not adjusted
  double* station = u.station_pos[o.station].data();
  double* rotation = u.station_rot[o.station].data();
  const bool levelled = u.levelled[o.station];
  const std::string label = network.station_ids[o.station] + "->" + o.point;
  const std::string group = o.target_station >= 0 ? "mutual pointings" : "angles";
  const double sigma_across = NearPole(o.v) ? o.sigma.v_rad : o.sigma.hz_rad;
  const ResidualRow hz_row{Kind::kHz, o.source, label, sigma_across * kArcsecPerRad, group};
  const ResidualRow v_row{Kind::kV, o.source, label, o.sigma.v_rad * kArcsecPerRad, group};
  const bool hz = !removed.count({Kind::kHz, o.source});
  const bool v = !removed.count({Kind::kV, o.source});
  ceres::CostFunction* cost = nullptr;
  if (hz && v) {
    cost = levelled ? AngleResidual<1>::Create(o.hz, o.v, o.sigma.hz_rad, o.sigma.v_rad)
                    : AngleResidual<3>::Create(o.hz, o.v, o.sigma.hz_rad, o.sigma.v_rad);
    bundle.rows.push_back(hz_row);
    bundle.rows.push_back(v_row);
  } else if (hz || v) {
    const int component = hz ? 0 : 1;
    cost = levelled
               ? AngleComponentResidual<1>::Create(o.hz, o.v, o.sigma.hz_rad, o.sigma.v_rad,
                                                   component)
               : AngleComponentResidual<3>::Create(o.hz, o.v, o.sigma.hz_rad, o.sigma.v_rad,
                                                   component);
    bundle.rows.push_back(hz ? hz_row : v_row);
  }
  if (cost) {
    bundle.blocks.push_back(bundle.problem->AddResidualBlock(cost, Loss(robust_scale), station,
                                                             rotation, point));
  }
  if (o.distance && !removed.count({Kind::kDistance, o.source})) {
    bundle.blocks.push_back(
        bundle.problem->AddResidualBlock(LengthResidual::Create(*o.distance, o.sigma.distance_mm),
                                         Loss(robust_scale), station, point));
    bundle.rows.push_back({Kind::kDistance, o.source, label, o.sigma.distance_mm, "distances"});
  }
}

void SetConstant(ceres::Problem& problem, double* block) {
  if (problem.HasParameterBlock(block)) problem.SetParameterBlockConstant(block);
}

// Adjusted target points all on one line: the likely cause of a singular network.
bool TargetsCollinear(const BundleUnknowns& u, const IndexedNetwork& network) {
  std::vector<Eigen::Vector3d> pts;
  for (size_t k = 0; k < u.point_ids.size(); ++k) {
    if (!network.control.count(u.point_ids[k])) pts.push_back(u.point_pos[k]);
  }
  if (pts.size() < 2) return false;
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (const auto& p : pts) mean += p;
  mean /= static_cast<double>(pts.size());
  Eigen::Matrix3d scatter = Eigen::Matrix3d::Zero();
  for (const auto& p : pts) scatter += (p - mean) * (p - mean).transpose();
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(scatter);
  return eig.eigenvalues()(1) < 1e-6 * eig.eigenvalues()(2);
}

}  // namespace

BundleUnknowns UnknownsFrom(const IndexedNetwork& network, const InitialValues& initial,
                            std::vector<std::pair<std::string, std::string>>& excluded) {
  const std::vector<StationState>& st = initial.stations;
  BundleUnknowns u;
  u.offset = st[0].position;
  for (const auto& s : st) {
    u.levelled.push_back(s.levelled);
    u.station_pos.push_back(s.position - u.offset);
    u.station_rot.push_back(s.levelled ? Eigen::Vector3d(s.azimuth, 0, 0) : s.angle_axis);
  }
  for (const auto& id : network.usable) {
    auto it = initial.points.find(id);
    if (it == initial.points.end()) continue;
    u.point_index[id] = static_cast<int>(u.point_ids.size());
    u.point_ids.push_back(id);
    u.point_pos.push_back(it->second - u.offset);
  }
  for (const auto& [id, rays] : network.rays_of_point) {
    if (!network.usable.count(id)) {
      excluded.push_back({id, "one ray and no distance"});
    } else if (!u.point_index.count(id)) {
      excluded.push_back({id, "rays nearly parallel: no approximate position"});
    }
  }
  return u;
}

Bundle BuildBundle(const OrientationProblem& problem, const IndexedNetwork& network,
                   BundleUnknowns& u, const std::set<ObservationKey>& removed,
                   double robust_scale) {
  Bundle bundle;
  bundle.problem = std::make_unique<ceres::Problem>();
  for (const auto& o : network.obs) AddSighting(o, network, u, removed, robust_scale, bundle);
  for (size_t b = 0; b < problem.scale_bars.size(); ++b) {
    const auto& bar = problem.scale_bars[b];
    if (removed.count({Kind::kScaleBar, static_cast<int>(b)})) continue;
    bundle.blocks.push_back(bundle.problem->AddResidualBlock(
        LengthResidual::Create(bar.length_mm, bar.sigma_mm), Loss(robust_scale),
        u.point_pos[u.point_index.at(bar.from)].data(),
        u.point_pos[u.point_index.at(bar.to)].data()));
    bundle.rows.push_back({Kind::kScaleBar, static_cast<int>(b), bar.from + ":" + bar.to,
                           bar.sigma_mm, "scale bars"});
  }
  for (size_t c = 0; c < problem.control.size(); ++c) {
    const auto& cp = problem.control[c];
    auto it = u.point_index.find(cp.id);
    if (it == u.point_index.end()) continue;
    double* x = u.point_pos[it->second].data();
    if (!cp.sigma_mm) {
      SetConstant(*bundle.problem, x);
      continue;
    }
    if (removed.count({Kind::kControl, static_cast<int>(c)})) continue;
    bundle.blocks.push_back(bundle.problem->AddResidualBlock(
        ControlResidual::Create(cp.position_mm - u.offset, *cp.sigma_mm), Loss(robust_scale), x));
    for (int i = 0; i < 3; ++i) {
      bundle.rows.push_back(
          {Kind::kControl, static_cast<int>(c), cp.id, (*cp.sigma_mm)(i), "control"});
    }
  }
  if (network.use_control) {
    bundle.datum = "control points (" + std::to_string(network.fixed_control) + " fixed, " +
                   std::to_string(problem.control.size() - network.fixed_control) + " weighted)";
  } else {
    // The datum of the interface reference: the first station at the origin, levelled,
    // circle zero = azimuth 0. Fixing its position and azimuth removes exactly the 4 degrees
    // of freedom a levelled network has; the scale comes from bars and distances.
    SetConstant(*bundle.problem, u.station_pos[0].data());
    SetConstant(*bundle.problem, u.station_rot[0].data());
    bundle.datum = "station " + network.station_ids[0] + " at the origin, levelled, azimuth 0";
  }
  return bundle;
}

BundleSolve SolveBundle(Bundle& bundle, const BundleUnknowns& u, int max_iterations,
                        double tolerance) {
  ceres::Solver::Options options;
  options.linear_solver_type = ceres::DENSE_SCHUR;
  options.max_num_iterations = max_iterations;
  options.function_tolerance = tolerance;
  options.gradient_tolerance = tolerance;
  options.parameter_tolerance = tolerance;
  options.num_threads = 1;
  options.logging_type = ceres::SILENT;
  ceres::Solver::Summary summary;
  ceres::Solve(options, bundle.problem.get(), &summary);
  BundleSolve solve;
  solve.iterations = static_cast<int>(summary.iterations.size());
  solve.converged = summary.termination_type == ceres::CONVERGENCE;
  // A failed solve (e.g. a cost or derivative that is not finite) leaves nothing to take
  // statistics of.
  if (summary.termination_type == ceres::FAILURE) {
    solve.failure = "the adjustment failed: " + summary.message;
    return solve;
  }
  bool finite = true;
  for (const auto* set : {&u.station_pos, &u.station_rot, &u.point_pos})
    for (const auto& p : *set) finite = finite && p.allFinite();
  if (!finite) solve.failure = "an estimate is not finite after the adjustment";
  return solve;
}

std::optional<Linearisation> Linearise(Bundle& bundle, BundleUnknowns& u,
                                       const IndexedNetwork& network, const BundleSolve& solve,
                                       SolveStatus& failure) {
  ceres::Problem& problem = *bundle.problem;
  Linearisation lin;
  std::vector<double*> free_blocks;
  int columns = 0;
  auto add_block = [&](double* block, int size) {
    if (!problem.HasParameterBlock(block) || problem.IsParameterBlockConstant(block)) return;
    lin.column_of[block] = columns;
    columns += size;
    free_blocks.push_back(block);
  };
  for (size_t i = 0; i < u.station_pos.size(); ++i) {
    add_block(u.station_pos[i].data(), 3);
    add_block(u.station_rot[i].data(), u.levelled[i] ? 1 : 3);
  }
  for (auto& p : u.point_pos) add_block(p.data(), 3);
  ceres::Problem::EvaluateOptions eval;
  eval.parameter_blocks = free_blocks;
  eval.residual_blocks = bundle.blocks;
  eval.apply_loss_function = false;
  ceres::CRSMatrix crs;
  if (!problem.Evaluate(eval, nullptr, &lin.residuals, nullptr, &crs) ||
      static_cast<int>(lin.residuals.size()) != crs.num_rows ||
      static_cast<int>(crs.rows.size()) != crs.num_rows + 1 ||
      !std::all_of(lin.residuals.begin(), lin.residuals.end(),
                   [](double r) { return std::isfinite(r); }) ||
      !std::all_of(crs.values.begin(), crs.values.end(),
                   [](double v) { return std::isfinite(v); })) {
    failure = {SolveCode::kNonFinite,
               "the residuals or their derivatives at the solution are not finite"};
    return std::nullopt;
  }
  std::vector<Eigen::Triplet<double>> triplets;
  for (int r = 0; r < crs.num_rows; ++r) {
    for (int idx = crs.rows[r]; idx < crs.rows[r + 1]; ++idx)
      triplets.emplace_back(r, crs.cols[idx], crs.values[idx]);
  }
  lin.jacobian.resize(crs.num_rows, crs.num_cols);
  lin.jacobian.setFromTriplets(triplets.begin(), triplets.end());
  const Eigen::SparseMatrix<double> normal =
      Eigen::SparseMatrix<double>(lin.jacobian.transpose()) * lin.jacobian;
  Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> ldlt(normal);
  // Singularity test on the column-scaled normal matrix (units differ: mm and rad).
  const Eigen::VectorXd scale = normal.diagonal().cwiseMax(1e-300).cwiseSqrt().cwiseInverse();
  const Eigen::SparseMatrix<double> scaled = scale.asDiagonal() * normal * scale.asDiagonal();
  Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> check(scaled);
  const bool singular = check.info() != Eigen::Success || ldlt.info() != Eigen::Success ||
                        check.vectorD().minCoeff() < 1e-8;  // healthy networks: ~1e-3
  if (singular && !solve.converged) {
    // Iterations that ran out ending on a singular network: not a datum defect but an
    // adjustment that went astray (typically a gross blunder far from the other rays).
    failure = {SolveCode::kNotConverged,
               "the adjustment did not converge after " + std::to_string(solve.iterations) +
                   " iterations and ended on a degenerate network (a gross blunder? check the "
                   "rays of the points named in the warnings, and rays read at the zenith or "
                   "nadir)"};
    return std::nullopt;
  }
  if (singular) {
    failure = {SolveCode::kDegenerate,
               TargetsCollinear(u, network)
                   ? "all target points lie on one line: the stations can turn about it, the "
                     "network has no unique shape (add targets off the line, distances or "
                     "mutual pointings)"
                   : "the network is singular: its shape, datum or scale is not determined by "
                     "the observations"};
    return std::nullopt;
  }
  lin.q = ldlt.solve(Eigen::MatrixXd::Identity(columns, columns));
  return lin;
}

namespace {

// One observation's residual function over its unknowns: whitened residual × sigma = its
// residual in report units (arcsec, mm).
struct SingleObservation {
  std::unique_ptr<ceres::CostFunction> cost;
  std::vector<double*> blocks;
  double sigma = 1.0;
};

// nullopt for a control point, or a sighting of a point left out of the adjustment.
std::optional<SingleObservation> SingleOf(const OrientationProblem& problem,
                                          const IndexedNetwork& network, BundleUnknowns& u,
                                          const ObservationKey& key) {
  SingleObservation single;
  if (key.kind == Kind::kControl) return std::nullopt;
  if (key.kind == Kind::kScaleBar) {
    const auto& bar = problem.scale_bars[key.index];
    single.cost.reset(LengthResidual::Create(bar.length_mm, bar.sigma_mm));
    single.blocks = {u.point_pos[u.point_index.at(bar.from)].data(),
                     u.point_pos[u.point_index.at(bar.to)].data()};
    single.sigma = bar.sigma_mm;
    return single;
  }
  const int at = network.obs_of_source.at(key.index);
  if (at < 0) return std::nullopt;
  const IndexedObservation& o = network.obs[at];
  double* point = TargetOf(o, u);
  if (!point) return std::nullopt;
  if (key.kind == Kind::kDistance) {
    single.cost.reset(LengthResidual::Create(*o.distance, o.sigma.distance_mm));
    single.blocks = {u.station_pos[o.station].data(), point};
    single.sigma = o.sigma.distance_mm;
    return single;
  }
  const int component = key.kind == Kind::kHz ? 0 : 1;
  single.cost.reset(
      u.levelled[o.station]
          ? AngleComponentResidual<1>::Create(o.hz, o.v, o.sigma.hz_rad, o.sigma.v_rad, component)
          : AngleComponentResidual<3>::Create(o.hz, o.v, o.sigma.hz_rad, o.sigma.v_rad,
                                              component));
  single.blocks = {u.station_pos[o.station].data(), u.station_rot[o.station].data(), point};
  single.sigma =
      (component == 0 && !NearPole(o.v) ? o.sigma.hz_rad : o.sigma.v_rad) * kArcsecPerRad;
  return single;
}

}  // namespace

double ObservedMinusPredicted(const OrientationProblem& problem, const IndexedNetwork& network,
                              BundleUnknowns& u, const ObservationKey& key) {
  if (key.kind == Kind::kControl) {
    const auto& cp = problem.control[key.index];
    const Eigen::Vector3d at = u.point_pos[u.point_index.at(cp.id)] + u.offset;
    return (cp.position_mm - at).norm();
  }
  const std::optional<SingleObservation> single = SingleOf(problem, network, u, key);
  double residual = 0.0;
  if (!single || !single->cost->Evaluate(single->blocks.data(), &residual, nullptr))
    return std::nan("");
  return -residual * single->sigma;  // the residual is computed − observed, whitened
}

std::optional<PredictedTest> PredictedTestOf(const OrientationProblem& problem,
                                             const IndexedNetwork& network, BundleUnknowns& u,
                                             const Linearisation& lin, const ObservationKey& key) {
  const std::optional<SingleObservation> single = SingleOf(problem, network, u, key);
  if (!single) return std::nullopt;
  const std::vector<int32_t>& sizes = single->cost->parameter_block_sizes();
  std::vector<std::vector<double>> jacobians(sizes.size());
  std::vector<double*> pointers;
  for (size_t b = 0; b < sizes.size(); ++b) {
    jacobians[b].assign(sizes[b], 0.0);
    pointers.push_back(jacobians[b].data());
  }
  double residual = 0.0;
  if (!single->cost->Evaluate(single->blocks.data(), &residual, pointers.data()))
    return std::nullopt;
  Eigen::VectorXd a = Eigen::VectorXd::Zero(lin.q.rows());
  for (size_t b = 0; b < sizes.size(); ++b) {
    auto it = lin.column_of.find(single->blocks[b]);
    if (it == lin.column_of.end()) continue;  // a constant block
    for (int k = 0; k < sizes[b]; ++k) a(it->second + k) += jacobians[b][k];
  }
  const double spread = 1.0 + a.dot(lin.q * a);  // of the predicted residual, whitened
  return PredictedTest{residual / std::sqrt(spread), 1.0 / spread, -residual * single->sigma};
}

}  // namespace armsig::reduction
