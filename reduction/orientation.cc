#include "reduction/orientation.h"

#include <ceres/rotation.h>

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "core/units.h"
#include "reduction/adjustment_statistics.h"
#include "reduction/observation.h"
#include "reduction/orientation_bundle.h"
#include "reduction/orientation_initial.h"
#include "reduction/orientation_network.h"
#include "reduction/orientation_snooping.h"

namespace armsig::reduction {

void OrientationOptions::Check() const {
  if (max_iterations < 1) throw std::invalid_argument("max_iterations must be ≥ 1");
  snooping.Check();
  if (!(max_removed_fraction >= 0 && max_removed_fraction <= 1))
    throw std::invalid_argument("max_removed_fraction must lie in [0, 1]");
}

const char* KindName(ResidualReport::Kind kind) {
  static const char* kNames[] = {"Hz", "V", "distance", "scale bar", "control"};
  return kNames[static_cast<int>(kind)];
}

namespace {

using Kind = ResidualReport::Kind;

// The network cannot be solved: status kDegenerate naming every refusal.
OrientationResult& Refused(OrientationResult& result) {
  std::string why;
  for (const auto& r : result.refusals) why += (why.empty() ? "" : "; ") + r;
  result.status = {SolveCode::kDegenerate, why};
  return result;
}

// Approximate values the adjustment can start from: finite, and no station on a point it
// sights (a direction to itself has no derivative; it would fail at the first step).
void RefuseUnusableStart(const IndexedNetwork& network, const InitialValues& initial,
                         std::vector<std::string>& refusals) {
  constexpr double kCoincidentMm = 1e-6;
  const std::vector<StationState>& st = initial.stations;
  for (size_t i = 0; i < st.size(); ++i) {
    if (!st[i].position.allFinite() || !std::isfinite(st[i].azimuth) ||
        !st[i].angle_axis.allFinite()) {
      refusals.push_back("station " + network.station_ids[i] +
                         ": no finite approximate pose from its rays");
    }
  }
  for (const auto& o : network.obs) {
    const Eigen::Vector3d* target = nullptr;
    if (o.target_station >= 0) {
      target = &st[o.target_station].position;
    } else if (auto it = initial.points.find(o.point); it != initial.points.end()) {
      target = &it->second;
    }
    if (target &&
        (!target->allFinite() || (*target - st[o.station].position).norm() <= kCoincidentMm)) {
      refusals.push_back("station " + network.station_ids[o.station] + " and " +
                         (o.target_station >= 0 ? "station " : "point ") + o.point +
                         " get the same approximate position: the observations do not place "
                         "them apart (repeated or contradictory sightings?)");
      return;
    }
  }
}

// Free network: the covariance S-transformed to the inner-constraint datum.
void ToFreeDatum(const OrientationProblem& problem, const IndexedNetwork& network,
                 const BundleUnknowns& u, Linearisation& lin, OrientationResult& result) {
  using DatumKind = DatumBlock::Kind;
  std::vector<DatumBlock> all;
  for (size_t i = 0; i < u.station_pos.size(); ++i) {
    const std::string& id = network.station_ids[i];
    all.push_back({u.station_pos[i].data(), 3, DatumKind::kPosition, id});
    all.push_back({u.station_rot[i].data(), u.levelled[i] ? 1 : 3,
                   u.levelled[i] ? DatumKind::kAzimuth : DatumKind::kAngleAxis, id});
  }
  for (size_t k = 0; k < u.point_ids.size(); ++k)
    all.push_back({u.point_pos[k].data(), 3, DatumKind::kPosition, u.point_ids[k]});
  const int count = InnerConstraintCovariance(all, problem.datum_points, lin.q, lin.column_of);
  if (count >= 2) {
    result.datum += "; covariance by inner constraints over " +
                    (problem.datum_points.empty() ? std::string("all points and stations")
                                                  : std::to_string(count) + " datum points");
  }
}

// Stations and points back in the input frame, with their precisions; the status says
// whether every estimate is finite and the last adjustment converged.
void Results(const IndexedNetwork& network, const BundleUnknowns& u, const Adjustment& a,
             OrientationResult& result) {
  const Eigen::MatrixXd& q = a.lin.q;
  for (size_t i = 0; i < u.station_pos.size(); ++i) {
    Station s = network.station_info[i];
    s.pose.levelled = u.levelled[i];
    s.pose.position_mm = u.station_pos[i] + u.offset;
    if (u.levelled[i]) {
      s.pose.azimuth_rad = WrapTwoPi(u.station_rot[i](0));
      s.pose.world_from_station = LevelledRotation(s.pose.azimuth_rad);
    } else {
      double r[9];
      ceres::AngleAxisToRotationMatrix(u.station_rot[i].data(), ceres::ColumnMajorAdapter3x3(r));
      s.pose.world_from_station = Eigen::Map<Eigen::Matrix3d>(r);
    }
    if (auto it = a.lin.column_of.find(u.station_pos[i].data()); it != a.lin.column_of.end()) {
      for (int k = 0; k < 3; ++k) s.sigma_position_mm(k) = std::sqrt(q(it->second + k, it->second + k));
    }
    if (auto it = a.lin.column_of.find(u.station_rot[i].data()); it != a.lin.column_of.end()) {
      if (u.levelled[i])
        s.sigma_azimuth_rad = std::sqrt(q(it->second, it->second));
      else
        for (int k = 0; k < 3; ++k)
          s.sigma_rotation_rad(k) = std::sqrt(q(it->second + k, it->second + k));
    }
    result.stations.push_back(s);
  }
  for (size_t k = 0; k < u.point_ids.size(); ++k) {
    PointEstimate p;
    p.id = u.point_ids[k];
    p.position_mm = u.point_pos[k] + u.offset;
    p.rays = static_cast<int>(network.rays_of_point.at(p.id).size());
    p.control = network.control.count(p.id) > 0;
    if (auto it = a.lin.column_of.find(u.point_pos[k].data()); it != a.lin.column_of.end())
      p.covariance_mm2 = q.block<3, 3>(it->second, it->second);
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
  } else if (!a.solve.converged) {
    result.status = {SolveCode::kNotConverged,
                     "not converged after " + std::to_string(result.iterations) + " iterations"};
  }
}

}  // namespace

// The procedure: index the problem and refuse what cannot be solved, initial values
// (orientation_initial.cc), the adjustment (orientation_bundle.cc) repeated by data
// snooping, the statistics (adjustment_statistics.cc), the free-network covariance when
// asked, and the results in the input frame.
OrientationResult Orient(const OrientationProblem& problem, const OrientationOptions& options) {
  options.Check();
  OrientationResult result;
  const IndexedNetwork network = IndexNetwork(problem, result.refusals);
  RefuseUnsolvable(problem, network, result.refusals);
  if (!result.refusals.empty()) return Refused(result);

  const std::optional<InitialValues> initial =
      FindInitialValues(problem, network, result.refusals);
  if (!initial) return Refused(result);
  RefuseUnusableStart(network, *initial, result.refusals);
  if (!result.refusals.empty()) return Refused(result);
  BundleUnknowns unknowns = UnknownsFrom(network, *initial, result.excluded_points);

  std::optional<Adjustment> adjusted =
      AdjustWithSnooping(problem, network, options, unknowns, result);
  if (!adjusted) return result;
  Adjustment& a = *adjusted;
  result.observations = static_cast<int>(a.bundle.rows.size());
  result.unknowns = static_cast<int>(a.lin.q.rows());
  result.dof = a.dof();
  double vtpv = 0.0;
  for (double r : a.lin.residuals) vtpv += r * r;
  result.sigma0 = result.dof > 0 ? std::sqrt(vtpv / result.dof) : 0.0;
  result.residuals = a.statistics.residuals;
  result.groups = a.statistics.groups;
  for (auto& r : result.removed) {
    r.error = ObservedMinusPredicted(problem, network, unknowns, {r.kind, r.observation});
  }
  if (problem.free_datum && !network.use_control) ToFreeDatum(problem, network, unknowns, a.lin, result);
  Results(network, unknowns, a, result);
  return result;
}

}  // namespace armsig::reduction
