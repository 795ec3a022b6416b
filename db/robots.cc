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

std::string RobotModelYaml(Database& db, int64_t robot_id) {
  SQLite::Statement q(db.sql(), "SELECT model_yaml FROM robots WHERE id = ?");
  q.bind(1, robot_id);
  return q.executeStep() ? q.getColumn(0).getString() : std::string();
}

}  // namespace armsig::db
