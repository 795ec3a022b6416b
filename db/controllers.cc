#include "db/controllers.h"

#include "db/sql_util.h"

namespace armsig::db {

namespace {

// NULL for an empty text: "the controller did not say".
void BindText(Statement& s, int index, const std::string& text) {
  if (text.empty())
    s.BindNull(index);
  else
    s.Bind(index, text);
}

std::string TextOf(const Statement& q, int column) { return q.IsNull(column) ? "" : q.Text(column); }

}  // namespace

void SetSessionController(Database& db, int64_t session_id, const ControllerRecord& r) {
  auto s = Sql(db,
               "UPDATE sessions SET controller_model = ?, controller_serial = ?, "
               "controller_software = ?, kinematics_checksum = ?, kinematics_json = ? WHERE id = ?");
  BindText(*s, 1, r.model);
  BindText(*s, 2, r.serial);
  BindText(*s, 3, r.software);
  BindText(*s, 4, r.kinematics_checksum);
  BindText(*s, 5, r.kinematics_json);
  s->Bind(6, session_id);
  s->Execute();
}

std::optional<ControllerRecord> SessionController(Database& db, int64_t session_id) {
  auto q = Sql(db,
               "SELECT controller_model, controller_serial, controller_software, "
               "kinematics_checksum, kinematics_json FROM sessions WHERE id = ?");
  q->Bind(1, session_id);
  if (!q->Step()) return std::nullopt;
  ControllerRecord r{TextOf(*q, 0), TextOf(*q, 1), TextOf(*q, 2), TextOf(*q, 3), TextOf(*q, 4)};
  CheckStoredJsonText(r.kinematics_json, {db.path(), "sessions", session_id, "kinematics_json"});
  if (r == ControllerRecord{}) return std::nullopt;
  return r;
}

void RecordRobotController(Database& db, int64_t robot_id, const ControllerRecord& r) {
  // The identity once (coalesce keeps the first); the kinematics as they are now.
  auto s = Sql(db,
               "UPDATE robots SET controller_model = coalesce(controller_model, ?), "
               "controller_serial = coalesce(controller_serial, ?), kinematics_checksum = ?, "
               "kinematics_json = ? WHERE id = ?");
  BindText(*s, 1, r.model);
  BindText(*s, 2, r.serial);
  BindText(*s, 3, r.kinematics_checksum);
  BindText(*s, 4, r.kinematics_json);
  s->Bind(5, robot_id);
  s->Execute();
}

std::optional<ControllerRecord> RobotControllerRecord(Database& db, int64_t robot_id) {
  auto q = Sql(db,
               "SELECT controller_model, controller_serial, kinematics_checksum, kinematics_json "
               "FROM robots WHERE id = ?");
  q->Bind(1, robot_id);
  if (!q->Step()) return std::nullopt;
  ControllerRecord r{TextOf(*q, 0), TextOf(*q, 1), "", TextOf(*q, 2), TextOf(*q, 3)};
  CheckStoredJsonText(r.kinematics_json, {db.path(), "robots", robot_id, "kinematics_json"});
  if (r == ControllerRecord{}) return std::nullopt;
  return r;
}

std::vector<SessionKinematics> KinematicsHistory(Database& db, int64_t robot_id) {
  auto q = Sql(db,
               "SELECT id, started_at, kinematics_checksum FROM sessions WHERE robot_id = ? AND "
               "kinematics_checksum IS NOT NULL ORDER BY id");
  q->Bind(1, robot_id);
  std::vector<SessionKinematics> out;
  while (q->Step()) out.push_back({q->Int(0), q->Text(1), q->Text(2)});
  return out;
}

}  // namespace armsig::db
