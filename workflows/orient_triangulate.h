// `orient` and `triangulate` on files: the station network adjusted from an observations
// file (with scale bars, control points and the datum the user chose), and the target
// points intersected from oriented stations. Two-face readings first give each station's
// axis errors, which are applied to all its readings.
#pragma once

#include <map>
#include <string>
#include <vector>

#include "io/network_files.h"
#include "reduction/instrument_errors.h"
#include "reduction/orientation.h"

namespace armsig::workflows {

struct OrientFilesOptions {
  std::string observations, control;
  std::vector<std::string> scale_bars;  // "A:B=LEN_MM"
  double scale_bar_sigma_mm = 0.01;
  std::string datum_station;            // at the origin; default the first observed
  std::vector<std::string> unlevelled;  // stations whose rotation is free
  bool free_datum = false;
  std::vector<std::string> datum_points;  // free network over these only (implies free)
  bool instrument_errors = true;          // estimate and apply axis errors from two faces
  // Quality gate: σ0 a posteriori above this (the readings scatter this many times more
  // than their a priori sigmas say: a blunder, or sigmas that are not the instrument's) writes
  // nothing and exits 3, naming the largest standardised residuals. 0: no gate.
  double max_sigma0 = 5.0;
  // Data snooping (reduction/data_snooping.h): false = test and report only (--no-reject);
  // the adjustment's significance level; readings forced in (--keep): "STATION->POINT"
  // (its Hz, V and distance), a scale bar "A:B" or a control point's id.
  bool reject = true;
  double alpha = reduction::DataSnooping{}.alpha;
  std::vector<std::string> keep;
  std::string out;         // stations YAML written when set (only from a converged adjustment)
  std::string points_out;  // the adjusted target points CSV, when set
  std::string json_out;    // the adjustment as JSON, when set (also when a gate fails)
};

struct OrientRun {
  std::map<std::string, reduction::InstrumentErrors> instrument_errors;  // by station
  reduction::OrientationResult result;
  // The global test: P(χ²(dof) > σ0² · dof). Below 0.05 the a priori sigmas are too small
  // for these readings, and the written sigmas are the a posteriori ones (scaled by σ0).
  double global_test_p = 1.0;
  double sigma_scale = 1.0;  // what the written sigmas were multiplied by
  // Non-empty: a gate failed (an observation fails the blunder test and could not be
  // removed, or σ0 beyond --max-sigma0) and no stations file was written.
  std::string gate_failure;
  std::string observations;  // the file, and the line of each of its observations
  std::vector<int> lines;
  double alpha = reduction::DataSnooping{}.alpha;  // the snooping's significance level
  bool reject = true;                               // false: test only (--no-reject)
};

// The oriented stations with the adjustment's σ0, degrees of freedom and method
// ("mutual+scale_bar", "control+distances", …, from what the problem held), as the
// stations file carries them into a session's set-ups.
std::vector<reduction::Station> OrientedStations(const reduction::OrientationProblem& problem,
                                                 const reduction::OrientationResult& result);

// Reads the files, adjusts and writes the outputs. A network that cannot be solved
// (result.refusals) is an InputError naming the observations file and every reason; so
// are unknown stations.
OrientRun OrientFiles(const OrientFilesOptions& options);
// What `orient` prints: axis errors, the stations with sigmas, variance components, the
// observations data snooping removed and those it could not decide, the largest
// standardised residuals (suspected blunders marked), points left out.
std::string FormatOrientReport(const OrientRun& run);
// The --json document: the adjustment, the stations, the data snooping.
std::string FormatOrientJson(const OrientRun& run);

// The adjusted target points as CSV: coordinates, sigmas, 95 % ellipsoid semi-axes.
std::string FormatAdjustedPointsCsv(const std::vector<reduction::PointEstimate>& points);

struct TriangulateFilesOptions {
  std::string stations, observations;
  bool reject_blunders = true;
  std::optional<double> critical_w;  // else from the significance level of each point
  bool instrument_errors = true;
  std::string out;  // points CSV written when set
};

struct TriangulateRun {
  std::map<std::string, reduction::InstrumentErrors> instrument_errors;
  std::vector<reduction::Observation> observations;  // as corrected, for messages
  std::vector<io::TriangulatedPoint> points;         // in order of first appearance
  int intersected = 0, rejected_rays = 0;
};

// Every target point intersected (mutual pointings at stations are skipped); no miss or
// repeat tolerances; rejected rays and points not intersected are logged (warnings).
// An observation from a station not in the stations file is an InputError naming its
// line. Writes `out`.
TriangulateRun TriangulateFiles(const TriangulateFilesOptions& options);
// "N points intersected, M not, K rays rejected as blunders -> OUT" (and axis errors).
std::string FormatTriangulateSummary(const TriangulateRun& run, const std::string& out);
// Per station: two-face collimation, trunnion and index errors with their sigmas.
std::string FormatInstrumentErrors(
    const std::map<std::string, reduction::InstrumentErrors>& errors);

}  // namespace armsig::workflows
