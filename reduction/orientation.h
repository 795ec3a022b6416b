// Station orientation: a bundle adjustment (Ceres) of the station poses (levelled:
// position + azimuth; not levelled: position + rotation) and every target point, from
// mutual pointings, scale-bar lengths, control points and distances. Initial values are
// found from the observations alone. Datum without control points (SPEC): the first
// station at the origin, levelled, circle zero = azimuth 0.
#pragma once

#include <map>
#include <set>
#include <string>
#include <vector>

#include "core/error.h"
#include "reduction/intersection.h"
#include "reduction/network.h"

namespace armsig::reduction {

struct OrientationProblem {
  std::vector<std::string> station_ids;  // in datum order (first = datum station)
  std::set<std::string> unlevelled;      // stations whose rotation is free
  std::map<std::string, double> sigma_hz_rad, sigma_v_rad;  // per-station sigmas (optional)
  std::vector<Observation> observations;
  std::vector<ScaleBar> scale_bars;
  std::vector<ControlPoint> control;
  InstrumentDefaults defaults;
  // Free network: give the covariance in the minimum-trace datum over these points and
  // stations (inner constraints: 3 translations + rotation about z). Empty with
  // free_datum = every point and station. Coordinates stay in the SPEC frame (they
  // differ only by that 4-parameter transformation).
  bool free_datum = false;
  std::set<std::string> datum_points;
};

struct OrientationOptions {
  int max_iterations = 200;
  double critical_w = 3.29;
  double delta0 = 4.13;
  void Check() const;
};

struct PointEstimate {
  std::string id;
  Eigen::Vector3d position_mm = Eigen::Vector3d::Zero();
  Eigen::Matrix3d covariance_mm2 = Eigen::Matrix3d::Zero();  // a priori σ0 = 1
  int rays = 0;
  bool control = false;
};

struct ResidualReport {
  enum class Kind { kHz, kV, kDistance, kScaleBar, kControl };
  Kind kind;
  int observation = -1;     // index into problem.observations (or scale bar / control index)
  std::string label;        // "station→point"
  double residual = 0.0;    // arcsec for angles, mm for lengths (computed − observed)
  double sigma = 0.0;       // a priori, same unit
  double redundancy = 0.0;  // r_i
  double w = 0.0;           // standardised residual
  double mdb = 0.0;         // minimal detectable bias, same unit
};

struct GroupVariance {
  std::string group;  // angles, distances, mutual pointings, scale bars, control
  int count = 0;
  double redundancy = 0.0;
  double sigma0 = 0.0;  // √(Σv²/Σr), unit weight
};

// status: kDegenerate when the network cannot be solved (refusals say why; nothing else is
// filled), kNotConverged (the results are those of the last iteration), kNonFinite (an
// estimate or precision is not finite), else kOk.
struct OrientationResult {
  SolveStatus status;
  std::vector<std::string> refusals;  // why the network cannot be solved
  std::vector<Station> stations;      // with sigmas
  std::vector<PointEstimate> points;
  double sigma0 = 0.0;
  int dof = 0, observations = 0, unknowns = 0;
  int iterations = 0;
  std::vector<ResidualReport> residuals;
  std::vector<GroupVariance> groups;
  std::string datum;  // what fixed the datum
  // Points left out of the adjustment, with the reason (one ray, never intersected).
  std::vector<std::pair<std::string, std::string>> excluded_points;
};

OrientationResult Orient(const OrientationProblem& problem, const OrientationOptions& options = {});

}  // namespace armsig::reduction
