// `orient` and `triangulate` on files: the station network adjusted from an observations
// file (with scale bars, control points and the datum the user chose), and the target
// points intersected from oriented stations. Two-face readings first give each station's
// axis errors, which are applied to all its readings.
#pragma once

#include <map>
#include <string>
#include <vector>

#include "io/network_io.h"
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
};

struct OrientRun {
  std::map<std::string, reduction::InstrumentErrors> instrument_errors;  // by station
  reduction::OrientationResult result;
};

// Reads the files and adjusts. A network that cannot be solved (result.refusals) is an
// InputError naming the observations file and every reason; so are unknown stations.
OrientRun OrientFiles(const OrientFilesOptions& options);

// The adjusted target points as CSV: coordinates, sigmas, 95 % ellipsoid semi-axes.
std::string FormatAdjustedPointsCsv(const std::vector<reduction::PointEstimate>& points);

struct TriangulateFilesOptions {
  std::string stations, observations;
  bool reject_blunders = true;
  double critical_w = 3.29;
  bool instrument_errors = true;
};

struct TriangulateRun {
  std::map<std::string, reduction::InstrumentErrors> instrument_errors;
  std::vector<reduction::Observation> observations;  // as corrected, for messages
  std::vector<io::TriangulatedPoint> points;         // in order of first appearance
  int intersected = 0, rejected_rays = 0;
};

// Every target point intersected (mutual pointings at stations are skipped); no miss or
// repeat tolerances. An observation from a station not in the stations file is an
// InputError naming its line.
TriangulateRun TriangulateFiles(const TriangulateFilesOptions& options);

}  // namespace armsig::workflows
