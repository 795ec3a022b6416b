#include "db/observations.h"

#include <cmath>
#include <cstdio>

#include "core/units.h"
#include "db/sql_util.h"

namespace armsig::db {

int64_t EnsureStation(Database& db, const std::string& code) {
  SQLite::Statement find(db.sql(), "SELECT id FROM stations WHERE code = ?");
  find.bind(1, code);
  if (find.executeStep()) return find.getColumn(0).getInt64();
  SQLite::Statement s(db.sql(), "INSERT INTO stations(code) VALUES (?)");
  s.bind(1, code);
  s.exec();
  return db.sql().getLastInsertRowid();
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
    r.sigma0 = OptionalDouble(s.getColumn(11));
    r.dof = s.getColumn(12).getInt();
    r.method = s.getColumn(13).getString();
    r.sigma_hz_rad = OptionalDouble(s.getColumn(14));
    r.sigma_v_rad = OptionalDouble(s.getColumn(15));
    out[r.station] = r;
  }
  return out;
}

void InsertObservations(Database& db, int64_t session_id, const std::vector<ObservationRow>& rows) {
  std::map<std::string, int64_t> station_ids;
  SQLite::Statement s(
      db.sql(),
      "INSERT INTO observations(session_id, pose_id, point, station_id, hz_rad, v_rad, "
      "distance_mm, face, sigma_hz_arcsec, sigma_v_arcsec, sigma_distance_mm, return_code, "
      "temperature_c, pressure_hpa, humidity_percent) VALUES (?,?,?,?,?,?,?,?,?,?,?,?,?,?,?)");
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
    BindOptional(s, 9,
                 r.sigma_hz_rad ? std::optional(*r.sigma_hz_rad / kRadPerArcsec) : std::nullopt);
    BindOptional(s, 10,
                 r.sigma_v_rad ? std::optional(*r.sigma_v_rad / kRadPerArcsec) : std::nullopt);
    BindOptional(s, 11, r.sigma_distance_mm);
    s.bind(12, r.return_code);
    BindOptional(s, 13, r.temperature_c);
    BindOptional(s, 14, r.pressure_hpa);
    BindOptional(s, 15, r.humidity_percent);
    s.exec();
  }
}

std::vector<ObservationRow> LoadObservations(Database& db, int64_t session_id) {
  std::vector<ObservationRow> out;
  SQLite::Statement s(
      db.sql(),
      "SELECT o.pose_id, o.point, st.code, o.hz_rad, o.v_rad, o.distance_mm, o.face, "
      "o.sigma_hz_arcsec, o.sigma_v_arcsec, o.sigma_distance_mm, o.return_code, "
      "o.temperature_c, o.pressure_hpa, o.humidity_percent "
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
    r.temperature_c = OptionalDouble(s.getColumn(11));
    r.pressure_hpa = OptionalDouble(s.getColumn(12));
    r.humidity_percent = OptionalDouble(s.getColumn(13));
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
    if (p.covariance_mm2.allFinite()) {
      for (int k = 0; k < 3; ++k) s.bind(7 + k, std::sqrt(p.covariance_mm2(k, k)));
      const Eigen::Matrix<double, 3, 3, Eigen::RowMajor> c = p.covariance_mm2;
      s.bind(10, JsonArray(c.data(), 9));
    } else {  // not known (poses imported from a file)
      for (int k = 7; k <= 10; ++k) s.bind(k);
    }
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

std::vector<PointRow> LoadPoints(Database& db, int64_t session_id) {
  SQLite::Statement q(db.sql(),
                      "SELECT pose_id, point, x_mm, y_mm, z_mm, coalesce(covariance_json, ''), "
                      "rays, rejected_rays, sigma0, miss_mm, flags FROM points "
                      "WHERE session_id = ? ORDER BY pose_id, point");
  q.bind(1, session_id);
  std::vector<PointRow> out;
  while (q.executeStep()) {
    PointRow p;
    if (!q.getColumn(0).isNull()) p.pose_id = q.getColumn(0).getInt64();
    p.point = q.getColumn(1).getString();
    if (!q.getColumn(2).isNull()) {
      p.position_mm = Eigen::Vector3d(q.getColumn(2).getDouble(), q.getColumn(3).getDouble(),
                                      q.getColumn(4).getDouble());
    }
    if (auto c = ParseCovariance(q.getColumn(5).getString())) p.covariance_mm2 = *c;
    p.rays = q.getColumn(6).getInt();
    p.rejected_rays = q.getColumn(7).getInt();
    if (!q.getColumn(8).isNull()) p.sigma0 = q.getColumn(8).getDouble();
    if (!q.getColumn(9).isNull()) p.miss_mm = q.getColumn(9).getDouble();
    p.flags = q.getColumn(10).getString();
    out.push_back(std::move(p));
  }
  return out;
}

void ReplacePoints(Database& db, int64_t session_id, const std::vector<PointRow>& points) {
  SQLite::Statement del(db.sql(), "DELETE FROM points WHERE session_id = ?");
  del.bind(1, session_id);
  del.exec();
  for (const auto& p : points) InsertPoint(db, session_id, p);
}

}  // namespace armsig::db
