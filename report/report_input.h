// What the recalibration report is made of (report/report.h writes it): the run, where
// its data came from, the robot's history of parameter sets and how far each moved the arm.
#pragma once

#include <Eigen/Core>
#include <cmath>
#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "calibration/compensation.h"
#include "calibration/model.h"
#include "workflows/calibration_run.h"

namespace armsig::report {

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

// How far a version moved the arm: the positions it predicts against those of the set it
// is compared with (the one active before it, else the version before), over
// configurations spread over the work volume, its positions rigidly aligned onto the
// other's (calibration::ProfileDifference).
struct ReportDriftPoint {
  int version = 0;            // 0: this run (not stored)
  int against = 0;            // the version it is compared with
  double max_mm = NAN;        // the largest |Δx| over the configurations
  double mean_mm = NAN;       // their mean |Δx|
  double sigma_max_mm = NAN;  // the standard deviation of the largest |Δx|, both sets' own
  bool drift = false;         // flagged when it was stored
};
struct ReportDrift {
  std::vector<ReportDriftPoint> points;  // by version, this run last
  double tolerance_mm = NAN;             // drift needs more than this too (the drift gate)
  int configurations = 0;
};

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
  const workflows::CalibrationRun* run = nullptr;
  std::vector<MeasuredPose> validation;  // the poses of run->validation_pose_ids
  // Air temperature (°C) at the instrument for validation poses that have one (laser
  // trackers), by pose id: the error-against-temperature figure.
  std::map<std::string, double> temperature_c;
  ReportSources sources;
  std::vector<ReportHistoryPoint> history;
  // Every version's move of the arm against the set before it: the drift figure.
  ReportDrift drift_history{};
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

}  // namespace armsig::report
