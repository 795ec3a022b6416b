#include "reduction/orientation.h"

#include <ceres/ceres.h>
#include <ceres/rotation.h>

#include <Eigen/Eigenvalues>
#include <Eigen/SparseCholesky>
#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "core/units.h"
#include "reduction/adjustment_statistics.h"
#include "reduction/observation.h"
#include "reduction/orientation_costs.h"
#include "reduction/orientation_initial.h"

namespace armsig::reduction {

void OrientationOptions::Check() const {
  if (max_iterations < 1) throw std::invalid_argument("max_iterations must be ≥ 1");
  if (!(critical_w > 0)) throw std::invalid_argument("critical_w must be > 0");
}

namespace {
constexpr double kArcsecPerRad = 1.0 / kRadPerArcsec;
}  // namespace

// The adjustment: index the problem, refuse what cannot be solved, initial values
// (orientation_initial.cc), the bundle (cost functions in orientation_costs.h), then the
// statistics (adjustment_statistics.cc) and the results in the input frame.
OrientationResult Orient(const OrientationProblem& problem, const OrientationOptions& options) {
  options.Check();
  OrientationResult result;
  auto refuse = [&](std::string why) { result.refusals.push_back(std::move(why)); };
  // The network cannot be solved: status kDegenerate naming every refusal.
  auto refused = [&]() -> OrientationResult& {
    std::string why;
    for (const auto& r : result.refusals) why += (why.empty() ? "" : "; ") + r;
    result.status = {SolveCode::kDegenerate, why};
    return result;
  };

  // --- Index stations, points and observations.
  IndexedNetwork network;
  std::vector<std::string>& station_ids = network.station_ids;
  std::map<std::string, int>& station_index = network.station_index;
  for (const auto& id : problem.station_ids) {
    if (!station_index.emplace(id, static_cast<int>(station_ids.size())).second) {
      refuse("station " + id + " is listed twice");
      continue;
    }
    station_ids.push_back(id);
  }
  for (const auto& obs : problem.observations) {
    if (!station_index.count(obs.station)) {
      station_index.emplace(obs.station, static_cast<int>(station_ids.size()));
      station_ids.push_back(obs.station);
    }
  }
  const int ns = static_cast<int>(station_ids.size());
  std::vector<Station>& station_info = network.station_info;
  station_info.resize(ns);
  for (int i = 0; i < ns; ++i) {
    station_info[i].pose.id = station_ids[i];
    if (auto it = problem.sigma_hz_rad.find(station_ids[i]); it != problem.sigma_hz_rad.end())
      station_info[i].sigma_hz_rad = it->second;
    if (auto it = problem.sigma_v_rad.find(station_ids[i]); it != problem.sigma_v_rad.end())
      station_info[i].sigma_v_rad = it->second;
  }
  std::map<std::string, ControlPoint>& control = network.control;
  for (const auto& c : problem.control) {
    if (!control.emplace(c.id, c).second) refuse("control point " + c.id + " is given twice");
  }

  using Obs = IndexedObservation;
  std::vector<Obs>& obs = network.obs;
  auto& rays_of_point = network.rays_of_point;
  auto& stations_of_point = network.stations_of_point;
  for (size_t k = 0; k < problem.observations.size(); ++k) {
    const Observation& o = problem.observations[k];
    Obs x;
    x.station = station_index.at(o.station);
    const AngleReading face1 = ToFaceOne(o.reading);
    x.hz = face1.hz_rad;
    x.v = face1.v_rad;
    x.distance = o.distance_mm;
    x.sigma = SigmasOf(o, &station_info[x.station], problem.defaults);
    x.source = static_cast<int>(k);
    x.point = o.point;
    if (auto it = station_index.find(o.point); it != station_index.end()) {
      x.target_station = it->second;
      if (x.target_station == x.station) {
        refuse("observation " + std::to_string(k + 1) + ": station " + o.station +
               " sights itself");
        continue;
      }
    } else {
      rays_of_point[o.point].push_back(static_cast<int>(obs.size()));
      stations_of_point[o.point].insert(x.station);
    }
    obs.push_back(x);
  }

  // Points that cannot be determined: one ray without distance and not a control point.
  std::set<std::string>& usable = network.usable;
  for (const auto& [point, rays] : rays_of_point) {
    bool distance = false;
    for (int r : rays) distance |= obs[r].distance.has_value();
    if (rays.size() >= 2 || distance || control.count(point)) usable.insert(point);
  }

  // --- Refusals: scale, rays per station, scale-bar end points.
  int fixed_control = 0;
  for (const auto& c : problem.control) fixed_control += !c.sigma_mm.has_value();
  bool has_distance = false;
  for (const auto& o : obs) has_distance |= o.distance.has_value();
  network.use_control = problem.control.size() >= 2;
  const bool use_control = network.use_control;
  if (problem.scale_bars.empty() && !has_distance && !use_control) {
    refuse(
        "no scale: give a scale bar (--scale-bar A:B=LEN_MM), distances, or control points "
        "(--control)");
  }
  // Constraints between two things must join two different ones: Ceres is never given one
  // parameter block twice (it aborts the process on that).
  for (const auto& bar : problem.scale_bars) {
    if (bar.from == bar.to) {
      refuse("scale bar " + bar.from + ":" + bar.to + ": both ends are the same point");
      continue;
    }
    for (const auto* end : {&bar.from, &bar.to}) {
      if (!usable.count(*end)) {
        refuse("scale bar " + bar.from + ":" + bar.to + ": point " + *end +
               (rays_of_point.count(*end) ? " has only one ray" : " is never observed"));
      }
    }
  }
  if (use_control) {
    // The control points fix position, orientation and scale only when they are spread:
    // all in one place they fix no azimuth and no scale; on one line, no rotation about it
    // when no station is levelled.
    Eigen::Vector3d mean = Eigen::Vector3d::Zero();
    for (const auto& c : problem.control) mean += c.position_mm;
    mean /= static_cast<double>(problem.control.size());
    Eigen::Matrix3d scatter = Eigen::Matrix3d::Zero();
    for (const auto& c : problem.control) {
      scatter += (c.position_mm - mean) * (c.position_mm - mean).transpose();
    }
    const Eigen::Vector3d spread = Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(scatter)
                                       .eigenvalues()
                                       .cwiseMax(0)
                                       .cwiseSqrt();
    bool all_unlevelled = ns > 0;
    for (const auto& id : station_ids) all_unlevelled &= problem.unlevelled.count(id) > 0;
    constexpr double kSpreadMm = 1e-3;  // a µm: below any survey, above rounding
    if (!(spread(2) > kSpreadMm)) {
      refuse(
          "the control points all lie in one place: they fix no orientation and no scale "
          "(give control points at different places)");
    } else if (all_unlevelled && !(spread(1) > kSpreadMm)) {
      refuse(
          "the control points lie on one line and no station is levelled: the network can "
          "turn about that line (give a control point off the line)");
    }
  }
  for (int i = 0; i < ns; ++i) {
    bool observed = false;
    for (const auto& o : obs) observed |= o.station == i || o.target_station == i;
    if (!observed) {
      refuse("station " + station_ids[i] + " has no observations");
      continue;
    }
  }
  for (int i = 0; i < ns; ++i) {
    const bool levelled = !problem.unlevelled.count(station_ids[i]);
    if (i == 0 && !use_control) continue;  // the datum station
    int tie = 0;
    for (const auto& o : obs) {
      if (o.station == i) {
        if (o.target_station >= 0)
          ++tie;
        else if (stations_of_point[o.point].size() >= 2 || control.count(o.point))
          ++tie;
      } else if (o.target_station == i) {
        ++tie;
      }
    }
    const int needed = levelled ? 2 : 3;
    if (tie < needed) {
      refuse("station " + station_ids[i] + " has " + std::to_string(tie) +
             " rays to points other stations or control points fix (needs at least " +
             std::to_string(needed) + ")");
    }
  }
  if (!result.refusals.empty()) return refused();

  // --- Initial values.
  std::optional<InitialValues> initial = FindInitialValues(problem, network, result.refusals);
  if (!initial) return refused();
  std::vector<StationState>& st = initial->stations;
  std::map<std::string, Eigen::Vector3d>& known = initial->points;
  // Approximate values the adjustment can start from: finite, and no station on a point it
  // sights (a direction to itself has no derivative; it would fail at the first step).
  {
    constexpr double kCoincidentMm = 1e-6;
    for (int i = 0; i < ns; ++i) {
      if (!st[i].position.allFinite() || !std::isfinite(st[i].azimuth) ||
          !st[i].angle_axis.allFinite()) {
        refuse("station " + station_ids[i] + ": no finite approximate pose from its rays");
      }
    }
    for (const auto& o : obs) {
      const Eigen::Vector3d* target = nullptr;
      if (o.target_station >= 0) {
        target = &st[o.target_station].position;
      } else if (auto it = known.find(o.point); it != known.end()) {
        target = &it->second;
      }
      if (target &&
          (!target->allFinite() || (*target - st[o.station].position).norm() <= kCoincidentMm)) {
        refuse("station " + station_ids[o.station] + " and " +
               (o.target_station >= 0 ? "station " : "point ") + o.point +
               " get the same approximate position: the observations do not place them apart "
               "(repeated or contradictory sightings?)");
        break;
      }
    }
    if (!result.refusals.empty()) return refused();
  }

  // --- The bundle. Coordinates are shifted to the first station's start so that large
  // coordinates (1e7 mm) keep their precision; shifted back at the end.
  const Eigen::Vector3d offset = st[0].position;
  std::vector<Eigen::Vector3d> station_pos(ns);
  std::vector<Eigen::Vector3d> station_rot(ns);  // azimuth in [0] or angle-axis
  for (int i = 0; i < ns; ++i) {
    station_pos[i] = st[i].position - offset;
    station_rot[i] = st[i].levelled ? Eigen::Vector3d(st[i].azimuth, 0, 0) : st[i].angle_axis;
  }
  std::vector<std::string> point_ids;
  std::map<std::string, int> point_index;
  for (const auto& id : usable) {
    if (!known.count(id)) continue;
    point_index[id] = static_cast<int>(point_ids.size());
    point_ids.push_back(id);
  }
  for (const auto& [id, rays] : rays_of_point) {
    if (!usable.count(id)) {
      result.excluded_points.push_back({id, "one ray and no distance"});
    } else if (!point_index.count(id)) {
      result.excluded_points.push_back({id, "rays nearly parallel: no approximate position"});
    }
  }
  std::vector<Eigen::Vector3d> point_pos(point_ids.size());
  for (size_t k = 0; k < point_ids.size(); ++k) point_pos[k] = known.at(point_ids[k]) - offset;

  ceres::Problem::Options problem_options;
  ceres::Problem bundle(problem_options);
  using Row = ResidualRow;
  std::vector<ceres::ResidualBlockId> blocks;
  std::vector<std::vector<Row>> block_rows;
  for (const auto& o : obs) {
    double* point = nullptr;
    if (o.target_station >= 0)
      point = station_pos[o.target_station].data();
    else if (auto it = point_index.find(o.point); it != point_index.end())
      point = point_pos[it->second].data();
    else
      continue;  // one-ray point: reported, not adjusted
    ceres::CostFunction* cost =
        st[o.station].levelled ? AngleResidual<1>::Create(o.hz, o.v, o.sigma.hz_rad, o.sigma.v_rad)
                               : AngleResidual<3>::Create(o.hz, o.v, o.sigma.hz_rad, o.sigma.v_rad);
    blocks.push_back(bundle.AddResidualBlock(cost, nullptr, station_pos[o.station].data(),
                                             station_rot[o.station].data(), point));
    const std::string label = station_ids[o.station] + "->" + o.point;
    const std::string group = o.target_station >= 0 ? "mutual pointings" : "angles";
    const double sigma_across = NearPole(o.v) ? o.sigma.v_rad : o.sigma.hz_rad;
    block_rows.push_back(
        {{ResidualReport::Kind::kHz, o.source, label, sigma_across * kArcsecPerRad, group},
         {ResidualReport::Kind::kV, o.source, label, o.sigma.v_rad * kArcsecPerRad, group}});
    if (o.distance) {
      blocks.push_back(
          bundle.AddResidualBlock(LengthResidual::Create(*o.distance, o.sigma.distance_mm), nullptr,
                                  station_pos[o.station].data(), point));
      block_rows.push_back(
          {{ResidualReport::Kind::kDistance, o.source, label, o.sigma.distance_mm, "distances"}});
    }
  }
  for (size_t b = 0; b < problem.scale_bars.size(); ++b) {
    const auto& bar = problem.scale_bars[b];
    blocks.push_back(bundle.AddResidualBlock(LengthResidual::Create(bar.length_mm, bar.sigma_mm),
                                             nullptr, point_pos[point_index.at(bar.from)].data(),
                                             point_pos[point_index.at(bar.to)].data()));
    block_rows.push_back({{ResidualReport::Kind::kScaleBar, static_cast<int>(b),
                           bar.from + ":" + bar.to, bar.sigma_mm, "scale bars"}});
  }
  std::string datum;
  for (size_t c = 0; c < problem.control.size(); ++c) {
    const auto& cp = problem.control[c];
    auto it = point_index.find(cp.id);
    if (it == point_index.end()) continue;
    double* x = point_pos[it->second].data();
    if (cp.sigma_mm) {
      blocks.push_back(bundle.AddResidualBlock(
          ControlResidual::Create(cp.position_mm - offset, *cp.sigma_mm), nullptr, x));
      std::vector<Row> rows;
      for (int i = 0; i < 3; ++i) {
        rows.push_back({ResidualReport::Kind::kControl, static_cast<int>(c), cp.id,
                        (*cp.sigma_mm)(i), "control"});
      }
      block_rows.push_back(rows);
    } else {
      bundle.SetParameterBlockConstant(x);
    }
  }
  if (use_control) {
    datum = "control points (" + std::to_string(fixed_control) + " fixed, " +
            std::to_string(problem.control.size() - fixed_control) + " weighted)";
  } else {
    // SPEC datum: the first station at the origin, levelled, circle zero = azimuth 0.
    // Fixing its position and azimuth removes exactly the 4 degrees of freedom a levelled
    // network has; the scale comes from bars and distances.
    bundle.SetParameterBlockConstant(station_pos[0].data());
    bundle.SetParameterBlockConstant(station_rot[0].data());
    datum = "station " + station_ids[0] + " at the origin, levelled, azimuth 0";
  }
  result.datum = datum;

  ceres::Solver::Options solver_options;
  solver_options.linear_solver_type = ceres::DENSE_SCHUR;
  solver_options.max_num_iterations = options.max_iterations;
  solver_options.function_tolerance = 1e-14;
  solver_options.gradient_tolerance = 1e-14;
  solver_options.parameter_tolerance = 1e-14;
  solver_options.num_threads = 1;
  solver_options.logging_type = ceres::SILENT;
  ceres::Solver::Summary summary;
  ceres::Solve(solver_options, &bundle, &summary);
  result.iterations = static_cast<int>(summary.iterations.size());
  const bool converged = summary.termination_type == ceres::CONVERGENCE;
  // A failed solve (e.g. a cost or derivative that is not finite) leaves nothing to take
  // statistics of: the status says why, and no estimate is reported.
  auto non_finite = [&](const std::string& why) -> OrientationResult& {
    result.status = {SolveCode::kNonFinite, why};
    return result;
  };
  if (summary.termination_type == ceres::FAILURE) {
    return non_finite("the adjustment failed: " + summary.message);
  }
  bool parameters_finite = true;
  for (const auto& p : station_pos) parameters_finite = parameters_finite && p.allFinite();
  for (const auto& r : station_rot) parameters_finite = parameters_finite && r.allFinite();
  for (const auto& p : point_pos) parameters_finite = parameters_finite && p.allFinite();
  if (!parameters_finite) return non_finite("an estimate is not finite after the adjustment");

  // --- Statistics from the whitened Jacobian at the solution.
  std::vector<double*> free_blocks;
  std::map<const double*, int> column_of;
  int columns = 0;
  auto add_block = [&](double* block, int size) {
    if (bundle.IsParameterBlockConstant(block)) return;
    column_of[block] = columns;
    columns += size;
    free_blocks.push_back(block);
  };
  for (int i = 0; i < ns; ++i) {
    add_block(station_pos[i].data(), 3);
    add_block(station_rot[i].data(), st[i].levelled ? 1 : 3);
  }
  for (auto& p : point_pos) {
    if (bundle.HasParameterBlock(p.data())) add_block(p.data(), 3);
  }
  ceres::Problem::EvaluateOptions eval;
  eval.parameter_blocks = free_blocks;
  eval.residual_blocks = blocks;
  eval.apply_loss_function = false;
  std::vector<double> residuals;
  ceres::CRSMatrix crs;
  if (!bundle.Evaluate(eval, nullptr, &residuals, nullptr, &crs) ||
      static_cast<int>(residuals.size()) != crs.num_rows ||
      static_cast<int>(crs.rows.size()) != crs.num_rows + 1 ||
      !std::all_of(residuals.begin(), residuals.end(), [](double r) { return std::isfinite(r); }) ||
      !std::all_of(crs.values.begin(), crs.values.end(),
                   [](double v) { return std::isfinite(v); })) {
    return non_finite("the residuals or their derivatives at the solution are not finite");
  }
  Eigen::SparseMatrix<double> j(crs.num_rows, crs.num_cols);
  {
    std::vector<Eigen::Triplet<double>> triplets;
    for (int r = 0; r < crs.num_rows; ++r) {
      for (int idx = crs.rows[r]; idx < crs.rows[r + 1]; ++idx) {
        triplets.emplace_back(r, crs.cols[idx], crs.values[idx]);
      }
    }
    j.setFromTriplets(triplets.begin(), triplets.end());
  }
  const Eigen::SparseMatrix<double> normal = Eigen::SparseMatrix<double>(j.transpose()) * j;
  Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> ldlt(normal);
  // Singularity test on the column-scaled normal matrix (units differ: mm and rad).
  {
    // Adjusted target points all on one line: the likely cause, named in the message.
    bool targets_collinear = false;
    std::vector<Eigen::Vector3d> pts;
    for (size_t k = 0; k < point_ids.size(); ++k) {
      if (!control.count(point_ids[k])) pts.push_back(point_pos[k]);
    }
    if (pts.size() >= 2) {
      Eigen::Vector3d mean = Eigen::Vector3d::Zero();
      for (const auto& p : pts) mean += p;
      mean /= pts.size();
      Eigen::Matrix3d scatter = Eigen::Matrix3d::Zero();
      for (const auto& p : pts) scatter += (p - mean) * (p - mean).transpose();
      Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(scatter);
      targets_collinear = eig.eigenvalues()(1) < 1e-6 * eig.eigenvalues()(2);
    }
    Eigen::VectorXd scale = normal.diagonal().cwiseMax(1e-300).cwiseSqrt().cwiseInverse();
    const Eigen::SparseMatrix<double> scaled = scale.asDiagonal() * normal * scale.asDiagonal();
    Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> check(scaled);
    const bool singular = check.info() != Eigen::Success || ldlt.info() != Eigen::Success ||
                          check.vectorD().minCoeff() < 1e-8;  // healthy networks: ~1e-3
    if (singular && !converged) {
      // Iterations that ran out ending on a singular network: not a datum defect but an
      // adjustment that went astray (typically a gross blunder far from the other rays).
      result.status = {SolveCode::kNotConverged,
                       "the adjustment did not converge after " +
                           std::to_string(result.iterations) +
                           " iterations and ended on a degenerate network (a gross blunder? "
                           "check the rays of the points named in the warnings, and rays read "
                           "at the zenith or nadir)"};
      return result;
    }
    if (singular) {
      refuse(targets_collinear
                 ? "all target points lie on one line: the stations can turn about it, the "
                   "network has no unique shape (add targets off the line, distances or mutual "
                   "pointings)"
                 : "the network is singular: its shape, datum or scale is not determined by "
                   "the observations");
      return refused();
    }
  }
  Eigen::MatrixXd q = ldlt.solve(Eigen::MatrixXd::Identity(columns, columns));

  result.observations = crs.num_rows;
  result.unknowns = columns;
  result.dof = result.observations - result.unknowns;
  double vtpv = 0.0;
  for (double r : residuals) vtpv += r * r;
  result.sigma0 = result.dof > 0 ? std::sqrt(vtpv / result.dof) : 0.0;

  std::vector<ResidualRow> rows;
  for (const auto& block : block_rows) rows.insert(rows.end(), block.begin(), block.end());
  ResidualStatistics statistics = ResidualStatisticsOf(j, residuals, q, rows, options.delta0);
  result.residuals = std::move(statistics.residuals);
  result.groups = std::move(statistics.groups);

  // --- Free network: S-transformation of the covariance to the inner-constraint datum.
  if (problem.free_datum && !use_control) {
    using Kind = DatumBlock::Kind;
    std::vector<DatumBlock> all;
    for (int i = 0; i < ns; ++i) {
      all.push_back({station_pos[i].data(), 3, Kind::kPosition, station_ids[i]});
      all.push_back({station_rot[i].data(), st[i].levelled ? 1 : 3,
                     st[i].levelled ? Kind::kAzimuth : Kind::kAngleAxis, station_ids[i]});
    }
    for (size_t k = 0; k < point_ids.size(); ++k)
      all.push_back({point_pos[k].data(), 3, Kind::kPosition, point_ids[k]});
    const int count = InnerConstraintCovariance(all, problem.datum_points, q, column_of);
    if (count >= 2) {
      result.datum += "; covariance by inner constraints over " +
                      (problem.datum_points.empty() ? std::string("all points and stations")
                                                    : std::to_string(count) + " datum points");
    }
  }

  // --- Results back in the input frame.
  for (int i = 0; i < ns; ++i) {
    Station s = station_info[i];
    s.pose.levelled = st[i].levelled;
    s.pose.position_mm = station_pos[i] + offset;
    if (st[i].levelled) {
      s.pose.azimuth_rad = WrapTwoPi(station_rot[i](0));
      s.pose.world_from_station = LevelledRotation(s.pose.azimuth_rad);
    } else {
      double r[9];
      ceres::AngleAxisToRotationMatrix(station_rot[i].data(), ceres::ColumnMajorAdapter3x3(r));
      s.pose.world_from_station = Eigen::Map<Eigen::Matrix3d>(r);
    }
    if (auto it = column_of.find(station_pos[i].data()); it != column_of.end()) {
      for (int k = 0; k < 3; ++k)
        s.sigma_position_mm(k) = std::sqrt(q(it->second + k, it->second + k));
    }
    if (auto it = column_of.find(station_rot[i].data()); it != column_of.end()) {
      if (st[i].levelled)
        s.sigma_azimuth_rad = std::sqrt(q(it->second, it->second));
      else
        for (int k = 0; k < 3; ++k)
          s.sigma_rotation_rad(k) = std::sqrt(q(it->second + k, it->second + k));
    }
    result.stations.push_back(s);
  }
  for (size_t k = 0; k < point_ids.size(); ++k) {
    PointEstimate p;
    p.id = point_ids[k];
    p.position_mm = point_pos[k] + offset;
    p.rays = static_cast<int>(rays_of_point[p.id].size());
    p.control = control.count(p.id) > 0;
    if (auto it = column_of.find(point_pos[k].data()); it != column_of.end()) {
      p.covariance_mm2 = q.block<3, 3>(it->second, it->second);
    }
    result.points.push_back(p);
  }
  // A solve with any non-finite estimate never reports ok.
  bool finite = std::isfinite(result.sigma0);
  for (const auto& s : result.stations) {
    finite = finite && s.pose.position_mm.allFinite() && s.pose.world_from_station.allFinite() &&
             s.sigma_position_mm.allFinite() && std::isfinite(s.sigma_azimuth_rad) &&
             s.sigma_rotation_rad.allFinite();
  }
  for (const auto& p : result.points)
    finite = finite && p.position_mm.allFinite() && p.covariance_mm2.allFinite();
  if (!finite) {
    result.status = {SolveCode::kNonFinite, "an estimate or its precision is not finite"};
  } else if (!converged) {
    result.status = {SolveCode::kNotConverged,
                     "not converged after " + std::to_string(result.iterations) + " iterations"};
  }
  return result;
}

}  // namespace armsig::reduction
