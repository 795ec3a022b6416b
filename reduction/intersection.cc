#include "reduction/intersection.h"

#include <Eigen/Cholesky>
#include <Eigen/LU>
#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "core/units.h"
#include "reduction/observation.h"

namespace armsig::reduction {

void IntersectionOptions::Check() const {
  snooping.Check();
  if (!(min_ray_angle_rad >= 0)) throw std::invalid_argument("min_ray_angle_rad must be ≥ 0");
  if (max_iterations < 1) throw std::invalid_argument("max_iterations must be ≥ 1");
}

Ray RayOf(const Observation& observation, const Station& station,
          const InstrumentDefaults& defaults) {
  const EffectiveSigmas sigma = SigmasOf(observation, &station, defaults);
  Ray ray;
  ray.station_mm = station.pose.position_mm;
  ray.world_from_station = station.pose.world_from_station;
  ray.reading = observation.reading;
  ray.distance_mm = observation.distance_mm;
  ray.sigma_hz_rad = sigma.hz_rad;
  ray.sigma_v_rad = sigma.v_rad;
  ray.sigma_distance_mm = sigma.distance_mm;
  return ray;
}

AngleReading PredictReading(const Eigen::Vector3d& station_mm,
                            const Eigen::Matrix3d& world_from_station,
                            const Eigen::Vector3d& target_mm) {
  return ReadingOf(world_from_station.transpose() * (target_mm - station_mm));
}

namespace {

constexpr double kArcsecPerRad = 1.0 / kRadPerArcsec;

// Linearised observation rows of one ray at X (whitened: divided by the sigmas).
struct RayRows {
  Eigen::Matrix<double, 3, 3> a;  // rows: hz, v, distance
  Eigen::Vector3d r;              // residuals computed − observed, whitened
  int count;                      // 2 or 3
};

inline void Linearise(const Ray& ray, double hz_obs, double v_obs, const Eigen::Vector3d& x,
                      RayRows& rows) {
  const Eigen::Vector3d d = ray.world_from_station.transpose() * (x - ray.station_mm);
  const double rho2 = d.x() * d.x() + d.y() * d.y();
  const double rho = std::sqrt(rho2);
  const double r2 = rho2 + d.z() * d.z();
  const Eigen::Matrix3d rt = ray.world_from_station.transpose();
  rows.a.row(2).setZero();
  rows.r(2) = 0.0;
  rows.count = 2;
  if (ray.distance_mm) {
    const double dist = std::sqrt(r2);
    rows.a.row(2) = (d.transpose() / dist) * rt / ray.sigma_distance_mm;
    rows.r(2) = (dist - *ray.distance_mm) / ray.sigma_distance_mm;
    rows.count = 3;
  }
  const bool pole_reading = NearPole(v_obs);
  if (pole_reading || PredictedNearPole<double>(d)) {
    // At the zenith or nadir: PoleResidual, e·d̂ with ∂(e·d̂)/∂d = (e − (e·d̂) d̂)ᵀ / |d|,
    // both components weighted with sigma_v (SigmaAcross). A reading away from the poles
    // whose prediction passes the standing axis (HzVResidual): the first component divided
    // by sin V_obs is ΔHz, weighted with sigma_hz.
    const double dist = std::sqrt(r2);
    const Eigen::Vector3d unit = d / dist;
    const Eigen::Vector2d residual = PoleResidual<double>(d, hz_obs, v_obs);
    const Eigen::Vector3d e_hz(std::cos(hz_obs), -std::sin(hz_obs), 0.0);
    const Eigen::Vector3d e_v(std::cos(v_obs) * std::sin(hz_obs),
                              std::cos(v_obs) * std::cos(hz_obs), -std::sin(v_obs));
    const double across = pole_reading ? ray.sigma_v_rad : std::sin(v_obs) * ray.sigma_hz_rad;
    rows.a.row(0) = ((e_hz - residual(0) * unit).transpose() / dist) * rt / across;
    rows.a.row(1) = ((e_v - residual(1) * unit).transpose() / dist) * rt / ray.sigma_v_rad;
    rows.r(0) = residual(0) / across;
    rows.r(1) = residual(1) / ray.sigma_v_rad;
    return;
  }
  const Eigen::Vector2d residual = HzVResidual<double>(d, hz_obs, v_obs);
  // Analytic derivatives of HzVOf (the inner loop; checked against autodiff in the tests):
  // ∂hz/∂d and ∂v/∂d in the station frame, then to the world: ∂/∂X = ∂/∂d · Rᵀ.
  const Eigen::RowVector3d dhz(d.y() / rho2, -d.x() / rho2, 0.0);
  const Eigen::RowVector3d dv(d.x() * d.z() / (r2 * rho), d.y() * d.z() / (r2 * rho), -rho / r2);
  rows.a.row(0) = dhz * rt / ray.sigma_hz_rad;
  rows.a.row(1) = dv * rt / ray.sigma_v_rad;
  rows.r(0) = residual(0) / ray.sigma_hz_rad;
  rows.r(1) = residual(1) / ray.sigma_v_rad;
}

}  // namespace

namespace {

// One point's rays as the intersection works on them: fixed-size, so that a loop over many
// points does not allocate.
struct RayWork {
  int n = 0;
  double hz[64], v[64];   // face I
  Eigen::Vector3d u[64];  // world directions
  bool active[64];        // not rejected
  RayRows rows[64];
  bool has_distance = false;
  // The tested rows of the active rays (data snooping's candidates; a ray is one group).
  double tested_w[3 * 64], tested_r[3 * 64];
  int tested_ray[3 * 64], tested_row[3 * 64];
  int tested = 0;
};

// Face-I readings and world directions; the reason the rays cannot be intersected, if any.
std::optional<SolveStatus> Prepare(std::span<const Ray> rays, const IntersectionOptions& options,
                                   RayWork& work) {
  const int n = work.n = static_cast<int>(rays.size());
  if (n > 64) throw std::invalid_argument("more than 64 rays for one point");
  work.has_distance = false;
  for (int k = 0; k < n; ++k) {
    const AngleReading face1 = ToFaceOne(rays[k].reading);
    work.hz[k] = face1.hz_rad;
    work.v[k] = face1.v_rad;
    work.u[k] = rays[k].world_from_station * DirectionInStation(face1);
    work.has_distance |= rays[k].distance_mm.has_value();
    work.active[k] = true;
  }
  for (int k = 0; k < n; ++k) {
    const Ray& ray = rays[k];
    const bool finite = ray.station_mm.allFinite() && ray.world_from_station.allFinite() &&
                        std::isfinite(work.hz[k]) && std::isfinite(work.v[k]) &&
                        std::isfinite(ray.sigma_hz_rad) && std::isfinite(ray.sigma_v_rad) &&
                        (!ray.distance_mm ||
                         (std::isfinite(*ray.distance_mm) && std::isfinite(ray.sigma_distance_mm)));
    if (!finite) return SolveStatus{SolveCode::kNonFinite, "ray " + std::to_string(k + 1) + " is not finite"};
  }
  if (n == 0 || (n == 1 && !work.has_distance)) {
    return SolveStatus{SolveCode::kTooFewObservations, n == 0 ? "no ray" : "one ray and no distance"};
  }
  if (!work.has_distance) {
    double largest = 0.0;
    for (int a = 0; a < n; ++a) {
      for (int b = a + 1; b < n; ++b) largest = std::max(largest, work.u[a].cross(work.u[b]).norm());
    }
    if (std::asin(std::min(1.0, largest)) < options.min_ray_angle_rad) {
      return SolveStatus{SolveCode::kDegenerate,
                         "rays nearly parallel (largest angle " +
                             std::to_string(std::asin(std::min(1.0, largest)) / kRadPerDeg) +
                             " deg)"};
    }
  }
  return std::nullopt;
}

// Closed-form start: polar points where distances exist, else the closest point of all rays:
// Σ (I − uuᵀ) X = Σ (I − uuᵀ) S.
Eigen::Vector3d ClosedFormStart(std::span<const Ray> rays, const RayWork& work) {
  Eigen::Vector3d x = Eigen::Vector3d::Zero();
  if (work.has_distance) {
    int count = 0;
    for (int k = 0; k < work.n; ++k) {
      if (rays[k].distance_mm) {
        x += rays[k].station_mm + *rays[k].distance_mm * work.u[k];
        ++count;
      }
    }
    return x / count;
  }
  Eigen::Matrix3d m = Eigen::Matrix3d::Zero();
  Eigen::Vector3d b = Eigen::Vector3d::Zero();
  for (int k = 0; k < work.n; ++k) {
    const Eigen::Matrix3d p = Eigen::Matrix3d::Identity() - work.u[k] * work.u[k].transpose();
    m += p;
    b += p * rays[k].station_mm;
  }
  return m.ldlt().solve(b);
}

// Gauss–Newton on the active rays from x. The last iteration's rows also serve the
// statistics: its step is below a nanometre, so its Jacobian is the solution's and the
// residuals follow linearly (r + A·δ, exact to second order). Returns the iterations.
int GaussNewton(std::span<const Ray> rays, const IntersectionOptions& options, RayWork& work,
                Eigen::Vector3d& x, Eigen::Matrix3d& q, Eigen::Vector3d& step, bool& converged) {
  converged = false;
  int it = 0;
  step.setZero();
  for (; it < options.max_iterations && !converged; ++it) {
    Eigen::Matrix3d normal = Eigen::Matrix3d::Zero();
    Eigen::Vector3d g = Eigen::Vector3d::Zero();
    for (int k = 0; k < work.n; ++k) {
      if (!work.active[k]) continue;
      Linearise(rays[k], work.hz[k], work.v[k], x, work.rows[k]);
      normal.noalias() += work.rows[k].a.transpose() * work.rows[k].a;
      g.noalias() += work.rows[k].a.transpose() * work.rows[k].r;
    }
    q = normal.inverse();
    step = -q * g;
    x += step;
    converged = step.squaredNorm() < 1e-12;  // 1 nm
  }
  return it;
}

// Residuals, miss distances, standardised residuals and minimal detectable biases of every
// ray at the solution x; σ0 and degrees of freedom of the active ones, whose tests are kept
// in `work` for data snooping. Returns the largest |w|.
double TestRays(std::span<const Ray> rays, RayWork& work, const Eigen::Vector3d& x,
                const Eigen::Matrix3d& q, const Eigen::Vector3d& step, const SnoopLevels& levels,
                IntersectionResult& result) {
  int observations = 0;
  double vtpv = 0.0, worst_w = 0.0;
  work.tested = 0;
  result.max_miss_mm = 0.0;
  for (int k = 0; k < work.n; ++k) {
    RayRows& row = work.rows[k];
    if (work.active[k]) {
      row.r.noalias() += row.a * step;
    } else {
      Linearise(rays[k], work.hz[k], work.v[k], x, row);
    }
    RayResult& rr = result.rays[k];
    // The first row's sigma: sigma_hz, or sigma_v across the line of sight at a pole.
    const double sigma_across = NearPole(work.v[k]) ? rays[k].sigma_v_rad : rays[k].sigma_hz_rad;
    rr.hz_arcsec = row.r(0) * sigma_across * kArcsecPerRad;
    rr.v_arcsec = row.r(1) * rays[k].sigma_v_rad * kArcsecPerRad;
    rr.distance_mm = row.count == 3 ? std::optional<double>(row.r(2) * rays[k].sigma_distance_mm)
                                    : std::nullopt;
    const Eigen::Vector3d to_point = x - rays[k].station_mm;
    rr.miss_mm = (to_point - to_point.dot(work.u[k]) * work.u[k]).norm();
    if (!work.active[k]) continue;
    observations += row.count;
    result.max_miss_mm = std::max(result.max_miss_mm, rr.miss_mm);
    double w[3] = {0, 0, 0};
    for (int i = 0; i < row.count; ++i) {
      vtpv += row.r(i) * row.r(i);
      // Redundancy number r_i = 1 − a_i Q a_iᵀ (whitened).
      const double redundancy = 1.0 - row.a.row(i) * q * row.a.row(i).transpose();
      const double inv_sqrt = 1.0 / std::sqrt(std::max(redundancy, 1e-12));
      w[i] = redundancy > 1e-6 ? row.r(i) * inv_sqrt : 0.0;
      if (i == 0) rr.mdb_hz_arcsec = sigma_across * levels.delta0 * inv_sqrt * kArcsecPerRad;
      if (i == 1) rr.mdb_v_arcsec = rays[k].sigma_v_rad * levels.delta0 * inv_sqrt * kArcsecPerRad;
      work.tested_w[work.tested] = w[i];
      work.tested_r[work.tested] = std::max(0.0, redundancy);
      work.tested_ray[work.tested] = k;
      work.tested_row[work.tested] = i;
      ++work.tested;
      worst_w = std::max(worst_w, std::abs(w[i]));
    }
    rr.w_hz = w[0];
    rr.w_v = w[1];
    rr.w_distance = w[2];
  }
  result.dof = observations - 3;
  result.sigma0 = result.dof > 0 ? std::sqrt(vtpv / result.dof) : 0.0;
  return worst_w;
}

// The data-snooping decision on the tested rows (reduction/data_snooping.h): rays to reject.
SnoopDecision DecideOnRays(const RayWork& work, const Eigen::Matrix3d& q, int dof,
                           const IntersectionOptions& options, const SnoopLevels& levels) {
  SnoopCandidate candidates[3 * 64];
  for (int c = 0; c < work.tested; ++c) {
    candidates[c] = {work.tested_w[c], work.tested_r[c], work.tested_ray[c],
                     work.rows[work.tested_ray[c]].count, false};
  }
  // ρ_ij = Qvv_ij / √(r_i r_j), Qvv_ij = −a_i Q a_jᵀ (whitened rows).
  auto correlation = [&](int i, int j) {
    const auto a_i = work.rows[work.tested_ray[i]].a.row(work.tested_row[i]);
    const auto a_j = work.rows[work.tested_ray[j]].a.row(work.tested_row[j]);
    const double scale = std::sqrt(work.tested_r[i] * work.tested_r[j]);
    return scale > 0 ? -(a_i * q * a_j.transpose())(0, 0) / scale : 0.0;
  };
  return DecideRejection(std::span<const SnoopCandidate>(candidates, work.tested), dof,
                         options.snooping, levels, correlation);
}

}  // namespace

// Prepare, start, then rounds of Gauss–Newton and data snooping: a round rejects the rays the
// policy can decide, until no test fails or what fails cannot be decided.
void Intersect(std::span<const Ray> rays, const IntersectionOptions& options,
               IntersectionResult& result) {
  const int n = static_cast<int>(rays.size());
  result.status = SolveStatus{};
  result.flags = PointFlags{};
  result.rays.assign(n, RayResult{});
  result.rejected = 0;
  result.iterations = 0;
  result.sigma0 = 0.0;
  result.dof = 0;
  result.max_miss_mm = 0.0;
  auto fail = [&](SolveStatus status) {
    result.status = std::move(status);
    result.flags = FlagsOf(result.status);
    result.position_mm.setConstant(std::numeric_limits<double>::quiet_NaN());
    result.covariance_mm2.setConstant(std::numeric_limits<double>::quiet_NaN());
    result.rays_used = 0;
  };
  RayWork work;  // 14 kB on the stack, nothing allocated
  if (auto refused = Prepare(rays, options, work)) return fail(*refused);
  Eigen::Vector3d x = ClosedFormStart(rays, work);
  for (int round = 0; round <= n; ++round) {
    Eigen::Matrix3d q;
    Eigen::Vector3d step;
    bool converged = false;
    result.iterations += GaussNewton(rays, options, work, x, q, step, converged);
    if (!x.allFinite() || !q.allFinite())
      return fail({SolveCode::kNonFinite, "the estimate is not finite"});
    if (!converged) return fail({SolveCode::kNotConverged, "no convergence"});
    result.covariance_mm2 = q;
    int tests = 0, used = 0;
    for (int k = 0; k < n; ++k) {
      tests += work.active[k] ? work.rows[k].count : 0;
      used += work.active[k];
    }
    const SnoopLevels levels = options.snooping.Levels(tests);
    const double worst_w = TestRays(rays, work, x, q, step, levels, result);
    result.position_mm = x;
    result.rays_used = used;
    if (!(worst_w > levels.critical_w)) break;  // the usual case: no blunder
    const SnoopDecision decision = DecideOnRays(work, q, result.dof, options, levels);
    if (decision.remove.empty()) {
      if (!decision.undecided.empty()) result.flags.Set(PointFlag::kBlunderSuspected);
      break;
    }
    for (int c : decision.remove) {
      const int ray = work.tested_ray[c];
      if (!work.active[ray]) continue;
      work.active[ray] = false;
      result.rays[ray].rejected = true;
      ++result.rejected;
    }
    result.flags.Set(PointFlag::kBlunderRejected);
  }
}

IntersectionResult Intersect(std::span<const Ray> rays, const IntersectionOptions& options) {
  IntersectionResult result;
  Intersect(rays, options, result);
  return result;
}

void IntersectPoint(const RayGroup& group, const PointOptions& options, ReducedPoint& out) {
  out.repeat_mm.reset();
  if (group.repeats.size() >= 2) {
    // Repeatability: the largest distance between the points of the repeated rounds
    // (rounds that cannot be intersected do not count).
    std::vector<Eigen::Vector3d> points;
    for (const auto& round : group.repeats) {
      Intersect(round, options.intersection, out.result);
      if (out.result.status.ok()) points.push_back(out.result.position_mm);
    }
    double spread = 0.0;
    for (size_t a = 0; a < points.size(); ++a)
      for (size_t b = a + 1; b < points.size(); ++b)
        spread = std::max(spread, (points[a] - points[b]).norm());
    out.repeat_mm = spread;
  }
  Intersect(group.rays, options.intersection, out.result);
  IntersectionResult& r = out.result;
  if (!r.status.ok()) return;
  const PointChecks& checks = options.checks;
  if (checks.max_miss_mm && r.max_miss_mm > *checks.max_miss_mm)
    r.flags.Set(PointFlag::kMissExceeded);
  if (checks.max_repeat_mm && out.repeat_mm && *out.repeat_mm > *checks.max_repeat_mm)
    r.flags.Set(PointFlag::kRepeatExceeded);
}

ReducedPoint IntersectPoint(const RayGroup& group, const PointOptions& options) {
  ReducedPoint out;
  IntersectPoint(group, options, out);
  return out;
}

std::vector<ReducedPoint> IntersectPoints(std::span<const RayGroup> groups,
                                          const PointOptions& options) {
  std::vector<ReducedPoint> out(groups.size());
  for (size_t k = 0; k < groups.size(); ++k) IntersectPoint(groups[k], options, out[k]);
  return out;
}

PointFlags CarriedOverFlags(PointFlags stored, const PointChecks& checks) {
  PointFlags kept;
  kept.Set(PointFlag::kRepeatExceeded, stored.Has(PointFlag::kRepeatExceeded));
  kept.Set(PointFlag::kSigmaExceeded, stored.Has(PointFlag::kSigmaExceeded));
  if (!checks.max_miss_mm) kept.Set(PointFlag::kMissExceeded, stored.Has(PointFlag::kMissExceeded));
  return kept;
}

}  // namespace armsig::reduction
