// Intersection of the rays of one target point: a closed-form start (closest point of
// the rays, or a polar point where a distance is measured), then weighted least squares
// on the observed Hz, V (and slope distances), with covariance, per-ray residuals and
// Baarda's data snooping: a blunder ray is reported and, when enough rays remain,
// rejected.
#pragma once

#include <Eigen/Core>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "core/types.h"

namespace armsig::reduction {

// One ray, everything resolved: station pose, face-I reading, sigmas.
struct Ray {
  Eigen::Vector3d station_mm = Eigen::Vector3d::Zero();
  Eigen::Matrix3d world_from_station = Eigen::Matrix3d::Identity();
  AngleReading reading;  // any face; reduced to face I internally
  double distance_mm = std::numeric_limits<double>::quiet_NaN();  // NaN = none
  double sigma_hz_rad = 0.0, sigma_v_rad = 0.0, sigma_distance_mm = 0.0;
};

struct IntersectionOptions {
  bool reject_blunders = true;
  double critical_w = 3.29;            // |w| beyond this is a blunder (α0 = 0.1 %, two-sided)
  double delta0 = 4.13;                // non-centrality for the MDB (α0 = 0.1 %, β0 = 80 %)
  double min_ray_angle_rad = 3.49e-3;  // 0.2°: rays closer than this are "nearly parallel"
  int max_iterations = 10;
  void Check() const;
};

enum class IntersectionStatus {
  kOk,
  kOneRay,        // a single ray without distance: no point
  kParallelRays,  // every pair of rays closer than min_ray_angle
  kNoConvergence,
};
const char* ToString(IntersectionStatus status);

struct RayResult {
  double hz_arcsec = 0.0, v_arcsec = 0.0;  // residuals (computed − observed)
  double distance_mm = std::numeric_limits<double>::quiet_NaN();
  double w_hz = 0.0, w_v = 0.0, w_distance = 0.0;  // standardised residuals
  double mdb_hz_arcsec = 0.0, mdb_v_arcsec = 0.0;  // minimal detectable biases
  double miss_mm = 0.0;                            // distance of the point from the ray
  bool rejected = false;
};

struct IntersectionResult {
  IntersectionStatus status = IntersectionStatus::kOk;
  Eigen::Vector3d position_mm = Eigen::Vector3d::Zero();
  Eigen::Matrix3d covariance_mm2 = Eigen::Matrix3d::Zero();  // a priori (σ0 = 1)
  double sigma0 = 0.0;                                       // a posteriori, unit weight
  int dof = 0;
  int iterations = 0;
  int rays_used = 0;
  int rejected = 0;
  bool blunder_suspected = false;  // a ray fails the test but cannot be rejected
  double max_miss_mm = 0.0;
  std::vector<RayResult> rays;  // one per input ray, in order
  std::string reason;           // why status is not kOk
};

// Reuses `result`'s storage, so a loop over many points does not allocate.
void Intersect(std::span<const Ray> rays, const IntersectionOptions& options,
               IntersectionResult& result);
IntersectionResult Intersect(std::span<const Ray> rays, const IntersectionOptions& options = {});

// Hz, V (face I, rad) and slope distance of `target` seen from a station.
AngleReading PredictReading(const Eigen::Vector3d& station_mm,
                            const Eigen::Matrix3d& world_from_station,
                            const Eigen::Vector3d& target_mm);

}  // namespace armsig::reduction
