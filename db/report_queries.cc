#include "db/report_queries.h"

#include <algorithm>

#include "db/sql_util.h"

namespace armsig::db {

std::vector<ReportSession> LoadReportSessions(Database& db,
                                                const std::vector<int64_t>& session_ids) {
  std::vector<ReportSession> out;
  for (int64_t id : session_ids) {
    if (auto s = LoadSession(db, id)) out.push_back(std::move(*s));
  }
  std::sort(out.begin(), out.end(), [](const auto& a, const auto& b) { return a.id < b.id; });
  return out;
}

std::map<std::string, double> PoseTemperatures(Database& db,
                                               const std::vector<int64_t>& session_ids) {
  std::map<std::string, double> out;
  auto q = Sql(db,
                      "SELECT p.label, avg(o.temperature_c) FROM observations o JOIN poses p ON "
                      "p.id = o.pose_id WHERE o.session_id = ? AND o.temperature_c IS NOT NULL "
                      "GROUP BY p.id");
  for (int64_t id : session_ids) {
    q->Bind(1, id);
    while (q->Step()) {
      out[std::to_string(id) + ":" + q->Text(0)] = q->Double(1);
    }
  }
  return out;
}

std::vector<InstrumentSummary> SessionInstruments(Database& db, int64_t session_id) {
  std::vector<InstrumentSummary> out;
  auto q = Sql(db,
      "SELECT name, kind, protocol, coalesce(serial_number, ''), coalesce(firmware, ''), "
      "sigma_hz_arcsec, sigma_v_arcsec, sigma_distance_mm FROM instruments WHERE id IN ("
      "SELECT instrument_id FROM observations WHERE session_id = ?1 UNION "
      "SELECT st.instrument_id FROM stations st JOIN observations o ON o.station_id = st.id "
      "WHERE o.session_id = ?1 UNION "
      "SELECT st.instrument_id FROM stations st JOIN station_setups su ON su.station_id = st.id "
      "WHERE su.session_id = ?1) ORDER BY name");  // ?1: one parameter, three places
  q->Bind(1, session_id);
  auto optional = [&](int column) { return q->OptionalDouble(column); };
  while (q->Step()) {
    InstrumentSummary i;
    i.name = q->Text(0);
    i.kind = q->Text(1);
    i.protocol = q->Text(2);
    i.serial_number = q->Text(3);
    i.firmware = q->Text(4);
    i.sigma_hz_arcsec = optional(5);
    i.sigma_v_arcsec = optional(6);
    i.sigma_distance_mm = optional(7);
    out.push_back(std::move(i));
  }
  auto at = Sql(db,
      "SELECT i.name, st.code FROM observations o JOIN stations st ON st.id = o.station_id "
      "JOIN instruments i ON i.id = coalesce(o.instrument_id, st.instrument_id) "
      "WHERE o.session_id = ?1 UNION "
      "SELECT i.name, st.code FROM station_setups su JOIN stations st ON st.id = su.station_id "
      "JOIN instruments i ON i.id = st.instrument_id WHERE su.session_id = ?1 ORDER BY 1, 2");
  at->Bind(1, session_id);
  while (at->Step()) {
    const std::string name = at->Text(0);
    for (auto& i : out) {
      if (i.name == name) i.stations.push_back(at->Text(1));
    }
  }
  return out;
}

std::vector<StoredResidual> LoadStoredResiduals(Database& db, int64_t calibration_id) {
  auto q = db.connection().Prepare(
      "SELECT pose_label, role, dx_mm, dy_mm, dz_mm, distance_mm, nominal_distance_mm FROM "
      "validation_residuals WHERE calibration_id = ? ORDER BY id");
  q->Bind(1, calibration_id);
  std::vector<StoredResidual> out;
  while (q->Step()) {
    StoredResidual r;
    r.pose_label = q->Text(0);
    r.role = q->Text(1);
    r.dx_mm = q->Double(2);
    r.dy_mm = q->Double(3);
    r.dz_mm = q->Double(4);
    r.distance_mm = q->Double(5);
    if (!q->IsNull(6)) r.nominal_distance_mm = q->Double(6);
    out.push_back(std::move(r));
  }
  return out;
}

}  // namespace armsig::db
