// The report's numbers, apart from how they are drawn or printed: percentiles and per-axis
// statistics of the validation errors, the worst poses, the histogram, and the
// error-against-temperature trend with when it may be shown.
#pragma once

#include <Eigen/Core>
#include <cmath>
#include <limits>
#include <optional>
#include <string>
#include <vector>

#include "calibration/drift.h"
#include "report/report_input.h"

namespace armsig::report {

// Nearest-rank percentile: the smallest value v with at least `percent` % of the values
// ≤ v (sorted[ceil(percent·n/100) − 1]). NaN for no values.
double PercentileNearestRank(std::vector<double> values, int percent);

// Statistics of one component (dX, dY, dZ: signed; "distance": the norm); the
// percentiles are of the absolute values.
struct AxisStatistics {
  std::string name;
  double mean_mm = NAN, std_mm = NAN, rms_mm = NAN, max_abs_mm = NAN;
  double p50_mm = NAN, p95_mm = NAN, p99_mm = NAN;
};
// dX, dY, dZ and distance, in that order.
std::vector<AxisStatistics> ResidualStatistics(const std::vector<Eigen::Vector3d>& residuals);

// Indices of the `count` largest error distances, largest first (ties: lower index first).
std::vector<int> WorstResiduals(const std::vector<Eigen::Vector3d>& residuals, int count);

// NiceTicks and IntegerTicks: report/figures.h.

// The histogram of error distances as drawn: equal bins from 0, integer counts and the
// integer ticks of its count axis.
struct Histogram {
  double bin_width_mm = 0.0;
  std::vector<int> counts;
  std::vector<int> count_ticks;
};
Histogram HistogramOf(const std::vector<double>& distances_mm, int bins = 20);

// The least-squares line y = intercept + slope·x (the error-against-temperature trend);
// nullopt for fewer than two points or a single x.
struct LinearTrend {
  double slope = 0.0, intercept = 0.0;
  int points = 0;
  // From 3 points on: the slope's standard deviation (from the scatter about the line)
  // and the two-sided p-value of "no slope" (Student's t on points − 2 degrees of
  // freedom); with 2 points, NaN and 1.
  double sigma_slope = std::numeric_limits<double>::quiet_NaN();
  double p_value = 1.0;
};
std::optional<LinearTrend> LinearTrendOf(const std::vector<double>& x,
                                         const std::vector<double>& y);

// `after` against `before` (calibration::ProfileDifference) over `configurations`: the
// largest and mean |Δx| and the largest one's sigma (version fields left to the caller).
ReportDriftPoint DriftPointOf(const calibration::RobotModel& model,
                              const calibration::FittedSet& before,
                              const calibration::FittedSet& after,
                              const std::vector<Eigen::VectorXd>& configurations);

// A slope of the error against the temperature says something only over a span of
// temperatures a thermal effect can show in, and from enough poses to tell it from their
// scatter: at least 1 °C and 10 poses.
inline constexpr double kMinTrendSpanC = 1.0;
inline constexpr int kMinTrendPoints = 10;
// "" when the trend of these temperatures may be shown, else why not ("the temperatures
// span only 0.01 °C; a slope needs at least 1 °C").
std::string TemperatureTrendRefusal(const std::vector<double>& temperatures_c);

}  // namespace armsig::report
