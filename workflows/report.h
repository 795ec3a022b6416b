// The recalibration report: one self-contained HTML page (figures drawn with OpenCV,
// embedded as PNG data URIs, no JavaScript, an A4 print stylesheet) a technician would
// rather look at than read.
#pragma once

#include <Eigen/Core>
#include <cmath>
#include <cstdint>
#include <map>
#include <limits>
#include <optional>
#include <string>
#include <vector>

#include "calibration/compensation.h"
#include "db/database.h"
#include "workflows/calibration_run.h"
#include "workflows/figures.h"

namespace armsig::workflows {

struct ReportActivation {
  std::string at;  // ISO-8601 UTC
  std::string by;  // recalibrate | activate | demo | migration
};
struct ReportHistoryPoint {
  int version = 0;  // 0: this run, not stored (rejected)
  std::string created_at;
  double validation_mean_mm = 0.0;
  std::string params_spec;  // all | geometric | auto | a list of names ("" = not known)
  bool active = false;
  bool drift = false;  // its comparison with the set active before it flagged drift
  std::vector<ReportActivation> activations{};  // every time it was made active, oldest first
};
// Every stored version of the robot with its drift flag and activations (schema v4).
std::vector<ReportHistoryPoint> ReportHistoryOf(db::Database& db, int64_t robot_id);

// Where the data came from: filled by LoadReportSources, or by hand (tests, imports).
struct ReportSession {
  int64_t id = 0;
  std::string started_at, finished_at, state, note;
  int poses_fit = 0, poses_validation = 0;
};
struct ReportInstrument {
  std::string name;         // station id (lab file) or instrument name (instruments table)
  std::string description;  // "geocom on /dev/ttyUSB0, σ 0.5″ / 0.5″"
  std::vector<int64_t> sessions;
};
struct ReportStationSetup {
  int64_t session_id = 0;
  std::string station;
  std::optional<double> sigma0;  // a-posteriori σ0 of the orientation, when stored
  int dof = 0;
  std::string method;
};
struct ReportSources {
  std::vector<ReportSession> sessions;
  std::vector<ReportInstrument> instruments;
  std::vector<ReportStationSetup> setups;
};

struct ReportInput {
  std::string generated_at;    // ISO-8601 UTC; "" = now
  std::string armsig_version;  // ARMSIG_VERSION of the program writing the report
  std::string robot;
  int version = 0;                 // 0 when nothing was stored
  std::string decision;            // "stored as version 4" / "rejected: …"
  std::vector<std::string> gates;  // one line per gate with its figures
  const calibration::RobotModel* model = nullptr;
  const CalibrationRun* run = nullptr;
  std::vector<MeasuredPose> validation;  // the poses of run->validation_pose_ids
  // Air temperature (°C) at the instrument for validation poses that have one (laser
  // trackers), by pose id: the error-against-temperature figure.
  std::map<std::string, double> temperature_c;
  ReportSources sources;
  std::vector<ReportHistoryPoint> history;
  // The change against the set active before this run; `previous_version` nullopt when
  // the robot had none. `changes_note` says why the comparison is limited or absent when
  // the caller knows more than the report can tell from the specs.
  std::optional<int> previous_version;
  std::string previous_params_spec;
  std::vector<calibration::ParameterChange> changes;
  std::string changes_note;
  bool drift = false;
  // The nightly job's window: every session tested against the set active before the run
  // (calibration::TestAgainstSet), the drift line, and the named causes, best first.
  struct WindowTest {
    int64_t session = 0;
    std::string started_at;
    int poses = 0;
    double mean_mm = 0.0, effect_max_mm = 0.0, p_value = 1.0;
    bool disagrees = false, outlier = false;
  };
  std::vector<WindowTest> window{};
  std::string drift_line{};
  std::vector<std::string> causes{};
};

// Writes DIR/index.html and DIR/*.png; returns the HTML path. Throws on I/O failure.
// Temporary files a crashed writer left beside them (older than a minute) are removed.
std::string WriteReport(const std::string& dir, const ReportInput& input);

// The text index.html carries to say which robot's which version it reports (a <meta>
// element of its head); "" for a run that stored nothing.
std::string ReportSetMarker(const std::string& robot, int version);

// Removes the temporary files (NAME.tmp.XXXXXX, io/atomic_file.h) of the report's own
// files left in DIR by a writer that died, when older than `min_age_s`. Returns how many.
int RemoveReportDebris(const std::string& dir, double min_age_s);

// The sessions behind the run's pose ids ("<session>:<label>", as db::LoadRobotPoses
// names them), with their dates, the instruments of their stored lab files and of the
// instruments table, and their stations' latest orientation.
ReportSources LoadReportSources(db::Database& db, const CalibrationRun& run);
// The same for sessions given by id (no pose counts): what the ISO 9283 page names.
ReportSources LoadReportSources(db::Database& db, const std::vector<int64_t>& session_ids);

// ---- The pieces of the page, exposed for tests ----

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

// NiceTicks and IntegerTicks: workflows/figures.h.

// The histogram of error distances as drawn: equal bins from 0, integer counts and the
// integer ticks of its count axis.
struct Histogram {
  double bin_width_mm = 0.0;
  std::vector<int> counts;
  std::vector<int> count_ticks;
};
Histogram HistogramOf(const std::vector<double>& distances_mm, int bins = 20);

// A parameter's change as the change table shows it: three significant digits, in mm or
// mrad from 0.01 up, else in µm or µrad ("-0.0420 µrad", never "-0.0000 mrad").
std::string FormatChange(double value, bool millimetres);

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

// "all", "geometric", "auto" or "list" (a comma list of names and groups).
std::string ParamsKind(const std::string& params_spec);

}  // namespace armsig::workflows
