#include "db/robots.h"

#include "db/sql_util.h"

namespace armsig::db {

int64_t EnsureRobot(Database& db, const std::string& name, const std::string& model_name,
                    const std::string& model_yaml) {
  if (auto id = FindRobot(db, name)) return *id;
  // Two writers registering one name at once: the second waits for the first's commit
  // (PostgreSQL) or its turn (SQLite), then finds the robot.
  auto s = Sql(db,
               "INSERT INTO robots(name, model_name, model_yaml) VALUES (?,?,?) "
               "ON CONFLICT (name) DO NOTHING");
  s->Bind(1, name);
  s->Bind(2, model_name);
  s->Bind(3, model_yaml);
  s->Execute();
  if (auto id = FindRobot(db, name)) return *id;
  throw DatabaseError(db.path() + ": robot " + name + " was neither stored nor found", "", false);
}

std::optional<int64_t> FindRobot(Database& db, const std::string& name) {
  auto s = Sql(db, "SELECT id FROM robots WHERE name = ?");
  s->Bind(1, name);
  if (s->Step()) return s->Int(0);
  return std::nullopt;
}

std::vector<RobotRow> ListRobots(Database& db) {
  auto q = Sql(db,
               "SELECT r.id, r.name, r.model_name, r.created_at, "
               "(SELECT count(*) FROM sessions s WHERE s.robot_id = r.id), "
               "(SELECT max(version) FROM calibrations c WHERE c.robot_id = r.id AND "
               "c.active = 1) FROM robots r ORDER BY r.name");
  std::vector<RobotRow> out;
  while (q->Step()) {
    RobotRow r;
    r.id = q->Int(0);
    r.name = q->Text(1);
    r.model_name = q->Text(2);
    r.created_at = q->Text(3);
    r.sessions = static_cast<int>(q->Int(4));
    if (!q->IsNull(5)) r.active_version = static_cast<int>(q->Int(5));
    out.push_back(std::move(r));
  }
  return out;
}

std::string RobotModelYaml(Database& db, int64_t robot_id) {
  auto q = Sql(db, "SELECT model_yaml FROM robots WHERE id = ?");
  q->Bind(1, robot_id);
  return q->Step() ? q->Text(0) : std::string();
}

}  // namespace armsig::db
