#include "reduction/intersection.h"

#include <Eigen/Cholesky>
#include <Eigen/LU>
#include <cmath>
#include <stdexcept>

#include "core/units.h"
#include "reduction/observation.h"

namespace armsig::reduction {

void IntersectionOptions::Check() const {
  if (!(critical_w > 0)) throw std::invalid_argument("critical_w must be > 0");
  if (!(min_ray_angle_rad >= 0)) throw std::invalid_argument("min_ray_angle_rad must be ≥ 0");
  if (max_iterations < 1) throw std::invalid_argument("max_iterations must be ≥ 1");
}

const char* ToString(IntersectionStatus status) {
  switch (status) {
    case IntersectionStatus::kOk:
      return "ok";
    case IntersectionStatus::kOneRay:
      return "one_ray";
    case IntersectionStatus::kParallelRays:
      return "parallel_rays";
    case IntersectionStatus::kNoConvergence:
      return "no_convergence";
  }
  return "?";
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
  const double hz = std::atan2(d.x(), d.y());
  const double v = std::atan2(rho, d.z());
  // ∂hz/∂d and ∂v/∂d in the station frame, then to the world: ∂/∂X = ∂/∂d · Rᵀ.
  const Eigen::RowVector3d dhz(d.y() / rho2, -d.x() / rho2, 0.0);
  const Eigen::RowVector3d dv(d.x() * d.z() / (r2 * rho), d.y() * d.z() / (r2 * rho), -rho / r2);
  const Eigen::Matrix3d rt = ray.world_from_station.transpose();
  rows.a.row(0) = dhz * rt / ray.sigma_hz_rad;
  rows.a.row(1) = dv * rt / ray.sigma_v_rad;
  rows.r(0) = WrapPi(hz - hz_obs) / ray.sigma_hz_rad;
  rows.r(1) = (v - v_obs) / ray.sigma_v_rad;
  rows.count = 2;
  rows.a.row(2).setZero();
  rows.r(2) = 0.0;
  if (std::isfinite(ray.distance_mm)) {
    const double dist = std::sqrt(r2);
    rows.a.row(2) = (d.transpose() / dist) * rt / ray.sigma_distance_mm;
    rows.r(2) = (dist - ray.distance_mm) / ray.sigma_distance_mm;
    rows.count = 3;
  }
}

}  // namespace

void Intersect(std::span<const Ray> rays, const IntersectionOptions& options,
               IntersectionResult& result) {
  const int n = static_cast<int>(rays.size());
  result.status = IntersectionStatus::kOk;
  result.reason.clear();
  result.rays.assign(n, RayResult{});
  result.rejected = 0;
  result.blunder_suspected = false;
  result.iterations = 0;
  result.sigma0 = 0.0;
  result.dof = 0;
  result.max_miss_mm = 0.0;

  // Face-I readings and world directions.
  Eigen::Vector3d origin_sum = Eigen::Vector3d::Zero();
  double hz[64], v[64];
  Eigen::Vector3d u[64];
  if (n > 64) throw std::invalid_argument("more than 64 rays for one point");
  bool has_distance = false;
  for (int k = 0; k < n; ++k) {
    const AngleReading face1 = ToFaceOne(rays[k].reading);
    hz[k] = face1.hz_rad;
    v[k] = face1.v_rad;
    u[k] = rays[k].world_from_station * DirectionInStation(face1);
    has_distance |= std::isfinite(rays[k].distance_mm);
    origin_sum += rays[k].station_mm;
  }
  auto fail = [&](IntersectionStatus status, std::string reason) {
    result.status = status;
    result.reason = std::move(reason);
    result.position_mm.setConstant(std::numeric_limits<double>::quiet_NaN());
    result.covariance_mm2.setConstant(std::numeric_limits<double>::quiet_NaN());
    result.rays_used = 0;
  };
  if (n == 0 || (n == 1 && !has_distance)) {
    fail(IntersectionStatus::kOneRay, n == 0 ? "no ray" : "one ray and no distance");
    return;
  }
  if (!has_distance) {
    double largest = 0.0;
    for (int a = 0; a < n; ++a) {
      for (int b = a + 1; b < n; ++b) largest = std::max(largest, u[a].cross(u[b]).norm());
    }
    if (std::asin(std::min(1.0, largest)) < options.min_ray_angle_rad) {
      fail(IntersectionStatus::kParallelRays,
           "rays nearly parallel (largest angle " +
               std::to_string(std::asin(std::min(1.0, largest)) / kRadPerDeg) + " deg)");
      return;
    }
  }

  std::vector<RayResult>& out = result.rays;
  bool active[64];
  for (int k = 0; k < n; ++k) active[k] = true;

  // Closed-form start: polar points where distances exist, else the closest point of
  // all rays: Σ (I − uuᵀ) X = Σ (I − uuᵀ) S.
  Eigen::Vector3d x = Eigen::Vector3d::Zero();
  if (has_distance) {
    int count = 0;
    for (int k = 0; k < n; ++k) {
      if (std::isfinite(rays[k].distance_mm)) {
        x += rays[k].station_mm + rays[k].distance_mm * u[k];
        ++count;
      }
    }
    x /= count;
  } else {
    Eigen::Matrix3d m = Eigen::Matrix3d::Zero();
    Eigen::Vector3d b = Eigen::Vector3d::Zero();
    for (int k = 0; k < n; ++k) {
      const Eigen::Matrix3d p = Eigen::Matrix3d::Identity() - u[k] * u[k].transpose();
      m += p;
      b += p * rays[k].station_mm;
    }
    x = m.ldlt().solve(b);
  }

  RayRows rows[64];
  Eigen::Matrix3d normal;
  for (int round = 0; round <= n; ++round) {
    // Gauss–Newton on the active rays. The last iteration's rows also serve the
    // statistics: its step is below a nanometre, so its Jacobian is the solution's and
    // the residuals follow linearly (r + A·δ, exact to second order).
    bool converged = false;
    int it = 0;
    Eigen::Vector3d step = Eigen::Vector3d::Zero();
    Eigen::Matrix3d q;
    for (; it < options.max_iterations && !converged; ++it) {
      normal.setZero();
      Eigen::Vector3d g = Eigen::Vector3d::Zero();
      for (int k = 0; k < n; ++k) {
        if (!active[k]) continue;
        Linearise(rays[k], hz[k], v[k], x, rows[k]);
        normal.noalias() += rows[k].a.transpose() * rows[k].a;
        g.noalias() += rows[k].a.transpose() * rows[k].r;
      }
      q = normal.inverse();
      step = -q * g;
      x += step;
      converged = step.squaredNorm() < 1e-12;  // 1 nm
    }
    result.iterations += it;
    if (!converged || !x.allFinite()) {
      fail(IntersectionStatus::kNoConvergence, "no convergence");
      return;
    }

    result.covariance_mm2 = q;
    int observations = 0;
    double vtpv = 0.0;
    int worst = -1;
    double worst_w = 0.0;
    result.max_miss_mm = 0.0;
    for (int k = 0; k < n; ++k) {
      RayRows& row = rows[k];
      if (active[k]) {
        row.r.noalias() += row.a * step;
      } else {
        Linearise(rays[k], hz[k], v[k], x, row);
      }
      RayResult& rr = out[k];
      rr.hz_arcsec = row.r(0) * rays[k].sigma_hz_rad * kArcsecPerRad;
      rr.v_arcsec = row.r(1) * rays[k].sigma_v_rad * kArcsecPerRad;
      rr.distance_mm = row.count == 3 ? row.r(2) * rays[k].sigma_distance_mm
                                      : std::numeric_limits<double>::quiet_NaN();
      const Eigen::Vector3d to_point = x - rays[k].station_mm;
      rr.miss_mm = (to_point - to_point.dot(u[k]) * u[k]).norm();
      if (!active[k]) continue;
      observations += row.count;
      result.max_miss_mm = std::max(result.max_miss_mm, rr.miss_mm);
      double w[3] = {0, 0, 0};
      for (int i = 0; i < row.count; ++i) {
        vtpv += row.r(i) * row.r(i);
        // Redundancy number r_i = 1 − a_i Q a_iᵀ (whitened).
        const double redundancy = 1.0 - row.a.row(i) * q * row.a.row(i).transpose();
        const double safe = std::max(redundancy, 1e-12);
        const double inv_sqrt = 1.0 / std::sqrt(safe);
        w[i] = redundancy > 1e-6 ? row.r(i) * inv_sqrt : 0.0;
        if (i == 0)
          rr.mdb_hz_arcsec = rays[k].sigma_hz_rad * options.delta0 * inv_sqrt * kArcsecPerRad;
        if (i == 1)
          rr.mdb_v_arcsec = rays[k].sigma_v_rad * options.delta0 * inv_sqrt * kArcsecPerRad;
        if (std::abs(w[i]) > worst_w) {
          worst_w = std::abs(w[i]);
          worst = k;
        }
      }
      rr.w_hz = w[0];
      rr.w_v = w[1];
      rr.w_distance = w[2];
    }
    result.dof = observations - 3;
    result.sigma0 = result.dof > 0 ? std::sqrt(vtpv / result.dof) : 0.0;
    result.position_mm = x;
    int used = 0;
    for (int k = 0; k < n; ++k) used += active[k];
    result.rays_used = used;
    if (worst < 0 || worst_w <= options.critical_w) break;
    // Reject the worst ray only if what remains still has redundancy to check itself.
    const bool worst_has_distance = std::isfinite(rays[worst].distance_mm);
    const int remaining_observations = observations - (worst_has_distance ? 3 : 2);
    if (!options.reject_blunders || remaining_observations - 3 < 1) {
      result.blunder_suspected = true;
      break;
    }
    active[worst] = false;
    out[worst].rejected = true;
    ++result.rejected;
  }
}

IntersectionResult Intersect(std::span<const Ray> rays, const IntersectionOptions& options) {
  IntersectionResult result;
  Intersect(rays, options, result);
  return result;
}

}  // namespace armsig::reduction
