#include "db/observations.h"

#include <fmt/chrono.h>
#include <fmt/format.h>

#include <cmath>
#include <cstdio>

#include "core/units.h"
#include "db/schema.h"
#include "db/sql_util.h"

namespace armsig::db {

int64_t EnsureStation(Database& db, const std::string& code) {
  auto find = Sql(db, "SELECT id FROM stations WHERE code = ?");
  find->Bind(1, code);
  if (find->Step()) return find->Int(0);
  // Captures on several machines naming one new station at once: the second waits for the
  // first's commit (PostgreSQL) or its turn (SQLite), then finds it.
  auto s = Sql(db, "INSERT INTO stations(code) VALUES (?) ON CONFLICT (code) DO NOTHING");
  s->Bind(1, code);
  s->Execute();
  find->Bind(1, code);
  if (find->Step()) return find->Int(0);
  throw DatabaseError(db.path() + ": station " + code + " was neither stored nor found", "",
                      false);
}

int64_t EnsureInstrument(Database& db, const InstrumentRow& i) {
  auto find = Sql(db, "SELECT id, port, firmware FROM instruments WHERE name = ?");
  find->Bind(1, i.name);
  if (find->Step()) {
    const int64_t id = find->Int(0);
    if (find->Text(1) != i.port || find->Text(2) != i.firmware) {
      auto update = Sql(db, "UPDATE instruments SET port = ?, firmware = ? WHERE id = ?");
      update->Bind(1, i.port);
      update->Bind(2, i.firmware);
      update->Bind(3, id);
      update->Execute();
    }
    return id;
  }
  auto s = Sql(db,
               "INSERT INTO instruments(name, kind, protocol, port, serial_number, firmware, "
               "sigma_hz_arcsec, sigma_v_arcsec, sigma_distance_mm) VALUES (?,?,?,?,?,?,?,?,?) "
               "ON CONFLICT (name) DO NOTHING");
  s->Bind(1, i.name);
  s->Bind(2, i.kind);
  s->Bind(3, i.protocol);
  s->Bind(4, i.port);
  s->Bind(5, i.serial_number);
  s->Bind(6, i.firmware);
  s->Bind(7, i.sigma_hz_arcsec);
  s->Bind(8, i.sigma_v_arcsec);
  s->Bind(9, i.sigma_distance_mm);
  s->Execute();
  find->Bind(1, i.name);
  if (find->Step()) return find->Int(0);
  throw DatabaseError(db.path() + ": instrument " + i.name + " was neither stored nor found", "",
                      false);
}

int64_t InsertStationSetup(Database& db, std::optional<int64_t> session_id,
                           const StationSetupRow& setup) {
  const int64_t station_id = EnsureStation(db, setup.station);
  auto s = Sql(
      db,
      "INSERT INTO station_setups(station_id, session_id, x_mm, y_mm, z_mm, levelled, "
      "azimuth_rad, rotation_json, sx_mm, sy_mm, sz_mm, s_azimuth_rad, sigma0, dof, method, "
      "sigma_hz_rad, sigma_v_rad) VALUES (?,?,?,?,?,?,?,?,?,?,?,?,?,?,?,?,?) RETURNING id");
  s->Bind(1, station_id);
  if (session_id)
    s->Bind(2, *session_id);
  else
    s->BindNull(2);
  for (int k = 0; k < 3; ++k) s->Bind(3 + k, setup.pose.position_mm(k));
  s->Bind(6, setup.pose.levelled ? 1 : 0);
  if (setup.pose.levelled) {
    s->Bind(7, setup.pose.azimuth_rad);
    s->BindNull(8);
  } else {
    s->BindNull(7);
    const Eigen::Matrix<double, 3, 3, Eigen::RowMajor> r = setup.pose.world_from_station;
    s->Bind(8, JsonArray(r.data(), 9));
  }
  for (int k = 0; k < 3; ++k) s->Bind(9 + k, setup.sigma_position_mm(k));
  s->Bind(12, setup.sigma_azimuth_rad);
  s->Bind(13, setup.sigma0);
  s->Bind(14, setup.dof);
  s->Bind(15, setup.method);
  s->Bind(16, setup.sigma_hz_rad);
  s->Bind(17, setup.sigma_v_rad);
  return InsertedId(*s, db.path() + ": a station set-up");
}

std::map<std::string, StationSetupRow> LatestStationSetups(Database& db, int64_t session_id) {
  std::map<std::string, StationSetupRow> out;
  // Session-less set-ups first, then the session's own: later rows overwrite earlier.
  auto s =
      Sql(db,
          "SELECT st.code, x_mm, y_mm, z_mm, levelled, azimuth_rad, rotation_json, sx_mm, sy_mm, "
          "sz_mm, s_azimuth_rad, sigma0, dof, method, sigma_hz_rad, sigma_v_rad, su.id "
          "FROM station_setups su JOIN stations st ON st.id = su.station_id "
          "WHERE su.session_id = ? OR su.session_id IS NULL "
          "ORDER BY (su.session_id IS NOT NULL), su.id");
  s->Bind(1, session_id);
  while (s->Step()) {
    StationSetupRow r;
    r.station = s->Text(0);
    r.pose.id = r.station;
    r.pose.position_mm = {s->Double(1), s->Double(2),
                          s->Double(3)};
    r.pose.levelled = static_cast<int>(s->Int(4)) != 0;
    if (r.pose.levelled) {
      r.pose.azimuth_rad = s->Double(5);
      r.pose.world_from_station =
          Eigen::AngleAxisd(-r.pose.azimuth_rad, Eigen::Vector3d::UnitZ()).toRotationMatrix();
    } else {
      // Written as nine numbers (JsonArray), the same shape as a point's covariance.
      const auto m =
          ParseMatrix3(s->Text(6), {db.path(), "station_setups", s->Int(16), "rotation_json"});
      if (!m)
        RefuseStoredJson({db.path(), "station_setups", s->Int(16), "rotation_json"},
                         "expected nine numbers (a rotation of a station not levelled)");
      r.pose.world_from_station = *m;
    }
    r.sigma_position_mm = {s->Double(7), s->Double(8),
                           s->Double(9)};
    r.sigma_azimuth_rad = s->Double(10);
    r.sigma0 = s->OptionalDouble(11);
    r.dof = static_cast<int>(s->Int(12));
    r.method = s->Text(13);
    r.sigma_hz_rad = s->OptionalDouble(14);
    r.sigma_v_rad = s->OptionalDouble(15);
    out[r.station] = r;
  }
  return out;
}

std::string MeasuredAt(std::chrono::system_clock::time_point time) {
  const auto ms = std::chrono::floor<std::chrono::milliseconds>(time);
  const auto seconds = std::chrono::floor<std::chrono::seconds>(ms);
  return fmt::format("{:%Y-%m-%dT%H:%M:%S}.{:03d}Z", seconds,
                     static_cast<int>((ms - seconds).count()));
}

void InsertObservations(Database& db, int64_t session_id, const std::vector<ObservationRow>& rows) {
  std::map<std::string, int64_t> station_ids;
  auto s = Sql(
      db,
      "INSERT INTO observations(session_id, pose_id, point, station_id, hz_rad, v_rad, "
      "distance_mm, face, sigma_hz_arcsec, sigma_v_arcsec, sigma_distance_mm, return_code, "
      "temperature_c, pressure_hpa, humidity_percent, measured_at, note, instrument_id) "
      "VALUES (?,?,?,?,?,?,?,?,?,?,?,?,?,?,?,COALESCE(?," +
          std::string(NowIsoSql(db.backend())) + "),?,?)");
  for (const auto& r : rows) {
    auto it = station_ids.find(r.station);
    if (it == station_ids.end())
      it = station_ids.emplace(r.station, EnsureStation(db, r.station)).first;
    s->Bind(1, session_id);
    if (r.pose_id)
      s->Bind(2, *r.pose_id);
    else
      s->BindNull(2);
    s->Bind(3, r.point);
    s->Bind(4, it->second);
    s->Bind(5, r.reading.hz_rad);
    s->Bind(6, r.reading.v_rad);
    if (r.distance_mm)
      s->Bind(7, *r.distance_mm);
    else
      s->BindNull(7);
    s->Bind(8, r.reading.face);
    s->Bind(9,
                 r.sigma_hz_rad ? std::optional(*r.sigma_hz_rad / kRadPerArcsec) : std::nullopt);
    s->Bind(10,
                 r.sigma_v_rad ? std::optional(*r.sigma_v_rad / kRadPerArcsec) : std::nullopt);
    s->Bind(11, r.sigma_distance_mm);
    s->Bind(12, r.return_code);
    s->Bind(13, r.temperature_c);
    s->Bind(14, r.pressure_hpa);
    s->Bind(15, r.humidity_percent);
    if (r.measured_at)
      s->Bind(16, *r.measured_at);
    else
      s->BindNull(16);
    if (r.note.empty())
      s->BindNull(17);
    else
      s->Bind(17, r.note);
    if (r.instrument_id)
      s->Bind(18, *r.instrument_id);
    else
      s->BindNull(18);
    s->Execute();
  }
}

std::vector<ObservationRow> LoadObservations(Database& db, int64_t session_id) {
  std::vector<ObservationRow> out;
  auto s = Sql(
      db,
      "SELECT o.pose_id, o.point, st.code, o.hz_rad, o.v_rad, o.distance_mm, o.face, "
      "o.sigma_hz_arcsec, o.sigma_v_arcsec, o.sigma_distance_mm, o.return_code, "
      "o.temperature_c, o.pressure_hpa, o.humidity_percent, o.measured_at, o.note, "
      "o.instrument_id "
      "FROM observations o JOIN stations st ON st.id = o.station_id "
      "WHERE o.session_id = ? ORDER BY o.pose_id, o.point, o.id");
  s->Bind(1, session_id);
  while (s->Step()) {
    ObservationRow r;
    if (!s->IsNull(0)) r.pose_id = s->Int(0);
    r.point = s->Text(1);
    r.station = s->Text(2);
    r.reading = {s->Double(3), s->Double(4), static_cast<int>(s->Int(6))};
    if (!s->IsNull(5)) r.distance_mm = s->Double(5);
    if (!s->IsNull(7)) r.sigma_hz_rad = s->Double(7) * kRadPerArcsec;
    if (!s->IsNull(8)) r.sigma_v_rad = s->Double(8) * kRadPerArcsec;
    if (!s->IsNull(9)) r.sigma_distance_mm = s->Double(9);
    r.return_code = static_cast<int>(s->Int(10));
    r.temperature_c = s->OptionalDouble(11);
    r.pressure_hpa = s->OptionalDouble(12);
    r.humidity_percent = s->OptionalDouble(13);
    r.measured_at = s->Text(14);
    if (!s->IsNull(15)) r.note = s->Text(15);
    if (!s->IsNull(16)) r.instrument_id = s->Int(16);
    out.push_back(std::move(r));
  }
  return out;
}

void InsertPoint(Database& db, int64_t session_id, const PointRow& p) {
  auto s = Sql(
      db,
      std::string("INSERT INTO points(session_id, pose_id, point, x_mm, y_mm, z_mm, sx_mm, "
                  "sy_mm, sz_mm, covariance_json, rays, rejected_rays, sigma0, miss_mm, flags, ") +
          kOrientationColumns + ", sync_sigma_mm) VALUES (?,?,?,?,?,?,?,?,?,?,?,?,?,?,?,?,?,?,?,?,?,?)");
  s->Bind(1, session_id);
  if (p.pose_id)
    s->Bind(2, *p.pose_id);
  else
    s->BindNull(2);
  s->Bind(3, p.point);
  if (p.position_mm) {
    for (int k = 0; k < 3; ++k) s->Bind(4 + k, (*p.position_mm)(k));
    if (p.covariance_mm2.allFinite()) {
      for (int k = 0; k < 3; ++k) s->Bind(7 + k, std::sqrt(p.covariance_mm2(k, k)));
      const Eigen::Matrix<double, 3, 3, Eigen::RowMajor> c = p.covariance_mm2;
      s->Bind(10, JsonArray(c.data(), 9));
    } else {  // not known (poses imported from a file)
      for (int k = 7; k <= 10; ++k) s->BindNull(k);
    }
  } else {
    for (int k = 4; k <= 10; ++k) s->BindNull(k);
  }
  s->Bind(11, p.rays);
  s->Bind(12, p.rejected_rays);
  s->Bind(13, p.sigma0);
  s->Bind(14, p.miss_mm);
  s->Bind(15, p.flags);
  BindOrientation(*s, 16, p.orientation);
  s->Bind(22, p.sync_sigma_mm);
  s->Execute();
}

std::vector<PointRow> LoadPoints(Database& db, int64_t session_id) {
  auto q = Sql(db,
               std::string("SELECT pose_id, point, x_mm, y_mm, z_mm, "
                           "coalesce(covariance_json, ''), rays, rejected_rays, sigma0, miss_mm, "
                           "flags, id, ") +
                   kOrientationColumns +
                   ", sync_sigma_mm FROM points WHERE session_id = ? ORDER BY pose_id, point");
  q->Bind(1, session_id);
  std::vector<PointRow> out;
  while (q->Step()) {
    PointRow p;
    if (!q->IsNull(0)) p.pose_id = q->Int(0);
    p.point = q->Text(1);
    if (!q->IsNull(2)) {
      p.position_mm = Eigen::Vector3d(q->Double(2), q->Double(3),
                                      q->Double(4));
    }
    if (auto c = ParseMatrix3(q->Text(5), {db.path(), "points", q->Int(11), "covariance_json"}))
      p.covariance_mm2 = *c;
    p.rays = static_cast<int>(q->Int(6));
    p.rejected_rays = static_cast<int>(q->Int(7));
    if (!q->IsNull(8)) p.sigma0 = q->Double(8);
    if (!q->IsNull(9)) p.miss_mm = q->Double(9);
    p.flags = q->Text(10);
    p.orientation = OrientationAt(*q, 12, {db.path(), "points", q->Int(11), "rx_rad"});
    if (!q->IsNull(18)) p.sync_sigma_mm = q->Double(18);
    out.push_back(std::move(p));
  }
  return out;
}

void ReplacePoints(Database& db, int64_t session_id, const std::vector<PointRow>& points) {
  auto del = Sql(db, "DELETE FROM points WHERE session_id = ?");
  del->Bind(1, session_id);
  del->Execute();
  for (const auto& p : points) InsertPoint(db, session_id, p);
}

SessionRowsMark MarkSessionRows(Database& db, int64_t session_id) {
  auto q = Sql(db,
               "SELECT (SELECT count(*) FROM observations WHERE session_id = ?1), "
               "(SELECT coalesce(max(id), 0) FROM observations WHERE session_id = ?1), "
               "(SELECT count(*) FROM station_setups WHERE session_id = ?1), "
               "(SELECT coalesce(max(id), 0) FROM station_setups WHERE session_id = ?1), "
               "(SELECT count(*) FROM points WHERE session_id = ?1), "
               "(SELECT coalesce(max(id), 0) FROM points WHERE session_id = ?1)");
  q->Bind(1, session_id);
  SessionRowsMark mark;
  if (q->Step()) {
    mark = {q->Int(0), q->Int(1), q->Int(2), q->Int(3), q->Int(4), q->Int(5)};
  }
  return mark;
}

}  // namespace armsig::db
