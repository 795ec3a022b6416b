#include "db/store.h"

#include <cmath>
#include <cstdio>
#include <nlohmann/json.hpp>

#include "core/units.h"

namespace armsig::db {

namespace {

void BindOptional(SQLite::Statement& s, int index, double value) {
  if (std::isfinite(value))
    s.bind(index, value);
  else
    s.bind(index);
}

std::string JsonArray(const double* v, int n) {
  std::string out = "[";
  char buffer[32];
  for (int i = 0; i < n; ++i) {
    std::snprintf(buffer, sizeof buffer, "%s%.17g", i ? "," : "", v[i]);
    out += buffer;
  }
  return out + "]";
}

}  // namespace

int64_t EnsureRobot(Database& db, const std::string& name, const std::string& model_name,
                    const std::string& model_yaml) {
  if (auto id = FindRobot(db, name)) return *id;
  SQLite::Statement s(db.sql(), "INSERT INTO robots(name, model_name, model_yaml) VALUES (?,?,?)");
  s.bind(1, name);
  s.bind(2, model_name);
  s.bind(3, model_yaml);
  s.exec();
  return db.sql().getLastInsertRowid();
}

std::optional<int64_t> FindRobot(Database& db, const std::string& name) {
  SQLite::Statement s(db.sql(), "SELECT id FROM robots WHERE name = ?");
  s.bind(1, name);
  if (s.executeStep()) return s.getColumn(0).getInt64();
  return std::nullopt;
}

int64_t EnsureStation(Database& db, const std::string& code) {
  SQLite::Statement find(db.sql(), "SELECT id FROM stations WHERE code = ?");
  find.bind(1, code);
  if (find.executeStep()) return find.getColumn(0).getInt64();
  SQLite::Statement s(db.sql(), "INSERT INTO stations(code) VALUES (?)");
  s.bind(1, code);
  s.exec();
  return db.sql().getLastInsertRowid();
}

int64_t CreateSession(Database& db, int64_t robot_id, const std::string& lab_yaml,
                      const std::string& plan_json, const std::string& state,
                      const std::string& note) {
  SQLite::Statement s(
      db.sql(),
      "INSERT INTO sessions(robot_id, lab_yaml, plan_json, state, note) VALUES (?,?,?,?,?)");
  s.bind(1, robot_id);
  s.bind(2, lab_yaml);
  s.bind(3, plan_json);
  s.bind(4, state);
  s.bind(5, note);
  s.exec();
  return db.sql().getLastInsertRowid();
}

void SetSessionState(Database& db, int64_t session_id, const std::string& state) {
  SQLite::Statement s(
      db.sql(),
      "UPDATE sessions SET state = ?, finished_at = CASE WHEN ? IN ('completed','aborted') "
      "THEN strftime('%Y-%m-%dT%H:%M:%fZ','now') END WHERE id = ?");
  s.bind(1, state);
  s.bind(2, state);
  s.bind(3, session_id);
  s.exec();
}

std::vector<int64_t> SessionIds(Database& db) {
  std::vector<int64_t> out;
  SQLite::Statement s(db.sql(), "SELECT id FROM sessions ORDER BY id");
  while (s.executeStep()) out.push_back(s.getColumn(0).getInt64());
  return out;
}

bool SessionExists(Database& db, int64_t session_id) {
  SQLite::Statement s(db.sql(), "SELECT 1 FROM sessions WHERE id = ?");
  s.bind(1, session_id);
  return s.executeStep();
}

int64_t InsertStationSetup(Database& db, std::optional<int64_t> session_id,
                           const StationSetupRow& setup) {
  const int64_t station_id = EnsureStation(db, setup.station);
  SQLite::Statement s(
      db.sql(),
      "INSERT INTO station_setups(station_id, session_id, x_mm, y_mm, z_mm, levelled, "
      "azimuth_rad, rotation_json, sx_mm, sy_mm, sz_mm, s_azimuth_rad, sigma0, dof, method, "
      "sigma_hz_rad, sigma_v_rad) VALUES (?,?,?,?,?,?,?,?,?,?,?,?,?,?,?,?,?)");
  s.bind(1, station_id);
  if (session_id)
    s.bind(2, *session_id);
  else
    s.bind(2);
  for (int k = 0; k < 3; ++k) s.bind(3 + k, setup.pose.position_mm(k));
  s.bind(6, setup.pose.levelled ? 1 : 0);
  if (setup.pose.levelled) {
    s.bind(7, setup.pose.azimuth_rad);
    s.bind(8);
  } else {
    s.bind(7);
    const Eigen::Matrix<double, 3, 3, Eigen::RowMajor> r = setup.pose.world_from_station;
    s.bind(8, JsonArray(r.data(), 9));
  }
  for (int k = 0; k < 3; ++k) s.bind(9 + k, setup.sigma_position_mm(k));
  s.bind(12, setup.sigma_azimuth_rad);
  BindOptional(s, 13, setup.sigma0);
  s.bind(14, setup.dof);
  s.bind(15, setup.method);
  BindOptional(s, 16, setup.sigma_hz_rad);
  BindOptional(s, 17, setup.sigma_v_rad);
  s.exec();
  return db.sql().getLastInsertRowid();
}

std::map<std::string, StationSetupRow> LatestStationSetups(Database& db, int64_t session_id) {
  std::map<std::string, StationSetupRow> out;
  // Session-less set-ups first, then the session's own: later rows overwrite earlier.
  SQLite::Statement s(
      db.sql(),
      "SELECT st.code, x_mm, y_mm, z_mm, levelled, azimuth_rad, rotation_json, sx_mm, sy_mm, "
      "sz_mm, s_azimuth_rad, sigma0, dof, method, sigma_hz_rad, sigma_v_rad "
      "FROM station_setups su JOIN stations st ON st.id = su.station_id "
      "WHERE su.session_id = ? OR su.session_id IS NULL "
      "ORDER BY (su.session_id IS NOT NULL), su.id");
  s.bind(1, session_id);
  while (s.executeStep()) {
    StationSetupRow r;
    r.station = s.getColumn(0).getString();
    r.pose.id = r.station;
    r.pose.position_mm = {s.getColumn(1).getDouble(), s.getColumn(2).getDouble(),
                          s.getColumn(3).getDouble()};
    r.pose.levelled = s.getColumn(4).getInt() != 0;
    if (r.pose.levelled) {
      r.pose.azimuth_rad = s.getColumn(5).getDouble();
      r.pose.world_from_station =
          Eigen::AngleAxisd(-r.pose.azimuth_rad, Eigen::Vector3d::UnitZ()).toRotationMatrix();
    } else {
      const std::string json = s.getColumn(6).getString();
      double m[9];
      if (std::sscanf(json.c_str(), "[%lf,%lf,%lf,%lf,%lf,%lf,%lf,%lf,%lf]", &m[0], &m[1], &m[2],
                      &m[3], &m[4], &m[5], &m[6], &m[7], &m[8]) != 9) {
        throw std::runtime_error("station set-up of " + r.station + ": malformed rotation_json");
      }
      r.pose.world_from_station = Eigen::Map<Eigen::Matrix<double, 3, 3, Eigen::RowMajor>>(m);
    }
    r.sigma_position_mm = {s.getColumn(7).getDouble(), s.getColumn(8).getDouble(),
                           s.getColumn(9).getDouble()};
    r.sigma_azimuth_rad = s.getColumn(10).getDouble();
    r.sigma0 = s.getColumn(11).isNull() ? NAN : s.getColumn(11).getDouble();
    r.dof = s.getColumn(12).getInt();
    r.method = s.getColumn(13).getString();
    r.sigma_hz_rad = s.getColumn(14).isNull() ? NAN : s.getColumn(14).getDouble();
    r.sigma_v_rad = s.getColumn(15).isNull() ? NAN : s.getColumn(15).getDouble();
    out[r.station] = r;
  }
  return out;
}

int64_t InsertPose(Database& db, int64_t session_id, int seq, const std::string& label,
                   const std::optional<Eigen::VectorXd>& joints_rad, const std::string& status,
                   int attempts) {
  SQLite::Statement s(db.sql(),
                      "INSERT INTO poses(session_id, seq, label, joints_json, status, attempts) "
                      "VALUES (?,?,?,?,?,?)");
  s.bind(1, session_id);
  s.bind(2, seq);
  s.bind(3, label);
  if (joints_rad)
    s.bind(4, JsonArray(joints_rad->data(), static_cast<int>(joints_rad->size())));
  else
    s.bind(4);
  s.bind(5, status);
  s.bind(6, attempts);
  s.exec();
  return db.sql().getLastInsertRowid();
}

void InsertObservations(Database& db, int64_t session_id, const std::vector<ObservationRow>& rows) {
  std::map<std::string, int64_t> station_ids;
  SQLite::Statement s(
      db.sql(),
      "INSERT INTO observations(session_id, pose_id, point, station_id, hz_rad, v_rad, "
      "distance_mm, face, sigma_hz_arcsec, sigma_v_arcsec, sigma_distance_mm, return_code) "
      "VALUES (?,?,?,?,?,?,?,?,?,?,?,?)");
  for (const auto& r : rows) {
    auto it = station_ids.find(r.station);
    if (it == station_ids.end())
      it = station_ids.emplace(r.station, EnsureStation(db, r.station)).first;
    s.reset();
    s.bind(1, session_id);
    if (r.pose_id)
      s.bind(2, *r.pose_id);
    else
      s.bind(2);
    s.bind(3, r.point);
    s.bind(4, it->second);
    s.bind(5, r.reading.hz_rad);
    s.bind(6, r.reading.v_rad);
    if (r.distance_mm)
      s.bind(7, *r.distance_mm);
    else
      s.bind(7);
    s.bind(8, r.reading.face);
    BindOptional(s, 9, r.sigma_hz_rad / kRadPerArcsec);
    BindOptional(s, 10, r.sigma_v_rad / kRadPerArcsec);
    BindOptional(s, 11, r.sigma_distance_mm);
    s.bind(12, r.return_code);
    s.exec();
  }
}

std::vector<ObservationRow> LoadObservations(Database& db, int64_t session_id) {
  std::vector<ObservationRow> out;
  SQLite::Statement s(
      db.sql(),
      "SELECT o.pose_id, o.point, st.code, o.hz_rad, o.v_rad, o.distance_mm, o.face, "
      "o.sigma_hz_arcsec, o.sigma_v_arcsec, o.sigma_distance_mm, o.return_code "
      "FROM observations o JOIN stations st ON st.id = o.station_id "
      "WHERE o.session_id = ? ORDER BY o.pose_id, o.point, o.id");
  s.bind(1, session_id);
  while (s.executeStep()) {
    ObservationRow r;
    if (!s.getColumn(0).isNull()) r.pose_id = s.getColumn(0).getInt64();
    r.point = s.getColumn(1).getString();
    r.station = s.getColumn(2).getString();
    r.reading = {s.getColumn(3).getDouble(), s.getColumn(4).getDouble(), s.getColumn(6).getInt()};
    if (!s.getColumn(5).isNull()) r.distance_mm = s.getColumn(5).getDouble();
    if (!s.getColumn(7).isNull()) r.sigma_hz_rad = s.getColumn(7).getDouble() * kRadPerArcsec;
    if (!s.getColumn(8).isNull()) r.sigma_v_rad = s.getColumn(8).getDouble() * kRadPerArcsec;
    if (!s.getColumn(9).isNull()) r.sigma_distance_mm = s.getColumn(9).getDouble();
    r.return_code = s.getColumn(10).getInt();
    out.push_back(std::move(r));
  }
  return out;
}

void InsertPoint(Database& db, int64_t session_id, const PointRow& p) {
  SQLite::Statement s(
      db.sql(),
      "INSERT INTO points(session_id, pose_id, point, x_mm, y_mm, z_mm, sx_mm, sy_mm, "
      "sz_mm, covariance_json, rays, rejected_rays, sigma0, miss_mm, flags) "
      "VALUES (?,?,?,?,?,?,?,?,?,?,?,?,?,?,?)");
  s.bind(1, session_id);
  if (p.pose_id)
    s.bind(2, *p.pose_id);
  else
    s.bind(2);
  s.bind(3, p.point);
  if (p.position_mm) {
    for (int k = 0; k < 3; ++k) s.bind(4 + k, (*p.position_mm)(k));
    for (int k = 0; k < 3; ++k) s.bind(7 + k, std::sqrt(p.covariance_mm2(k, k)));
    const Eigen::Matrix<double, 3, 3, Eigen::RowMajor> c = p.covariance_mm2;
    s.bind(10, JsonArray(c.data(), 9));
  } else {
    for (int k = 4; k <= 10; ++k) s.bind(k);
  }
  s.bind(11, p.rays);
  s.bind(12, p.rejected_rays);
  BindOptional(s, 13, p.sigma0);
  BindOptional(s, 14, p.miss_mm);
  s.bind(15, p.flags);
  s.exec();
}

void ReplacePoints(Database& db, int64_t session_id, const std::vector<PointRow>& points) {
  SQLite::Statement del(db.sql(), "DELETE FROM points WHERE session_id = ?");
  del.bind(1, session_id);
  del.exec();
  for (const auto& p : points) InsertPoint(db, session_id, p);
}

}  // namespace armsig::db

namespace armsig::db {

std::optional<SessionRow> LoadSession(Database& db, int64_t session_id) {
  SQLite::Statement s(db.sql(),
                      "SELECT s.id, r.name, coalesce(s.lab_yaml,''), coalesce(s.plan_json,''), "
                      "s.state, coalesce(s.note,'') "
                      "FROM sessions s JOIN robots r ON r.id = s.robot_id WHERE s.id = ?");
  s.bind(1, session_id);
  if (!s.executeStep()) return std::nullopt;
  return SessionRow{s.getColumn(0).getInt64(),  s.getColumn(1).getString(),
                    s.getColumn(2).getString(), s.getColumn(3).getString(),
                    s.getColumn(4).getString(), s.getColumn(5).getString()};
}

std::vector<int> StoredSeqs(Database& db, int64_t session_id) {
  std::vector<int> out;
  SQLite::Statement s(db.sql(), "SELECT seq FROM poses WHERE session_id = ? ORDER BY seq");
  s.bind(1, session_id);
  while (s.executeStep()) out.push_back(s.getColumn(0).getInt());
  return out;
}

}  // namespace armsig::db

namespace armsig::db {

std::pair<int64_t, int> InsertCalibration(Database& db, const CalibrationRecord& c) {
  SQLite::Statement next(
      db.sql(), "SELECT coalesce(max(version), 0) + 1 FROM calibrations WHERE robot_id = ?");
  next.bind(1, c.robot_id);
  next.executeStep();
  const int version = next.getColumn(0).getInt();
  if (c.active) {
    SQLite::Statement off(db.sql(), "UPDATE calibrations SET active = 0 WHERE robot_id = ?");
    off.bind(1, c.robot_id);
    off.exec();
  }
  SQLite::Statement s(
      db.sql(),
      "INSERT INTO calibrations(robot_id, version, active, params_spec, inputs_json, options_json, "
      "rank, "
      "poses_fit, poses_validation, nominal_mean_mm, nominal_max_mm, nominal_rms_mm, fit_mean_mm, "
      "fit_max_mm, fit_rms_mm, validation_mean_mm, validation_max_mm, validation_rms_mm, "
      "report_json) "
      "VALUES (?,?,?,?,?,?,?,?,?,?,?,?,?,?,?,?,?,?,?)");
  s.bind(1, c.robot_id);
  s.bind(2, version);
  s.bind(3, c.active ? 1 : 0);
  s.bind(4, c.params_spec);
  s.bind(5, c.inputs_json);
  s.bind(6, c.options_json);
  s.bind(7, c.rank);
  s.bind(8, c.poses_fit);
  s.bind(9, c.poses_validation);
  const double stats[9] = {c.nominal_mean_mm,    c.nominal_max_mm,    c.nominal_rms_mm,
                           c.fit_mean_mm,        c.fit_max_mm,        c.fit_rms_mm,
                           c.validation_mean_mm, c.validation_max_mm, c.validation_rms_mm};
  for (int k = 0; k < 9; ++k) BindOptional(s, 10 + k, stats[k]);
  s.bind(19, c.report_json);
  s.exec();
  const int64_t id = db.sql().getLastInsertRowid();
  SQLite::Statement p(db.sql(),
                      "INSERT INTO calibration_parameters(calibration_id, name, value, unit, "
                      "identified, sigma) VALUES (?,?,?,?,?,?)");
  for (const auto& param : c.parameters) {
    p.reset();
    p.bind(1, id);
    p.bind(2, param.name);
    p.bind(3, param.value);
    p.bind(4, param.unit);
    p.bind(5, param.identified ? 1 : 0);
    BindOptional(p, 6, param.sigma);
    p.exec();
  }
  SQLite::Statement r(db.sql(),
                      "INSERT INTO validation_residuals(calibration_id, pose_label, role, dx_mm, "
                      "dy_mm, dz_mm, distance_mm, "
                      "nominal_distance_mm) VALUES (?,?,?,?,?,?,?,?)");
  for (const auto& res : c.residuals) {
    r.reset();
    r.bind(1, id);
    r.bind(2, res.pose_label);
    r.bind(3, res.role);
    r.bind(4, res.error_mm.x());
    r.bind(5, res.error_mm.y());
    r.bind(6, res.error_mm.z());
    r.bind(7, res.error_mm.norm());
    BindOptional(r, 8, res.nominal_distance_mm);
    r.exec();
  }
  return {id, version};
}

}  // namespace armsig::db

namespace armsig::db {

std::vector<MeasuredPose> LoadRobotPoses(Database& db, int64_t robot_id, const std::string& since,
                                         int64_t* max_pose_row) {
  SQLite::Statement q(
      db.sql(),
      "SELECT s.id, p.label, p.joints_json, pt.x_mm, pt.y_mm, pt.z_mm, p.id FROM poses p "
      "JOIN sessions s ON s.id = p.session_id JOIN points pt ON pt.pose_id = p.id "
      "WHERE s.robot_id = ? AND p.status = 'measured' AND pt.x_mm IS NOT NULL "
      "AND p.joints_json IS NOT NULL AND (? = '' OR s.started_at >= ?) ORDER BY p.id");
  q.bind(1, robot_id);
  q.bind(2, since);
  q.bind(3, since);
  std::vector<MeasuredPose> out;
  int64_t newest = 0;
  while (q.executeStep()) {
    MeasuredPose pose;
    pose.id = std::to_string(q.getColumn(0).getInt64()) + ":" + q.getColumn(1).getString();
    const auto joints =
        nlohmann::json::parse(q.getColumn(2).getString()).get<std::vector<double>>();
    pose.joints_rad = Eigen::Map<const Eigen::VectorXd>(joints.data(), joints.size());
    pose.target_in_world = {q.getColumn(3).getDouble(), q.getColumn(4).getDouble(),
                            q.getColumn(5).getDouble()};
    newest = std::max<int64_t>(newest, q.getColumn(6).getInt64());
    out.push_back(std::move(pose));
  }
  if (max_pose_row) *max_pose_row = newest;
  return out;
}

std::vector<StoredCalibration> CalibrationHistory(Database& db, int64_t robot_id) {
  std::vector<StoredCalibration> out;
  SQLite::Statement q(
      db.sql(),
      "SELECT id, version, active, created_at, params_spec, inputs_json, coalesce(report_json,''), "
      "validation_mean_mm, validation_max_mm FROM calibrations WHERE robot_id = ? ORDER BY "
      "version");
  q.bind(1, robot_id);
  while (q.executeStep()) {
    StoredCalibration c;
    c.id = q.getColumn(0).getInt64();
    c.version = q.getColumn(1).getInt();
    c.active = q.getColumn(2).getInt() != 0;
    c.created_at = q.getColumn(3).getString();
    c.params_spec = q.getColumn(4).getString();
    c.inputs_json = q.getColumn(5).getString();
    c.report_json = q.getColumn(6).getString();
    if (!q.getColumn(7).isNull()) c.validation_mean_mm = q.getColumn(7).getDouble();
    if (!q.getColumn(8).isNull()) c.validation_max_mm = q.getColumn(8).getDouble();
    SQLite::Statement p(db.sql(),
                        "SELECT name, value, unit, identified, sigma FROM calibration_parameters "
                        "WHERE calibration_id = ? "
                        "ORDER BY rowid");
    p.bind(1, c.id);
    while (p.executeStep()) {
      CalibrationRecord::Parameter param;
      param.name = p.getColumn(0).getString();
      param.value = p.getColumn(1).getDouble();
      param.unit = p.getColumn(2).getString();
      param.identified = p.getColumn(3).getInt() != 0;
      param.sigma = p.getColumn(4).isNull() ? NAN : p.getColumn(4).getDouble();
      c.parameters.push_back(param);
    }
    out.push_back(std::move(c));
  }
  return out;
}

std::optional<StoredCalibration> ActiveCalibration(Database& db, int64_t robot_id) {
  for (auto& c : CalibrationHistory(db, robot_id)) {
    if (c.active) return c;
  }
  return std::nullopt;
}

std::vector<MeasuredPose> LoadSessionPoses(Database& db, int64_t session_id,
                                           std::vector<Eigen::Matrix3d>* covariances) {
  SQLite::Statement q(
      db.sql(),
      "SELECT p.label, p.joints_json, pt.x_mm, pt.y_mm, pt.z_mm, "
      "coalesce(pt.covariance_json, '') FROM poses p JOIN points pt ON pt.pose_id = p.id "
      "WHERE p.session_id = ? AND pt.x_mm IS NOT NULL AND p.joints_json IS NOT NULL "
      "ORDER BY p.seq");
  q.bind(1, session_id);
  std::vector<MeasuredPose> out;
  while (q.executeStep()) {
    MeasuredPose pose;
    pose.id = q.getColumn(0).getString();
    const auto joints =
        nlohmann::json::parse(q.getColumn(1).getString()).get<std::vector<double>>();
    pose.joints_rad = Eigen::Map<const Eigen::VectorXd>(joints.data(), joints.size());
    pose.target_in_world = {q.getColumn(2).getDouble(), q.getColumn(3).getDouble(),
                            q.getColumn(4).getDouble()};
    if (covariances) {
      Eigen::Matrix3d c = Eigen::Matrix3d::Constant(NAN);
      const std::string text = q.getColumn(5).getString();
      if (!text.empty()) {
        const auto v = nlohmann::json::parse(text).get<std::vector<double>>();
        c = Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>>(v.data());
      }
      covariances->push_back(c);
    }
    out.push_back(std::move(pose));
  }
  return out;
}

std::string RobotModelYaml(Database& db, int64_t robot_id) {
  SQLite::Statement q(db.sql(), "SELECT model_yaml FROM robots WHERE id = ?");
  q.bind(1, robot_id);
  return q.executeStep() ? q.getColumn(0).getString() : std::string();
}

}  // namespace armsig::db
