// Intersection of the rays of one target point: a closed-form start (closest point of
// the rays, or a polar point where a distance is measured), then weighted least squares
// on the observed Hz, V (and slope distances), with covariance, per-ray residuals and
// Baarda's data snooping (reduction/data_snooping.h, the policy orient shares): a blunder
// ray is reported and, when the policy can decide it, rejected.
#pragma once

#include <Eigen/Core>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "core/error.h"
#include "core/types.h"
#include "reduction/data_snooping.h"
#include "reduction/network.h"
#include "reduction/point_flags.h"

namespace armsig::reduction {

// One ray, everything resolved: station pose, face-I reading, sigmas.
struct Ray {
  Eigen::Vector3d station_mm = Eigen::Vector3d::Zero();
  Eigen::Matrix3d world_from_station = Eigen::Matrix3d::Identity();
  AngleReading reading;  // any face; reduced to face I internally
  std::optional<double> distance_mm;
  double sigma_hz_rad = 0.0, sigma_v_rad = 0.0, sigma_distance_mm = 0.0;
};

// The ray of an observation from its station's set-up, with the effective sigmas
// (SigmasOf: the observation's own, else the station's, else the defaults).
Ray RayOf(const Observation& observation, const Station& station,
          const InstrumentDefaults& defaults);

struct IntersectionOptions {
  // The blunder policy of every adjustment (α0 = 0.1 %, β0 = 80 %); a rejected blunder
  // takes its whole ray out (snooping.reject = false: test and flag only).
  DataSnooping snooping;
  double min_ray_angle_rad = 3.49e-3;  // 0.2°: rays closer than this are "nearly parallel"
  int max_iterations = 10;
  void Check() const;
};

struct RayResult {
  double hz_arcsec = 0.0, v_arcsec = 0.0;          // residuals (computed − observed)
  std::optional<double> distance_mm;               // residual of the distance, when measured
  double w_hz = 0.0, w_v = 0.0, w_distance = 0.0;  // standardised residuals
  double mdb_hz_arcsec = 0.0, mdb_v_arcsec = 0.0;  // minimal detectable biases
  double miss_mm = 0.0;                            // distance of the point from the ray
  bool rejected = false;
};

// status: kTooFewObservations (no ray, or one ray without distance), kDegenerate (every
// pair of rays closer than min_ray_angle), kNotConverged, kNonFinite (an estimate is
// not finite); position and covariance are NaN unless ok.
struct IntersectionResult {
  SolveStatus status;
  Eigen::Vector3d position_mm = Eigen::Vector3d::Zero();
  Eigen::Matrix3d covariance_mm2 = Eigen::Matrix3d::Zero();  // a priori (σ0 = 1)
  double sigma0 = 0.0;                                       // a posteriori, unit weight
  int dof = 0;
  int iterations = 0;
  int rays_used = 0;
  int rejected = 0;
  // blunder_rejected, blunder_suspected (a ray fails the test but cannot be rejected),
  // or the flag of a failed solve (FlagsOf(status)); IntersectPoint adds its checks.
  PointFlags flags;
  double max_miss_mm = 0.0;     // largest miss distance of the rays used
  std::vector<RayResult> rays;  // one per input ray, in order
};

// Reuses `result`'s storage, so a loop over many points does not allocate.
void Intersect(std::span<const Ray> rays, const IntersectionOptions& options,
               IntersectionResult& result);
IntersectionResult Intersect(std::span<const Ray> rays, const IntersectionOptions& options = {});

// Hz, V (face I, rad) of `target` seen from a station (HzVOf).
AngleReading PredictReading(const Eigen::Vector3d& station_mm,
                            const Eigen::Matrix3d& world_from_station,
                            const Eigen::Vector3d& target_mm);

}  // namespace armsig::reduction

namespace armsig::reduction {

// The checks a reduced point must pass; a check without a tolerance is not made.
struct PointChecks {
  std::optional<double> max_miss_mm;    // miss_exceeded above this
  std::optional<double> max_repeat_mm;  // repeat_exceeded above this
};

struct PointOptions {
  IntersectionOptions intersection;
  PointChecks checks;
};

// The rays of one target point (one pose, one point id). `repeats`: the rays of each
// independent repeated measurement of it, when it was measured several times (capture's
// repeatability check); the rays of all of them are also in `rays`.
struct RayGroup {
  std::vector<Ray> rays;
  std::vector<std::vector<Ray>> repeats;
};

struct ReducedPoint {
  IntersectionResult result;        // result.flags carries every flag of the point
  std::optional<double> repeat_mm;  // largest distance between the repeats' points
  // Solved, and passes the checks given (blunder flags do not refuse a point).
  bool accepted() const {
    return result.status.ok() && !result.flags.Has(PointFlag::kMissExceeded) &&
           !result.flags.Has(PointFlag::kRepeatExceeded) &&
           !result.flags.Has(PointFlag::kSigmaExceeded);
  }
};

// Intersects one group and applies the checks.
void IntersectPoint(const RayGroup& group, const PointOptions& options, ReducedPoint& out);
ReducedPoint IntersectPoint(const RayGroup& group, const PointOptions& options = {});
// Every group, in order.
std::vector<ReducedPoint> IntersectPoints(std::span<const RayGroup> groups,
                                          const PointOptions& options = {});

// The flags of a previously stored point that a reduction with `checks` from the stored
// rays cannot derive again and so keeps: repeat_exceeded and sigma_exceeded always (only
// the accepted readings are stored, not the rounds; the sigma tolerance is capture's),
// miss_exceeded when no miss tolerance is given.
PointFlags CarriedOverFlags(PointFlags stored, const PointChecks& checks);

}  // namespace armsig::reduction
