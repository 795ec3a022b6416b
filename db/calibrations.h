// Parameter sets (arm signatures), versioned per robot; one may be active.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cmath>
#include <cstdint>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "db/database.h"

namespace armsig::db {

struct CalibrationRecord {
  int64_t robot_id = 0;
  std::string params_spec, inputs_json, options_json, report_json;
  int rank = 0, poses_fit = 0, poses_validation = 0;
  double nominal_mean_mm = NAN, nominal_max_mm = NAN, nominal_rms_mm = NAN;
  double fit_mean_mm = NAN, fit_max_mm = NAN, fit_rms_mm = NAN;
  double validation_mean_mm = NAN, validation_max_mm = NAN, validation_rms_mm = NAN;
  bool active = false;
  // The measuring frame of the data the set was fitted on (world from the robot base).
  Eigen::Isometry3d world_from_base = Eigen::Isometry3d::Identity();
  // Covariance of the identified parameters (named, in the matrix's order); empty = none.
  std::vector<std::string> covariance_parameters;
  Eigen::MatrixXd covariance;
  // The drift decision against the set active before it (JSON); "" when none was made.
  std::string drift_json{};
  // The residual map used with the parameters (io/residual_map_json.h); "" = none.
  std::string residual_map_json{};
  // The 6-DoF target's rotation in the last link frame (in the measuring frame of
  // world_from_base), when the set was fitted to measured orientations.
  std::optional<Eigen::Matrix3d> tool_rotation{};
  // Where the set holds (schema v13, io/validity_json.h): the joint arcs its terms were
  // fitted on and its predicted σ's calibration on held-out regions; "" = none stored.
  std::string validity_json{};
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
// Replaces a stored set's drift decision (inside the transaction that stored it).
void SetDriftJson(Database& db, int64_t calibration_id, const std::string& drift_json);

struct StoredCalibration {
  int64_t id = 0;
  int version = 0;
  bool active = false;
  std::string created_at, params_spec, inputs_json, options_json, report_json;
  int rank = 0, poses_fit = 0, poses_validation = 0;
  double fit_mean_mm = NAN, validation_mean_mm = NAN, validation_max_mm = NAN,
         validation_rms_mm = NAN;
  std::optional<Eigen::Isometry3d> world_from_base;  // absent in sets stored before schema v2
  std::vector<std::string> covariance_parameters;    // empty in sets stored before schema v3
  Eigen::MatrixXd covariance;
  std::string drift_json{};  // "" when no drift decision was stored (or before schema v4)
  std::string residual_map_json{};  // "" = parametric only (and before schema v5)
  std::optional<Eigen::Matrix3d> tool_rotation{};  // fitted to orientations (schema v12)
  std::string validity_json{};  // "" before schema v13 (io/validity_json.h)
  std::vector<CalibrationRecord::Parameter> parameters;
};
std::vector<StoredCalibration> CalibrationHistory(Database& db, int64_t robot_id);  // by version
std::optional<StoredCalibration> ActiveCalibration(Database& db, int64_t robot_id);

// Makes `version` the robot's only active set. Returns false (nothing changed) when the
// robot has no such version. Call inside a transaction, and record it (RecordActivation).
bool SetActiveVersion(Database& db, int64_t robot_id, int version);

// The activation history (schema v4): who made which set active, when, replacing which.
struct Activation {
  int version = 0;
  std::optional<int> previous_version;
  std::string activated_at;  // ISO-8601 UTC
  std::string activated_by;  // recalibrate | activate | demo | migration
  std::string note;
};
// Appends to the history (inside the transaction that changed the active set).
void RecordActivation(Database& db, int64_t robot_id, const Activation& activation);
// The robot's activations, oldest first.
std::vector<Activation> ActivationHistory(Database& db, int64_t robot_id);

}  // namespace armsig::db
