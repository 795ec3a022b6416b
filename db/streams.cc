#include "db/streams.h"

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "core/error.h"
#include "core/text.h"

#include "db/observations.h"
#include "db/sql_util.h"
#include "db/stored_json.h"

namespace armsig::db {

namespace {

std::string JsonOf(const Eigen::VectorXd& v) {
  nlohmann::json a = nlohmann::json::array();
  for (Eigen::Index i = 0; i < v.size(); ++i) a.push_back(v(i));
  return JsonText(a);
}

Eigen::VectorXd VectorOf(const std::string& text, int64_t row, const char* column) {
  const nlohmann::json a = nlohmann::json::parse(text, nullptr, false);
  if (!a.is_array()) {
    throw InputError(fmt::format("stream_joints row {}: {} is not a JSON array", row, column));
  }
  Eigen::VectorXd v(static_cast<Eigen::Index>(a.size()));
  for (size_t i = 0; i < a.size(); ++i) {
    if (!a[i].is_number()) {
      throw InputError(fmt::format("stream_joints row {}: {} holds a value that is no number", row,
                                   column));
    }
    v(static_cast<Eigen::Index>(i)) = a[i].get<double>();
  }
  return v;
}

}  // namespace

void InsertStreamSegment(Database& db, int64_t session_id, const StreamSegment& seg) {
  auto joints = Sql(db,
                    "INSERT INTO stream_joints(session_id, segment, t_s, q_json, qd_json) "
                    "VALUES (?,?,?,?,?)");
  for (const auto& j : seg.joints) {
    joints->Bind(1, session_id);
    joints->Bind(2, int64_t{seg.segment});
    joints->Bind(3, j.t_s);
    joints->Bind(4, JsonOf(j.q_rad));
    joints->Bind(5, JsonOf(j.qd_rad_s));
    joints->Execute();
  }
  std::map<std::string, int64_t> stations;
  const auto station = [&](const std::string& code) {
    auto it = stations.find(code);
    if (it == stations.end()) it = stations.emplace(code, EnsureStation(db, code)).first;
    return it->second;
  };
  auto points = Sql(db,
                    "INSERT INTO stream_points(session_id, segment, station_id, t_s, hz_rad, "
                    "v_rad, distance_mm, status) VALUES (?,?,?,?,?,?,?,?)");
  for (const auto& p : seg.points) {
    points->Bind(1, session_id);
    points->Bind(2, int64_t{seg.segment});
    points->Bind(3, station(p.station));
    points->Bind(4, p.t_s);
    points->Bind(5, p.hz_rad);
    points->Bind(6, p.v_rad);
    points->Bind(7, p.distance_mm);
    points->Bind(8, int64_t{p.status});
    points->Execute();
  }
  auto events = Sql(db,
                    "INSERT INTO stream_events(session_id, segment, station_id, t_s, status, what) "
                    "VALUES (?,?,?,?,?,?)");
  for (const auto& e : seg.events) {
    events->Bind(1, session_id);
    events->Bind(2, int64_t{seg.segment});
    events->Bind(3, station(e.station));
    events->Bind(4, e.t_s);
    events->Bind(5, int64_t{e.status});
    events->Bind(6, e.what);
    events->Execute();
  }
}

std::set<int> StoredStreamSegments(Database& db, int64_t session_id) {
  std::set<int> out;
  auto s = Sql(db, "SELECT DISTINCT segment FROM stream_joints WHERE session_id = ?");
  s->Bind(1, session_id);
  while (s->Step()) out.insert(static_cast<int>(s->Int(0)));
  return out;
}

SessionStreams LoadSessionStreams(Database& db, int64_t session_id) {
  SessionStreams out;
  {
    auto s = Sql(db,
                 "SELECT id, t_s, q_json, qd_json FROM stream_joints WHERE session_id = ? "
                 "ORDER BY segment, t_s, id");
    s->Bind(1, session_id);
    while (s->Step()) {
      const int64_t row = s->Int(0);
      out.joints.push_back(
          {s->Double(1), VectorOf(s->Text(2), row, "q_json"), VectorOf(s->Text(3), row, "qd_json")});
    }
  }
  {
    auto s = Sql(db,
                 "SELECT st.code, p.t_s, p.hz_rad, p.v_rad, p.distance_mm, p.status, p.segment "
                 "FROM stream_points p JOIN stations st ON st.id = p.station_id "
                 "WHERE p.session_id = ? ORDER BY p.segment, p.t_s, p.id");
    s->Bind(1, session_id);
    while (s->Step()) {
      out.points.push_back({s->Text(0), s->Double(1), s->Double(2), s->Double(3), s->Double(4),
                            static_cast<int>(s->Int(5)), static_cast<int>(s->Int(6))});
    }
  }
  {
    auto s = Sql(db,
                 "SELECT st.code, e.t_s, e.status, e.what "
                 "FROM stream_events e JOIN stations st ON st.id = e.station_id "
                 "WHERE e.session_id = ? ORDER BY e.segment, e.id");
    s->Bind(1, session_id);
    while (s->Step()) {
      out.events.push_back({s->Text(0), s->Double(1), static_cast<int>(s->Int(2)), s->Text(3)});
    }
  }
  return out;
}

void SetSessionSync(Database& db, int64_t session_id, const std::string& json) {
  auto s = Sql(db, "UPDATE sessions SET sync_json = ? WHERE id = ?");
  s->Bind(1, json);
  s->Bind(2, session_id);
  s->Execute();
}

std::optional<std::string> SessionSync(Database& db, int64_t session_id) {
  auto s = Sql(db, "SELECT sync_json FROM sessions WHERE id = ?");
  s->Bind(1, session_id);
  if (!s->Step() || s->IsNull(0)) return std::nullopt;
  return s->Text(0);
}

}  // namespace armsig::db
