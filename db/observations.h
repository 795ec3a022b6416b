// Station set-ups, raw observations and reduced points of a session.
#pragma once

#include <Eigen/Core>
#include <chrono>
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

// An instrument as it identified itself when a capture began (the `instruments` table).
struct InstrumentRow {
  std::string name;      // unique: the model and serial number, else the protocol and port
  std::string kind;      // theodolite | total_station | laser_tracker
  std::string protocol;  // geocom | gsi | emscon
  std::string port;      // serial path or HOST:PORT
  std::string serial_number, firmware;
  std::optional<double> sigma_hz_arcsec, sigma_v_arcsec, sigma_distance_mm;
};
// The id of the instrument of that name, stored first when it is new (its port and firmware
// brought up to date when they changed: a firmware update is part of the record).
int64_t EnsureInstrument(Database& db, const InstrumentRow& instrument);

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
  // When the instrument's answer arrived (ISO 8601 UTC, milliseconds, as `measured_at`
  // stores it); absent: the time it is stored (readings imported from a file).
  std::optional<std::string> measured_at;
  std::string note;                    // the instrument's warning with a valid reading
  std::optional<int64_t> instrument_id;  // EnsureInstrument's id; absent for imported readings
};
// A time as `measured_at` stores it (the database's own default does the same): ISO 8601
// UTC with milliseconds, 2026-11-27T13:04:14.123Z, so that stored times sort as text.
std::string MeasuredAt(std::chrono::system_clock::time_point time);
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
  // The target frame's measured orientation (a 6-DoF probe; imported poses); nullopt for a
  // position-only point.
  std::optional<MeasuredOrientation> orientation;
  // A point paired from a sweep's streams (measuring on the move): the clock's share of its
  // error, speed × σ_t (mm, included in covariance_mm2); nullopt for a point measured standing.
  std::optional<double> sync_sigma_mm;
};
// Adds one reduced point (call inside the configuration's transaction).
void InsertPoint(Database& db, int64_t session_id, const PointRow& point);
// Every stored point of a session, ordered by pose and point (`reduce` keeps the flags
// it cannot derive again from the observations).
std::vector<PointRow> LoadPoints(Database& db, int64_t session_id);
// Replaces the session's reduced points (call inside a transaction).
void ReplacePoints(Database& db, int64_t session_id, const std::vector<PointRow>& points);

// What a reduction of a session reads, as the count and the last id of its observations,
// station set-ups and points: rows are only ever added (points replaced whole, with new
// ids), so two equal marks mean the same rows. A reduction computed on a snapshot writes
// its points only if the mark under the write lock is still the snapshot's.
struct SessionRowsMark {
  int64_t observations = 0, last_observation = 0;
  int64_t setups = 0, last_setup = 0;
  int64_t points = 0, last_point = 0;
  bool operator==(const SessionRowsMark&) const = default;
};
SessionRowsMark MarkSessionRows(Database& db, int64_t session_id);

}  // namespace armsig::db
