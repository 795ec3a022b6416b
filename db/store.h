// Typed reads and writes of the armsig database. Callers group writes that belong
// together in one SQLite::Transaction; every function here is a plain statement.
#pragma once

#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "core/types.h"
#include "db/database.h"

namespace armsig::db {

int64_t EnsureRobot(Database& db, const std::string& name, const std::string& model_name,
                    const std::string& model_yaml);
std::optional<int64_t> FindRobot(Database& db, const std::string& name);
int64_t EnsureStation(Database& db, const std::string& code);
int64_t CreateSession(Database& db, int64_t robot_id, const std::string& lab_yaml,
                      const std::string& plan_json, const std::string& state,
                      const std::string& note);
void SetSessionState(Database& db, int64_t session_id, const std::string& state);
std::vector<int64_t> SessionIds(Database& db);
bool SessionExists(Database& db, int64_t session_id);

struct StationSetupRow {
  std::string station;  // code
  StationPose pose;
  Eigen::Vector3d sigma_position_mm = Eigen::Vector3d::Zero();
  double sigma_azimuth_rad = 0.0;
  double sigma_hz_rad = std::numeric_limits<double>::quiet_NaN();
  double sigma_v_rad = std::numeric_limits<double>::quiet_NaN();
  double sigma0 = std::numeric_limits<double>::quiet_NaN();
  int dof = 0;
  std::string method;
};
int64_t InsertStationSetup(Database& db, std::optional<int64_t> session_id,
                           const StationSetupRow& setup);
// The latest set-up of every station for a session (falling back to set-ups stored
// without a session), by station code.
std::map<std::string, StationSetupRow> LatestStationSetups(Database& db, int64_t session_id);

int64_t InsertPose(Database& db, int64_t session_id, int seq, const std::string& label,
                   const std::optional<Eigen::VectorXd>& joints_rad, const std::string& status,
                   int attempts);

struct ObservationRow {
  std::optional<int64_t> pose_id;
  std::string point;
  std::string station;  // code
  AngleReading reading;
  std::optional<double> distance_mm;
  double sigma_hz_rad = std::numeric_limits<double>::quiet_NaN();
  double sigma_v_rad = std::numeric_limits<double>::quiet_NaN();
  double sigma_distance_mm = std::numeric_limits<double>::quiet_NaN();
  int return_code = 0;
};
// Inserts with one prepared statement (station ids resolved once).
void InsertObservations(Database& db, int64_t session_id, const std::vector<ObservationRow>& rows);
// Every observation of a session, ordered by pose and point.
std::vector<ObservationRow> LoadObservations(Database& db, int64_t session_id);

struct PointRow {
  std::optional<int64_t> pose_id;
  std::string point;
  std::optional<Eigen::Vector3d> position_mm;  // nullopt: could not be reduced
  Eigen::Matrix3d covariance_mm2 = Eigen::Matrix3d::Zero();
  int rays = 0;
  int rejected_rays = 0;
  double sigma0 = std::numeric_limits<double>::quiet_NaN();
  double miss_mm = std::numeric_limits<double>::quiet_NaN();
  std::string flags;
};
// Adds one reduced point (call inside the configuration's transaction).
void InsertPoint(Database& db, int64_t session_id, const PointRow& point);
// Replaces the session's reduced points (call inside a transaction).
void ReplacePoints(Database& db, int64_t session_id, const std::vector<PointRow>& points);

}  // namespace armsig::db

namespace armsig::db {

struct SessionRow {
  int64_t id = 0;
  std::string robot;
  std::string lab_yaml, plan_json, state, note;
};
std::optional<SessionRow> LoadSession(Database& db, int64_t session_id);
// Plan indices already stored (measured or skipped) for a session.
std::vector<int> StoredSeqs(Database& db, int64_t session_id);

}  // namespace armsig::db

namespace armsig::db {

struct CalibrationRecord {
  int64_t robot_id = 0;
  std::string params_spec, inputs_json, options_json, report_json;
  int rank = 0, poses_fit = 0, poses_validation = 0;
  double nominal_mean_mm = NAN, nominal_max_mm = NAN, nominal_rms_mm = NAN;
  double fit_mean_mm = NAN, fit_max_mm = NAN, fit_rms_mm = NAN;
  double validation_mean_mm = NAN, validation_max_mm = NAN, validation_rms_mm = NAN;
  bool active = false;
  struct Parameter {
    std::string name, unit;
    double value = 0.0, sigma = NAN;
    bool identified = false;
  };
  std::vector<Parameter> parameters;
  struct Residual {
    std::string pose_label, role;  // fit | validation
    Eigen::Vector3d error_mm = Eigen::Vector3d::Zero();
    double nominal_distance_mm = NAN;
  };
  std::vector<Residual> residuals;
};

// Stores a calibration as the robot's next version (one transaction by the caller);
// `active` makes it the robot's only active set. Returns {id, version}.
std::pair<int64_t, int> InsertCalibration(Database& db, const CalibrationRecord& record);

}  // namespace armsig::db

namespace armsig::db {

// Every measured configuration of the robot with a reduced point: joints + target.
// Pose ids are "<session>:<label>". `since`: ISO date/time lower bound on the session
// start (empty = all). `max_pose_row` receives the newest pose row id (for idempotence).
std::vector<MeasuredPose> LoadRobotPoses(Database& db, int64_t robot_id, const std::string& since,
                                         int64_t* max_pose_row = nullptr);

struct StoredCalibration {
  int64_t id = 0;
  int version = 0;
  bool active = false;
  std::string created_at, params_spec, inputs_json, report_json;
  double validation_mean_mm = NAN, validation_max_mm = NAN;
  std::vector<CalibrationRecord::Parameter> parameters;
};
std::vector<StoredCalibration> CalibrationHistory(Database& db, int64_t robot_id);  // by version
std::optional<StoredCalibration> ActiveCalibration(Database& db, int64_t robot_id);
std::string RobotModelYaml(Database& db, int64_t robot_id);

// A session's measured configurations with their reduced points, in plan order, and
// each point's covariance (mm²).
std::vector<MeasuredPose> LoadSessionPoses(Database& db, int64_t session_id,
                                           std::vector<Eigen::Matrix3d>* covariances = nullptr);

}  // namespace armsig::db
