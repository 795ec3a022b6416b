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

// A record's columns in its table: a session keeps everything as it was when it began; a
// robot its identity from the first (coalesce keeps it) and its kinematics as they are now.
struct Column {
  const char* name;
  std::string ControllerRecord::*field;
  bool keep_first;
};
constexpr Column kSessionColumns[] = {{"controller_model", &ControllerRecord::model, false},
                                      {"controller_serial", &ControllerRecord::serial, false},
                                      {"controller_software", &ControllerRecord::software, false},
                                      {"kinematics_checksum", &ControllerRecord::kinematics_checksum, false},
                                      {"kinematics_json", &ControllerRecord::kinematics_json, false}};
constexpr Column kRobotColumns[] = {{"controller_model", &ControllerRecord::model, true},
                                    {"controller_serial", &ControllerRecord::serial, true},
                                    {"kinematics_checksum", &ControllerRecord::kinematics_checksum, false},
                                    {"kinematics_json", &ControllerRecord::kinematics_json, false}};

template <size_t N>
void Write(Database& db, const char* table, const Column (&columns)[N], int64_t id,
           const ControllerRecord& r) {
  std::string sql = std::string("UPDATE ") + table + " SET ";
  for (size_t k = 0; k < N; ++k) {
    const std::string name = columns[k].name;
    sql += (k ? ", " : "") + name + " = " + (columns[k].keep_first ? "coalesce(" + name + ", ?)" : "?");
  }
  auto s = Sql(db, sql + " WHERE id = ?");
  for (size_t k = 0; k < N; ++k) BindText(*s, static_cast<int>(k) + 1, r.*columns[k].field);
  s->Bind(static_cast<int>(N) + 1, id);
  s->Execute();
}

template <size_t N>
std::optional<ControllerRecord> Read(Database& db, const char* table, const Column (&columns)[N],
                                     int64_t id) {
  std::string sql = "SELECT ";
  for (size_t k = 0; k < N; ++k) sql += std::string(k ? ", " : "") + columns[k].name;
  auto q = Sql(db, sql + " FROM " + table + " WHERE id = ?");
  q->Bind(1, id);
  if (!q->Step()) return std::nullopt;
  ControllerRecord r;
  for (size_t k = 0; k < N; ++k) r.*columns[k].field = TextOf(*q, static_cast<int>(k));
  CheckStoredJsonText(r.kinematics_json, {db.path(), table, id, "kinematics_json"});
  if (r == ControllerRecord{}) return std::nullopt;
  return r;
}

}  // namespace

void SetSessionController(Database& db, int64_t session_id, const ControllerRecord& record) {
  Write(db, "sessions", kSessionColumns, session_id, record);
}

std::optional<ControllerRecord> SessionController(Database& db, int64_t session_id) {
  return Read(db, "sessions", kSessionColumns, session_id);
}

void RecordRobotController(Database& db, int64_t robot_id, const ControllerRecord& record) {
  Write(db, "robots", kRobotColumns, robot_id, record);
}

std::optional<ControllerRecord> RobotControllerRecord(Database& db, int64_t robot_id) {
  return Read(db, "robots", kRobotColumns, robot_id);
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
