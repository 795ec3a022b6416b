#include "db/robots.h"

#include "db/sql_util.h"

namespace armsig::db {

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

std::vector<RobotRow> ListRobots(Database& db) {
  SQLite::Statement q(db.sql(),
                      "SELECT r.id, r.name, r.model_name, r.created_at, "
                      "(SELECT count(*) FROM sessions s WHERE s.robot_id = r.id), "
                      "(SELECT max(version) FROM calibrations c WHERE c.robot_id = r.id AND "
                      "c.active = 1) FROM robots r ORDER BY r.name");
  std::vector<RobotRow> out;
  while (q.executeStep()) {
    RobotRow r;
    r.id = q.getColumn(0).getInt64();
    r.name = q.getColumn(1).getString();
    r.model_name = q.getColumn(2).getString();
    r.created_at = q.getColumn(3).getString();
    r.sessions = q.getColumn(4).getInt();
    if (!q.getColumn(5).isNull()) r.active_version = q.getColumn(5).getInt();
    out.push_back(std::move(r));
  }
  return out;
}

std::string RobotModelYaml(Database& db, int64_t robot_id) {
  SQLite::Statement q(db.sql(), "SELECT model_yaml FROM robots WHERE id = ?");
  q.bind(1, robot_id);
  return q.executeStep() ? q.getColumn(0).getString() : std::string();
}

}  // namespace armsig::db
