// Station orientation: a bundle adjustment (Ceres) of the station poses (levelled:
// position + azimuth; not levelled: position + rotation) and every target point, from
// mutual pointings, scale-bar lengths, control points and distances. Initial values are
// found from the observations alone. Datum without control points (the interface
// reference): the first station at the origin, levelled, circle zero = azimuth 0.
// Blunders are removed by iterative data snooping (reduction/data_snooping.h): the
// observation with the largest standardised residual beyond the critical value is taken
// out and the network adjusted again, until none fails or what fails cannot be decided.
#pragma once

#include <map>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "core/error.h"
#include "reduction/data_snooping.h"
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
  // free_datum = every point and station. Coordinates stay in the datum frame (they
  // differ only by that 4-parameter transformation).
  bool free_datum = false;
  std::set<std::string> datum_points;
};

// Observations forced into the adjustment: tested, never removed (indices into the
// problem's observations, scale bars and control points).
struct KeptObservations {
  std::set<int> observations, scale_bars, control;
};

struct OrientationOptions {
  int max_iterations = 200;  // of one adjustment
  DataSnooping snooping;     // α = 0.1 %, β0 = 80 %; snooping.reject = false: test only
  KeptObservations keep;
  // Snooping stops after removing this fraction of the tested observations (at least one):
  // more failing observations are not blunders but wrong sigmas, a systematic error or
  // mixed-up point names, which removing readings would hide.
  double max_removed_fraction = 0.05;
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

// "Hz", "V", "distance", "scale bar", "control".
const char* KindName(ResidualReport::Kind kind);

// An observation data snooping took out of the adjustment.
struct RemovedObservation {
  ResidualReport::Kind kind;
  int observation = -1;  // index into problem.observations (scale bar / control index)
  std::string station;   // empty for a scale bar or a control point
  std::string point;     // the target (a station's id for a mutual pointing); "A:B" for a bar
  std::string label;     // as in ResidualReport
  int line = 0;          // the observation's line in its file, when known
  double w = 0.0;           // its standardised residual when it was removed
  double redundancy = 0.0;  // and its redundancy number then
  double sigma = 0.0;       // a priori: arcsec for angles, mm for lengths
  // Its estimated error: observed − predicted by the final adjustment (arcsec or mm; for a
  // control point the length of the 3D discrepancy).
  double error = 0.0;
  // The adjustment that found it (1: the first; 0: set aside at the robust start as a
  // mistake, its w then the test from its predicted residual).
  int round = 0;
  // Removed with it because the data cannot tell which of them is wrong ("Hz 4->202").
  std::vector<std::string> twins;
};

// An observation that fails the test and was not removed, and why.
struct UndecidedBlunder {
  ResidualReport observation;
  Undecided why = Undecided::kRejectionOff;
  std::vector<ResidualReport> twins;  // those it cannot be told from (data_snooping.h)
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
  // Data snooping: what was removed (in order), what fails the test in the last adjustment
  // but could not be removed, whether it stopped at the removal limit, and the adjustments
  // it took.
  std::vector<RemovedObservation> removed;
  std::vector<UndecidedBlunder> undecided;
  SnoopLevels levels;  // of the tests of the last adjustment
  bool removal_limit_reached = false;
  int adjustments = 0;
};

OrientationResult Orient(const OrientationProblem& problem, const OrientationOptions& options = {});

}  // namespace armsig::reduction
