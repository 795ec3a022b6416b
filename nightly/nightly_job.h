// The nightly job's private parts, shared by its sources: the gates and limits it judges
// by, the helpers its steps share, and the job itself (nightly_job.cc: reading, fitting,
// storing and reporting a night; recalibrate_compare.cc: the window and the new set against
// the active set; recalibrate_decision.cc: the decision's text and JSON). Not an interface:
// nightly/recalibrate.h is.
#pragma once

#include <Eigen/Core>
#include <nlohmann/json.hpp>
#include <spdlog/spdlog.h>

#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "calibration/change.h"
#include "calibration/model.h"
#include "db/database.h"
#include "db/jobs.h"
#include "db/robots.h"
#include "db/store.h"
#include "io/file_lock.h"
#include "nightly/recalibrate.h"
#include "report/report.h"
#include "workflows/calibration_run.h"
#include "workflows/signature.h"

namespace armsig::nightly {

struct Gates {
  double max_mean_mm = 0.5, max_max_mm = 2.0, tolerance_mm = 0.02, drift_sigma = 5.0,
         drift_mm = kDefaultDriftMm;
  int window_sessions = kDefaultWindowSessions, window_days = kDefaultWindowDays;
};

constexpr int kDriftConfigurations = 50;     // spread over the work volume, the same every night
constexpr size_t kMinPosesPerSession = 3;    // to place a session's measurement frame
// A session the new set is tried on before activation needs enough configurations for its
// own frame's six degrees of freedom to leave a meaningful mean; the new set may be worse
// there than the reference by this share (and the tolerance in mm) before it is refused.
constexpr size_t kMinElsewherePoses = 10;
// A session is tested against the active set on its configurations inside the set's support
// (its terms' arcs, its map's); with fewer than this there, it is not tested. Six: their 18
// coordinates leave 12 beyond the six unknowns of the session's own frame, twice as many.
constexpr size_t kMinJudgedPoses = 6;
constexpr double kElsewhereTolerance = 0.05;

constexpr double kDriftSignificance = 1e-3;  // p-value below which two sets differ

// What the measurements are, not how they were asked for: every pose's id, joints and
// target, in order, with the options that shape the fit. Equal digests = same inputs.
std::string InputDigest(const std::vector<MeasuredPose>& poses, const std::string& params,
                        int select);
// Gates from the latest session's lab file (`recalibration:` block), then the options.
Gates LoadGates(db::Database& database, int64_t robot_id, const RecalibrateOptions& o);
// A calibration's stored inputs digest ("" when none was recorded).
std::string StoredDigest(const db::StoredCalibration& c);
// Whether a stored set was fitted on the same measurements as this night: the same sessions
// and as many poses (sessions only grow; the same ones re-reduced are the same robot too).
bool SameMeasurements(const db::StoredCalibration& c, const std::vector<int64_t>& sessions,
                      size_t poses);
// An error summary as the decision's JSON gives it.
nlohmann::json StatsJson(const calibration::ErrorStats& s);
// "2026-11-27T02:30:00.123Z" → "2026-11-27 02:30 UTC".
std::string ShortTime(const std::string& iso);
// "session 4" / "sessions 4, 5".
std::string SessionList(const std::vector<int64_t>& sessions);

// A session the night may use, with its usable configurations.
struct WindowSession {
  db::SessionSummary summary;
  std::vector<MeasuredPose> poses;
};
// Configurations a run of sessions needs for a fit of its own (nightly_job.cc).
int PosesNeeded(int identified, int sessions);
// The time `days` before now as session start times are stored (UTC, ISO 8601).
std::string DaysAgoUtc(int days);
// A cause of the comparison in the decision's words and units (mm, mrad, ppm).
NamedCause NameOf(const calibration::ExplainedCause& c, std::string over);
// The non-geometric terms a set of this --params estimates: the only terms that may be
// named as causes (nullopt: the spec cannot be read, every term).
std::optional<std::vector<int>> TermsOf(const calibration::RobotModel& model,
                                        const std::string& params_spec);
// The active set's error per coordinate out of sample: what a session of the same robot
// shows against it (its validation rms over three coordinates).
double SetSigmaMm(const db::StoredCalibration& c);

// One night of the job, step by step: read the window, test its sessions against the
// active set, choose what to fit (never across a change), fit, judge, compare, store,
// report.
class NightlyJob {
 public:
  explicit NightlyJob(const RecalibrateOptions& options) : options_(options) {}
  RecalibrationDecision Run();

 private:
  void Log(const std::string& message) const {
    spdlog::info("recalibrate: {}: {}", options_.robot, message);
  }
  void OpenAndLock();
  void ReadInputs();
  void SelectWindow(const std::vector<db::SessionSummary>& sessions,
                    std::vector<MeasuredPose> poses);
  void TestAgainstActive();
  std::vector<MeasuredPose> FitInput() const;
  bool UpToDate(const std::string& digest);
  void Fit(const std::vector<MeasuredPose>& poses);
  void JudgeGates();
  void CompareWithActive();
  void CompareOnSameData(const workflows::Signature& old);
  void TryElsewhere();
  void DriftConfigurations(const workflows::Signature& old);
  void Store(const nlohmann::json& inputs);
  void WriteRunReport();
  // A drift-suspected night's page: no fit, the decision and the window (report.h).
  void WriteDecisionOnlyReport();
  // The decision's part of a report: the drift line, its causes, the window tested.
  void AddDecision(report::ReportInput& input) const;
  void WriteOutput(const std::function<void()>& write);
  void Gate(const std::string& name, double value, double limit);

  const RecalibrateOptions& options_;
  std::string since_;
  std::optional<db::Database> database_;
  int64_t robot_id_ = 0;
  std::optional<io::FileLock> file_lock_;
  std::optional<db::RobotLock> server_lock_;
  calibration::RobotModel model_;
  Gates gates_;
  std::vector<WindowSession> window_;
  // Sessions of the robot the night does not fit (other kinds, outside the window) and that
  // are not from before a change: where a new set is tried before it becomes active.
  std::vector<WindowSession> elsewhere_;
  std::string floor_started_at_;
  std::vector<db::StoredCalibration> history_;
  std::optional<db::StoredCalibration> current_;
  size_t input_poses_ = 0;  // the poses this night fits and validates on
  std::vector<Eigen::VectorXd> spread_;
  // The configurations two sets are compared on: spread_, kept where both sets were fitted
  // (their terms' arcs), else the window's configurations there (DriftConfigurations).
  std::vector<Eigen::VectorXd> compared_;
  std::string compared_over_;
  // A window session lay outside the active set's support and was not tested against it.
  bool extended_ = false;
  RecalibrationDecision decision_;
  std::optional<workflows::CalibrationRun> run_;
  workflows::CalibrateSettings settings_;
  std::vector<MeasuredPose> fit_, validation_;
  std::vector<calibration::ParameterChange> changes_;
  bool pass_ = false;
};


}  // namespace armsig::nightly
