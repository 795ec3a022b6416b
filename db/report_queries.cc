#include "db/report_queries.h"

#include <SQLiteCpp/Statement.h>

#include <algorithm>

#include "db/sql_util.h"

namespace armsig::db {

std::vector<ReportSession> LoadSessionSummaries(Database& db,
                                                const std::vector<int64_t>& session_ids) {
  std::vector<ReportSession> out;
  SQLite::Statement q(
      db.sql(),
      "SELECT id, started_at, coalesce(finished_at, ''), state, coalesce(note, ''), "
      "coalesce(lab_yaml, '') FROM sessions WHERE id = ?");
  for (int64_t id : session_ids) {
    q.reset();
    q.bind(1, id);
    if (!q.executeStep()) continue;
    ReportSession s;
    s.id = q.getColumn(0).getInt64();
    s.started_at = q.getColumn(1).getString();
    s.finished_at = q.getColumn(2).getString();
    s.state = q.getColumn(3).getString();
    s.note = q.getColumn(4).getString();
    s.lab_yaml = q.getColumn(5).getString();
    out.push_back(std::move(s));
  }
  std::sort(out.begin(), out.end(), [](const auto& a, const auto& b) { return a.id < b.id; });
  return out;
}

std::map<std::string, double> PoseTemperatures(Database& db,
                                               const std::vector<int64_t>& session_ids) {
  std::map<std::string, double> out;
  SQLite::Statement q(db.sql(),
                      "SELECT p.label, avg(o.temperature_c) FROM observations o JOIN poses p ON "
                      "p.id = o.pose_id WHERE o.session_id = ? AND o.temperature_c IS NOT NULL "
                      "GROUP BY p.id");
  for (int64_t id : session_ids) {
    q.reset();
    q.bind(1, id);
    while (q.executeStep()) {
      out[std::to_string(id) + ":" + q.getColumn(0).getString()] = q.getColumn(1).getDouble();
    }
  }
  return out;
}

std::vector<InstrumentSummary> SessionInstruments(Database& db, int64_t session_id) {
  std::vector<InstrumentSummary> out;
  SQLite::Statement q(
      db.sql(),
      "SELECT name, kind, protocol, coalesce(serial_number, ''), coalesce(firmware, ''), "
      "sigma_hz_arcsec, sigma_v_arcsec, sigma_distance_mm FROM instruments WHERE id IN ("
      "SELECT instrument_id FROM observations WHERE session_id = ?1 UNION "
      "SELECT st.instrument_id FROM stations st JOIN observations o ON o.station_id = st.id "
      "WHERE o.session_id = ?1 UNION "
      "SELECT st.instrument_id FROM stations st JOIN station_setups su ON su.station_id = st.id "
      "WHERE su.session_id = ?1) ORDER BY name");
  q.bind(1, session_id);
  auto optional = [&](int column) { return OptionalDouble(q.getColumn(column)); };
  while (q.executeStep()) {
    InstrumentSummary i;
    i.name = q.getColumn(0).getString();
    i.kind = q.getColumn(1).getString();
    i.protocol = q.getColumn(2).getString();
    i.serial_number = q.getColumn(3).getString();
    i.firmware = q.getColumn(4).getString();
    i.sigma_hz_arcsec = optional(5);
    i.sigma_v_arcsec = optional(6);
    i.sigma_distance_mm = optional(7);
    out.push_back(std::move(i));
  }
  return out;
}

}  // namespace armsig::db
