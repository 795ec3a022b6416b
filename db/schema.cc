#include "db/schema.h"

#include <array>
#include <string>

#include "db/jobs.h"

namespace armsig::db {

namespace {

// Schema v1: the whole mission. Angles in rad, lengths in mm, times ISO-8601 UTC.
constexpr std::string_view kSchemaV1 = R"sql(
CREATE TABLE robots (
  id           INTEGER PRIMARY KEY,
  name         TEXT NOT NULL UNIQUE,
  model_name   TEXT NOT NULL,
  model_yaml   TEXT NOT NULL,              -- the robot model file as loaded
  created_at   TEXT NOT NULL DEFAULT (strftime('%Y-%m-%dT%H:%M:%fZ','now'))
);

CREATE TABLE instruments (
  id                 INTEGER PRIMARY KEY,
  name               TEXT NOT NULL UNIQUE,
  kind               TEXT NOT NULL CHECK (kind IN ('theodolite','total_station','laser_tracker','robot_controller','encoder_box')),
  protocol           TEXT NOT NULL,          -- geocom, gsi, val, as, counter_box, ...
  port               TEXT,
  serial_number      TEXT,
  firmware           TEXT,
  sigma_hz_arcsec    REAL,
  sigma_v_arcsec     REAL,
  sigma_distance_mm  REAL,
  created_at         TEXT NOT NULL DEFAULT (strftime('%Y-%m-%dT%H:%M:%fZ','now'))
);

CREATE TABLE stations (
  id             INTEGER PRIMARY KEY,
  code           TEXT NOT NULL UNIQUE,       -- station id used in observation files
  instrument_id  INTEGER REFERENCES instruments(id),
  description    TEXT
);

CREATE TABLE sessions (
  id           INTEGER PRIMARY KEY,
  robot_id     INTEGER NOT NULL REFERENCES robots(id),
  lab_yaml     TEXT,
  plan_json    TEXT,                        -- the configurations to measure, in order
  state        TEXT NOT NULL DEFAULT 'running' CHECK (state IN ('running','paused','completed','aborted')),
  note         TEXT,
  started_at   TEXT NOT NULL DEFAULT (strftime('%Y-%m-%dT%H:%M:%fZ','now')),
  finished_at  TEXT
);

-- Orientation results: one set-up per station and session (or standalone, session NULL).
CREATE TABLE station_setups (
  id            INTEGER PRIMARY KEY,
  station_id    INTEGER NOT NULL REFERENCES stations(id),
  session_id    INTEGER REFERENCES sessions(id),
  x_mm REAL NOT NULL, y_mm REAL NOT NULL, z_mm REAL NOT NULL,
  levelled      INTEGER NOT NULL CHECK (levelled IN (0,1)),
  azimuth_rad   REAL,                         -- levelled stations
  rotation_json TEXT,                         -- 3x3 row-major world_from_station otherwise
  sx_mm REAL, sy_mm REAL, sz_mm REAL, s_azimuth_rad REAL,
  sigma0        REAL,
  dof           INTEGER,
  method        TEXT,                         -- mutual+scale_bar, control, file
  sigma_hz_rad  REAL,                         -- the station's a-priori reading sigmas
  sigma_v_rad   REAL,
  created_at    TEXT NOT NULL DEFAULT (strftime('%Y-%m-%dT%H:%M:%fZ','now'))
);

-- Joint readings, one row per measured (or skipped) configuration of a session.
CREATE TABLE poses (
  id            INTEGER PRIMARY KEY,
  session_id    INTEGER NOT NULL REFERENCES sessions(id),
  seq           INTEGER NOT NULL,             -- index in the session's plan
  label         TEXT NOT NULL,                -- pose id in files
  joints_json   TEXT,                         -- encoder angles, rad, JSON array; NULL when skipped
  status        TEXT NOT NULL CHECK (status IN ('measured','skipped')),
  attempts      INTEGER NOT NULL DEFAULT 1,
  captured_at   TEXT NOT NULL DEFAULT (strftime('%Y-%m-%dT%H:%M:%fZ','now')),
  UNIQUE (session_id, seq)
);

-- Raw instrument readings exactly as observed.
CREATE TABLE observations (
  id                 INTEGER PRIMARY KEY,
  session_id         INTEGER REFERENCES sessions(id),
  pose_id            INTEGER REFERENCES poses(id),
  point              TEXT NOT NULL,           -- target point id (or a station id: mutual pointing)
  station_id         INTEGER NOT NULL REFERENCES stations(id),
  instrument_id      INTEGER REFERENCES instruments(id),
  hz_rad             REAL NOT NULL,
  v_rad              REAL NOT NULL,
  distance_mm        REAL,
  face               INTEGER NOT NULL DEFAULT 1 CHECK (face IN (1,2)),
  sigma_hz_arcsec    REAL,
  sigma_v_arcsec     REAL,
  sigma_distance_mm  REAL,
  return_code        INTEGER NOT NULL DEFAULT 0,  -- instrument return code (GeoCOM RC, 0 = OK)
  measured_at        TEXT NOT NULL DEFAULT (strftime('%Y-%m-%dT%H:%M:%fZ','now'))
);
CREATE INDEX observations_by_session ON observations(session_id, pose_id, point);

-- Reduced target coordinates with their precision.
CREATE TABLE points (
  id            INTEGER PRIMARY KEY,
  session_id    INTEGER REFERENCES sessions(id),
  pose_id       INTEGER REFERENCES poses(id),
  point         TEXT NOT NULL,
  x_mm REAL, y_mm REAL, z_mm REAL,              -- NULL when the point could not be reduced
  sx_mm REAL, sy_mm REAL, sz_mm REAL,
  covariance_json TEXT,                         -- 3x3 row-major, mm^2
  rays          INTEGER NOT NULL,
  rejected_rays INTEGER NOT NULL DEFAULT 0,
  sigma0        REAL,
  miss_mm       REAL,                           -- largest ray miss distance
  flags         TEXT NOT NULL DEFAULT '',       -- e.g. blunder_rejected, one_ray, parallel_rays
  reduced_at    TEXT NOT NULL DEFAULT (strftime('%Y-%m-%dT%H:%M:%fZ','now')),
  UNIQUE (session_id, pose_id, point)
);

-- Fitted parameter sets, versioned per robot.
CREATE TABLE calibrations (
  id               INTEGER PRIMARY KEY,
  robot_id         INTEGER NOT NULL REFERENCES robots(id),
  version          INTEGER NOT NULL,
  active           INTEGER NOT NULL DEFAULT 0 CHECK (active IN (0,1)),
  params_spec      TEXT NOT NULL,              -- geometric | all | list
  inputs_json      TEXT NOT NULL,              -- sources, pose counts, selection
  options_json     TEXT NOT NULL,
  rank             INTEGER NOT NULL,
  poses_fit        INTEGER NOT NULL,
  poses_validation INTEGER NOT NULL DEFAULT 0,
  nominal_mean_mm REAL, nominal_max_mm REAL, nominal_rms_mm REAL,
  fit_mean_mm REAL, fit_max_mm REAL, fit_rms_mm REAL,
  validation_mean_mm REAL, validation_max_mm REAL, validation_rms_mm REAL,
  report_json      TEXT,
  created_at       TEXT NOT NULL DEFAULT (strftime('%Y-%m-%dT%H:%M:%fZ','now')),
  UNIQUE (robot_id, version)
);

CREATE TABLE calibration_parameters (
  calibration_id  INTEGER NOT NULL REFERENCES calibrations(id) ON DELETE CASCADE,
  name            TEXT NOT NULL,
  value           REAL NOT NULL,              -- mm or rad
  unit            TEXT NOT NULL CHECK (unit IN ('mm','rad')),
  identified      INTEGER NOT NULL CHECK (identified IN (0,1)),
  sigma           REAL,
  PRIMARY KEY (calibration_id, name)
);

CREATE TABLE validation_residuals (
  id              INTEGER PRIMARY KEY,
  calibration_id  INTEGER NOT NULL REFERENCES calibrations(id) ON DELETE CASCADE,
  pose_id         INTEGER REFERENCES poses(id),
  pose_label      TEXT NOT NULL,
  role            TEXT NOT NULL CHECK (role IN ('fit','validation')),
  dx_mm REAL NOT NULL, dy_mm REAL NOT NULL, dz_mm REAL NOT NULL,
  distance_mm     REAL NOT NULL,
  nominal_distance_mm REAL
);
)sql";

// Schema v2: a parameter set's measuring frame in its own column (it lived inside
// report_json's "base"); existing sets get it from there.
constexpr std::string_view kSchemaV2 = R"sql(
ALTER TABLE calibrations ADD COLUMN world_from_base_json TEXT;  -- 4x4 row-major, world from robot base
UPDATE calibrations SET world_from_base_json = json_extract(report_json, '$.base')
  WHERE json_valid(report_json) AND json_type(report_json, '$.base') = 'array';
)sql";

// Schema v3: the covariance of a parameter set's identified parameters, so that the next
// set can be compared with it by propagated uncertainty (drift); NULL in older sets.
constexpr std::string_view kSchemaV3 = R"sql(
ALTER TABLE calibrations ADD COLUMN covariance_json TEXT;  -- {"parameters": [names], "matrix": [[…]]}, mm and rad
)sql";

// Schema v4: the life cycle's record. Every activation of a parameter set (who: the nightly
// job, `activate` or the demo; when; which set it replaced); each set's drift decision
// against the set that was active before it; and the process that runs a session (pid,
// host, start), so that a session left `running` by a killed process is told apart from a
// live capture. The set active at the migration gets an activation row by 'migration'.
constexpr std::string_view kSchemaV4 = R"sql(
CREATE TABLE activations (
  id                INTEGER PRIMARY KEY,
  robot_id          INTEGER NOT NULL REFERENCES robots(id),
  version           INTEGER NOT NULL,              -- the set made active
  previous_version  INTEGER,                       -- the set active before (NULL: none)
  activated_at      TEXT NOT NULL DEFAULT (strftime('%Y-%m-%dT%H:%M:%fZ','now')),
  activated_by      TEXT NOT NULL CHECK (activated_by IN ('recalibrate','activate','demo','migration')),
  note              TEXT
);
CREATE INDEX activations_by_robot ON activations(robot_id, id);
INSERT INTO activations(robot_id, version, activated_by, note)
  SELECT robot_id, version, 'migration',
         'active when the database was migrated to schema v4 (earlier activations were not recorded)'
  FROM calibrations WHERE active = 1 ORDER BY robot_id;
ALTER TABLE calibrations ADD COLUMN drift_json TEXT;  -- the drift decision against the set active before ({"flag", "against", …}); NULL when none was made
ALTER TABLE sessions ADD COLUMN owner_pid INTEGER;    -- the process running the session (capture, demo)
ALTER TABLE sessions ADD COLUMN owner_host TEXT;
ALTER TABLE sessions ADD COLUMN owner_started TEXT;   -- that process's start (boot id / start tick), against pid reuse
)sql";

// Schema v5: a parameter set may carry the residual map used with it, as JSON
// (io/residual_map_json.h); NULL for parametric sets.
constexpr std::string_view kSchemaV5 = R"sql(
ALTER TABLE calibrations ADD COLUMN residual_map_json TEXT;
)sql";

// Schema v6 (laser trackers): the air at the instrument with every reading (a
// laser tracker's weather station reports temperature, pressure and humidity with each
// result), for the record and for the recalibration report's error-against-temperature
// figure; NULL for readings without it (theodolites, older files).
constexpr std::string_view kSchemaV6 = R"sql(
ALTER TABLE observations ADD COLUMN temperature_c REAL;     -- deg C at the instrument
ALTER TABLE observations ADD COLUMN pressure_hpa REAL;      -- hPa
ALTER TABLE observations ADD COLUMN humidity_percent REAL;  -- % relative humidity
)sql";

// ---- Schema v7: the job queue of the nightly work. --------------------------
// Kept apart so that renumbering at a merge is moving this one entry: the DDL is
// db/jobs.cc's (the same text creates the table on PostgreSQL, EnsureJobsSchema).
constexpr int kJobsMigration = 7;  // the schema version that adds `jobs`
// --------------------------------------------------------------------------------------

// Schema v8 (`db push`): a session and a parameter set get a UUID the first time
// they are pushed to a central store, so that a second push (or one resumed after a cut
// connection) recognises what the server already holds; NULL until then.
constexpr std::string_view kSchemaV8 = R"sql(
ALTER TABLE sessions ADD COLUMN uuid TEXT;
CREATE UNIQUE INDEX sessions_by_uuid ON sessions(uuid);
ALTER TABLE calibrations ADD COLUMN uuid TEXT;
CREATE UNIQUE INDEX calibrations_by_uuid ON calibrations(uuid);
)sql";

// Schema v9 (the store on PostgreSQL): a parameter set's parameters keep the
// model's order in a column of their own (SQLite's rowid gave it, which PostgreSQL has not);
// existing rows get it from their rowid.
constexpr std::string_view kSchemaV9 = R"sql(
ALTER TABLE calibration_parameters ADD COLUMN seq INTEGER;  -- the parameter's place in the set (model order)
UPDATE calibration_parameters SET seq = rowid;
)sql";

// Schema v10 (`db push` carries the activation history): an activation gets a UUID the
// first time it is pushed, so a second push recognises it; NULL until then.
constexpr std::string_view kSchemaV10 = R"sql(
ALTER TABLE activations ADD COLUMN uuid TEXT;
CREATE UNIQUE INDEX activations_by_uuid ON activations(uuid);
)sql";

// Schema v11: a reading keeps the instrument's warning that came with it (GeoCOM 1283/1284:
// data valid, accuracy not guaranteed); `measured_at` and `instrument_id` are filled by the
// capture from then on (the time the instrument's answer arrived, the instrument as it
// identified itself).
constexpr std::string_view kSchemaV11 = R"sql(
ALTER TABLE observations ADD COLUMN note TEXT;  -- the instrument's warning with the reading
)sql";

// Schema v12 (6-DoF targets): a target point may carry its frame's measured orientation (a
// 6-DoF probe) as the angles rx, ry, rz of core/rotation.h, with their a-priori sigmas;
// NULL for position-only points. A parameter set fitted to orientations keeps the target's
// rotation in the last link frame; NULL for the others.
constexpr std::string_view kSchemaV12 = R"sql(
ALTER TABLE points ADD COLUMN rx_rad REAL;  -- world_from_target = Rx(rx)·Ry(ry)·Rz(rz)
ALTER TABLE points ADD COLUMN ry_rad REAL;
ALTER TABLE points ADD COLUMN rz_rad REAL;
ALTER TABLE points ADD COLUMN sigma_rx_rad REAL;  -- NULL: not given
ALTER TABLE points ADD COLUMN sigma_ry_rad REAL;
ALTER TABLE points ADD COLUMN sigma_rz_rad REAL;
ALTER TABLE calibrations ADD COLUMN tool_rotation_json TEXT;  -- 3x3 row-major, target in last link frame
)sql";

// Schema v13 (a signature that never makes the robot worse): every session has a kind —
// `calibration` (what the nightly job fits), `test` (an ISO 9283 test: measured to judge the
// robot, never fitted unless asked), `check` (measured to check a set where it was not
// fitted) — and every parameter set says where it holds (`validity_json`: the joint arcs
// its terms were fitted on, the calibration of its predicted σ on held-out regions).
constexpr std::string_view kSchemaV13 = R"sql(
ALTER TABLE sessions ADD COLUMN kind TEXT NOT NULL DEFAULT 'calibration' CHECK (kind IN ('calibration','test','check'));
ALTER TABLE calibrations ADD COLUMN validity_json TEXT;  -- {"term_arcs_rad": [[start, length]…], "sigma": {…}}; NULL before v13
)sql";

// Schema v14 (robot controllers that say who they are: Universal Robots, KUKA, ABB): a
// session keeps the controller as it identified itself when the session began (model,
// serial number, software) and the controller's own kinematics (UR KinematicsInfo: its
// checksum, and the DH table as JSON); the robot keeps the model and serial number of its
// first such session (a later session on a controller of another model or serial is
// refused) and the kinematics of its newest; a configuration keeps the controller's own time
// stamp of its joints. NULL where the controller cannot say (VAL, AS, counter boxes,
// imported poses).
constexpr std::string_view kSchemaV14 = R"sql(
ALTER TABLE sessions ADD COLUMN controller_model TEXT;     -- as the controller names the arm: UR10
ALTER TABLE sessions ADD COLUMN controller_serial TEXT;
ALTER TABLE sessions ADD COLUMN controller_software TEXT;  -- URSoftware 5.11.1.108318 (Nov 03 2021)
ALTER TABLE sessions ADD COLUMN kinematics_checksum TEXT;  -- the controller's own calibration (UR KinematicsInfo)
ALTER TABLE sessions ADD COLUMN kinematics_json TEXT;      -- {"checksum", "dh_theta_rad", "dh_a_mm", "dh_d_mm", "dh_alpha_rad", "calibration_status"}
ALTER TABLE robots ADD COLUMN controller_model TEXT;       -- the arm's identity: its first identified session's
ALTER TABLE robots ADD COLUMN controller_serial TEXT;
ALTER TABLE robots ADD COLUMN kinematics_checksum TEXT;    -- its newest session's
ALTER TABLE robots ADD COLUMN kinematics_json TEXT;
ALTER TABLE poses ADD COLUMN controller_time_s REAL;       -- the controller's clock when it gave the joints (UR RTDE timestamp, s since it started)
)sql";

// Schema v15 (the lab's round): a robot keeps its history when the lab reorganises. It can
// be renamed, removed (hidden, refused for new work, every row kept: `removed_at`) and brought
// back, and a session moved to another robot; each is a row of `robot_events`. A job counts
// its worker's heartbeats and keeps the lease its claimer asked for: a claimer judges a lease
// that looks expired (or impossibly far ahead) by whether the count still moves while it
// watches on its own monotonic clock, so a step of the clock neither hands a running job to
// a second worker nor strands a vanished worker's job.
constexpr std::string_view kSchemaV15 = R"sql(
ALTER TABLE robots ADD COLUMN removed_at TEXT;  -- `robot remove`: hidden, refused for new work, every row kept; NULL: in use
CREATE TABLE robot_events (
  id          INTEGER PRIMARY KEY,
  robot_id    INTEGER NOT NULL REFERENCES robots(id),
  event       TEXT NOT NULL CHECK (event IN ('renamed','removed','restored','session_moved_in','session_moved_out')),
  session_id  INTEGER REFERENCES sessions(id),  -- the session moved
  detail      TEXT NOT NULL,                    -- "renamed from ur10 to ur10-cell3", "session 4 moved in from puma"
  reason      TEXT,                             -- as given (--reason)
  at          TEXT NOT NULL DEFAULT (strftime('%Y-%m-%dT%H:%M:%fZ','now')),
  by_user     TEXT                              -- the user who ran the command
);
CREATE INDEX robot_events_by_robot ON robot_events(robot_id, id);
ALTER TABLE jobs ADD COLUMN heartbeats INTEGER NOT NULL DEFAULT 0;  -- the worker's heartbeats since its claim
ALTER TABLE jobs ADD COLUMN lease_ms INTEGER;                       -- the lease its claimer asked for
)sql";

constexpr std::string_view kSchemaV16 = R"sql(
-- Measuring on the move (`capture --on-the-move`): a sweep's raw streams, one segment (a run of
-- the plan's waypoints) per transaction, kept so the pairing can be done again.
CREATE TABLE stream_joints (
  id          INTEGER PRIMARY KEY,
  session_id  INTEGER NOT NULL REFERENCES sessions(id),
  segment     INTEGER NOT NULL,   -- the sweep's segment (0-based)
  t_s         REAL NOT NULL,      -- the controller's clock (UR RTDE timestamp)
  q_json      TEXT NOT NULL,      -- encoder angles, rad, JSON array
  qd_json     TEXT NOT NULL       -- their speeds, rad/s
);
CREATE INDEX stream_joints_by_session ON stream_joints(session_id, segment, t_s);
CREATE TABLE stream_points (
  id           INTEGER PRIMARY KEY,
  session_id   INTEGER NOT NULL REFERENCES sessions(id),
  segment      INTEGER NOT NULL,
  station_id   INTEGER NOT NULL REFERENCES stations(id),
  t_s          REAL NOT NULL,     -- the tracker's own clock
  hz_rad REAL NOT NULL, v_rad REAL NOT NULL, distance_mm REAL NOT NULL,
  status       INTEGER NOT NULL DEFAULT 0  -- the record's ES_MeasurementStatus
);
CREATE INDEX stream_points_by_session ON stream_points(session_id, segment, t_s);
-- What interrupted a stream (the beam broke), on the tracker's clock of the record before.
CREATE TABLE stream_events (
  id          INTEGER PRIMARY KEY,
  session_id  INTEGER NOT NULL REFERENCES sessions(id),
  segment     INTEGER NOT NULL,
  station_id  INTEGER NOT NULL REFERENCES stations(id),
  t_s         REAL NOT NULL,
  status      INTEGER NOT NULL,
  what        TEXT NOT NULL
);
-- A point paired from the streams carries the clock's share of its error (speed × σ_t), mm;
-- NULL for a point measured standing.
ALTER TABLE points ADD COLUMN sync_sigma_mm REAL;
-- The clock estimate of a session measured on the move (offset, drift, σ, what was left out).
ALTER TABLE sessions ADD COLUMN sync_json TEXT;
)sql";

// PostgreSQL's text of the migrations whose SQLite text does not translate word for word
// (PostgresDdl): v2 and v9 fill their new column from what only SQLite has (json_extract,
// rowid). A PostgreSQL store is created by an armsig of schema v9 or later, in one
// transaction from an empty database, so these tables are empty when the statements run.
constexpr std::string_view kSchemaV2Postgres = R"sql(
ALTER TABLE calibrations ADD COLUMN world_from_base_json TEXT;
)sql";
constexpr std::string_view kSchemaV9Postgres = R"sql(
ALTER TABLE calibration_parameters ADD COLUMN seq BIGINT;
)sql";

constexpr std::string_view kSqliteNow = "strftime('%Y-%m-%dT%H:%M:%fZ','now')";
constexpr std::string_view kPostgresNow =
    "to_char(now() AT TIME ZONE 'UTC', 'YYYY-MM-DD\"T\"HH24:MI:SS.MS\"Z\"')";

// Every table, in the order the schema versions added them: the first kTablesOfV1 are schema
// v1's (an armsig file from before application_id has at least those).
constexpr std::size_t kTablesOfV1 = 11;
constexpr std::array<std::string_view, 17> kTables = {"robots",
                                                      "instruments",
                                                      "stations",
                                                      "sessions",
                                                      "station_setups",
                                                      "poses",
                                                      "observations",
                                                      "points",
                                                      "calibrations",
                                                      "calibration_parameters",
                                                      "validation_residuals",
                                                      "activations",
                                                      "jobs",
                                                      "robot_events",
                                                      "stream_joints",
                                                      "stream_points",
                                                      "stream_events"};

}  // namespace

std::span<const std::string_view> Migrations() {
  static const std::string jobs = JobsSchemaSql(Backend::kSqlite);
  static const std::array<std::string_view, 16> migrations = [] {
    std::array<std::string_view, 16> m = {kSchemaV1,  kSchemaV2,  kSchemaV3,  kSchemaV4,
                                          kSchemaV5,  kSchemaV6,  {},         kSchemaV8,
                                          kSchemaV9,  kSchemaV10, kSchemaV11, kSchemaV12,
                                          kSchemaV13, kSchemaV14, kSchemaV15, kSchemaV16};
    m[kJobsMigration - 1] = jobs;
    return m;
  }();
  return migrations;
}

std::string PostgresDdl(std::string_view sqlite) {
  std::string out;
  out.reserve(sqlite.size() + 256);
  auto upper = [](char c) { return (c >= 'A' && c <= 'Z') || c == '_'; };
  size_t k = 0;
  while (k < sqlite.size()) {
    const char c = sqlite[k];
    if (c == '\'' || c == '"') {  // a quoted string or name, as it is
      const size_t end = sqlite.find(c, k + 1);
      const size_t stop = end == std::string_view::npos ? sqlite.size() : end + 1;
      out += sqlite.substr(k, stop - k);
      k = stop;
    } else if (c == '-' && k + 1 < sqlite.size() && sqlite[k + 1] == '-') {  // a comment
      const size_t end = sqlite.find('\n', k);
      const size_t stop = end == std::string_view::npos ? sqlite.size() : end;
      out += sqlite.substr(k, stop - k);
      k = stop;
    } else if (sqlite.substr(k).starts_with(kSqliteNow)) {
      out += kPostgresNow;
      k += kSqliteNow.size();
    } else if (upper(c) && (k == 0 || !upper(sqlite[k - 1]))) {
      size_t end = k;
      while (end < sqlite.size() && upper(sqlite[end])) ++end;
      const std::string_view word = sqlite.substr(k, end - k);
      constexpr std::string_view kRowidKey = "INTEGER PRIMARY KEY";
      if (sqlite.substr(k).starts_with(kRowidKey)) {
        out += "BIGINT GENERATED BY DEFAULT AS IDENTITY PRIMARY KEY";
        k += kRowidKey.size();
        continue;
      }
      if (word == "INTEGER")
        out += "BIGINT";
      else if (word == "REAL")
        out += "DOUBLE PRECISION";
      else
        out += word;
      k = end;
    } else {
      out += c;
      ++k;
    }
  }
  return out;
}

std::string MigrationSql(int from, Backend backend) {
  if (backend == Backend::kSqlite) return std::string(Migrations()[from]);
  switch (from + 1) {
    case 2: return std::string(kSchemaV2Postgres);
    case kJobsMigration: return JobsSchemaSql(Backend::kPostgres);
    case 9: return std::string(kSchemaV9Postgres);
    default: return PostgresDdl(Migrations()[from]);
  }
}

std::string_view NowIsoSql(Backend backend) {
  return backend == Backend::kSqlite ? kSqliteNow : kPostgresNow;
}
std::span<const std::string_view> TableNames() { return kTables; }
std::span<const std::string_view> LegacyTableNames() { return std::span(kTables).first(kTablesOfV1); }

}  // namespace armsig::db
