// Station set-ups, raw observations and reduced points of a session.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <limits>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "core/types.h"
#include "db/database.h"

namespace armsig::db {

int64_t EnsureStation(Database& db, const std::string& code);

struct StationSetupRow {
  std::string station;  // code
  StationPose pose;
  Eigen::Vector3d sigma_position_mm = Eigen::Vector3d::Zero();
  double sigma_azimuth_rad = 0.0;
  std::optional<double> sigma_hz_rad, sigma_v_rad;  // the station's a-priori sigmas
  std::optional<double> sigma0;                     // of the orientation, when adjusted
  int dof = 0;
  std::string method;
};
int64_t InsertStationSetup(Database& db, std::optional<int64_t> session_id,
                           const StationSetupRow& setup);
// The latest set-up of every station for a session (falling back to set-ups stored
// without a session), by station code.
std::map<std::string, StationSetupRow> LatestStationSetups(Database& db, int64_t session_id);

struct ObservationRow {
  std::optional<int64_t> pose_id;
  std::string point;
  std::string station;  // code
  AngleReading reading;
  std::optional<double> distance_mm;
  std::optional<double> sigma_hz_rad, sigma_v_rad, sigma_distance_mm;
  int return_code = 0;
  // The air at the instrument when it measured (laser trackers report it), °C, hPa, %RH.
  std::optional<double> temperature_c, pressure_hpa, humidity_percent;
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
  std::optional<double> sigma0, miss_mm;  // absent when not reduced
  std::string flags;
};
// Adds one reduced point (call inside the configuration's transaction).
void InsertPoint(Database& db, int64_t session_id, const PointRow& point);
// Every stored point of a session, ordered by pose and point (`reduce` keeps the flags
// it cannot derive again from the observations).
std::vector<PointRow> LoadPoints(Database& db, int64_t session_id);
// Replaces the session's reduced points (call inside a transaction).
void ReplacePoints(Database& db, int64_t session_id, const std::vector<PointRow>& points);

}  // namespace armsig::db
