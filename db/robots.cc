#include "db/robots.h"

#include "core/error.h"
#include "db/schema.h"
#include "db/sessions.h"
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

std::vector<RobotRow> ListRobots(Database& db, bool removed) {
  auto q = Sql(db,
               std::string("SELECT r.id, r.name, r.model_name, r.created_at, "
                           "(SELECT count(*) FROM sessions s WHERE s.robot_id = r.id), "
                           "(SELECT max(version) FROM calibrations c WHERE c.robot_id = r.id AND "
                           "c.active = 1), coalesce(r.removed_at, '') FROM robots r") +
                   (removed ? "" : " WHERE r.removed_at IS NULL") + " ORDER BY r.name");
  std::vector<RobotRow> out;
  while (q->Step()) {
    RobotRow r;
    r.id = q->Int(0);
    r.name = q->Text(1);
    r.model_name = q->Text(2);
    r.created_at = q->Text(3);
    r.sessions = static_cast<int>(q->Int(4));
    if (!q->IsNull(5)) r.active_version = static_cast<int>(q->Int(5));
    r.removed_at = q->Text(6);
    out.push_back(std::move(r));
  }
  return out;
}

std::string RobotModelYaml(Database& db, int64_t robot_id) {
  auto q = Sql(db, "SELECT model_yaml FROM robots WHERE id = ?");
  q->Bind(1, robot_id);
  return q->Step() ? q->Text(0) : std::string();
}

namespace {

struct RobotState {
  int64_t id = 0;
  std::string removed_at;
};
RobotState RequireRobot(Database& db, const std::string& name) {
  auto q = Sql(db, "SELECT id, coalesce(removed_at, '') FROM robots WHERE name = ?");
  q->Bind(1, name);
  if (!q->Step()) {
    throw InputError({db.path(), 0, 0, "robots"},
                     "no robot '" + name + "' (armsig robot list --removed lists them all)");
  }
  return {q->Int(0), q->Text(1)};
}

void AddEvent(Database& db, int64_t robot_id, const std::string& event,
              std::optional<int64_t> session_id, const std::string& detail,
              const std::string& reason, const std::string& user) {
  auto s = Sql(db,
               "INSERT INTO robot_events(robot_id, event, session_id, detail, reason, by_user) "
               "VALUES (?,?,?,?,?,?)");
  s->Bind(1, robot_id);
  s->Bind(2, event);
  if (session_id) {
    s->Bind(3, *session_id);
  } else {
    s->BindNull(3);
  }
  s->Bind(4, detail);
  if (reason.empty()) {
    s->BindNull(5);
  } else {
    s->Bind(5, reason);
  }
  s->Bind(6, user);
  s->Execute();
}

}  // namespace

void RenameRobot(Database& db, const std::string& name, const std::string& new_name,
                 const std::string& reason, const std::string& user) {
  WriteTransaction tx(db);
  const RobotState robot = RequireRobot(db, name);
  if (FindRobot(db, new_name)) {
    throw InputError({db.path(), 0, 0, "robots"},
                     "robot '" + new_name + "' exists already: nothing was renamed");
  }
  auto s = Sql(db, "UPDATE robots SET name = ? WHERE id = ?");
  s->Bind(1, new_name);
  s->Bind(2, robot.id);
  s->Execute();
  AddEvent(db, robot.id, "renamed", std::nullopt,
           "renamed from " + name + " to " + new_name, reason, user);
  tx.commit();
}

void RemoveRobot(Database& db, const std::string& name, const std::string& reason,
                 const std::string& user) {
  WriteTransaction tx(db);
  const RobotState robot = RequireRobot(db, name);
  if (!robot.removed_at.empty()) {
    throw InputError({db.path(), 0, 0, "robots"},
                     "robot '" + name + "' was removed already (" + robot.removed_at + ")");
  }
  if (db.connection().QueryInt("SELECT count(*) FROM sessions WHERE robot_id = " +
                               std::to_string(robot.id) + " AND state = 'running'") > 0) {
    throw InputError({db.path(), 0, 0, "robots"},
                     "robot '" + name + "' has a session being captured: end or pause it first");
  }
  auto s = Sql(db, std::string("UPDATE robots SET removed_at = ") +
                       std::string(NowIsoSql(db.connection().backend())) + " WHERE id = ?");
  s->Bind(1, robot.id);
  s->Execute();
  AddEvent(db, robot.id, "removed", std::nullopt, "removed " + name, reason, user);
  tx.commit();
}

void RestoreRobot(Database& db, const std::string& name, const std::string& reason,
                  const std::string& user) {
  WriteTransaction tx(db);
  const RobotState robot = RequireRobot(db, name);
  if (robot.removed_at.empty()) {
    throw InputError({db.path(), 0, 0, "robots"}, "robot '" + name + "' is in use, not removed");
  }
  auto s = Sql(db, "UPDATE robots SET removed_at = NULL WHERE id = ?");
  s->Bind(1, robot.id);
  s->Execute();
  AddEvent(db, robot.id, "restored", std::nullopt,
           "restored " + name + " (removed " + robot.removed_at + ")", reason, user);
  tx.commit();
}

std::string MoveSession(Database& db, int64_t session_id, const std::string& to,
                        const std::string& reason, const std::string& user) {
  WriteTransaction tx(db);
  const RobotState target = RequireRobot(db, to);
  if (!target.removed_at.empty()) {
    throw InputError({db.path(), 0, 0, "robots"},
                     "robot '" + to + "' was removed (" + target.removed_at +
                         "): restore it first (armsig robot restore " + to + ")");
  }
  auto q = Sql(db,
               "SELECT s.robot_id, r.name, s.state FROM sessions s JOIN robots r ON r.id = "
               "s.robot_id WHERE s.id = ?");
  q->Bind(1, session_id);
  if (!q->Step()) {
    throw InputError({db.path(), 0, 0, "sessions"}, "no session " + std::to_string(session_id));
  }
  const int64_t from_id = q->Int(0);
  const std::string from = q->Text(1);
  const SessionState state = SessionStateOf(q->Text(2));
  q.reset();
  if (from_id == target.id) {
    throw InputError({db.path(), 0, 0, "sessions"},
                     "session " + std::to_string(session_id) + " is robot " + to + "'s already");
  }
  if (state == SessionState::kRunning) {
    throw InputError({db.path(), 0, 0, "sessions"},
                     "session " + std::to_string(session_id) +
                         " is being captured: pause or end it before moving it");
  }
  auto s = Sql(db, "UPDATE sessions SET robot_id = ? WHERE id = ?");
  s->Bind(1, target.id);
  s->Bind(2, session_id);
  s->Execute();
  const std::string id = std::to_string(session_id);
  AddEvent(db, from_id, "session_moved_out", session_id,
           "session " + id + " moved to " + to, reason, user);
  AddEvent(db, target.id, "session_moved_in", session_id,
           "session " + id + " moved in from " + from, reason, user);
  tx.commit();
  return from;
}

std::vector<RobotEvent> RobotEvents(Database& db, int64_t robot_id) {
  auto q = Sql(db,
               "SELECT event, session_id, detail, coalesce(reason, ''), at, coalesce(by_user, '') "
               "FROM robot_events WHERE robot_id = ? ORDER BY id");
  q->Bind(1, robot_id);
  std::vector<RobotEvent> out;
  while (q->Step()) {
    RobotEvent e;
    e.event = q->Text(0);
    if (!q->IsNull(1)) e.session_id = q->Int(1);
    e.detail = q->Text(2);
    e.reason = q->Text(3);
    e.at = q->Text(4);
    e.by_user = q->Text(5);
    out.push_back(std::move(e));
  }
  return out;
}

std::optional<int64_t> FindRobotInUse(Database& db, const std::string& name) {
  auto q = Sql(db, "SELECT id, coalesce(removed_at, '') FROM robots WHERE name = ?");
  q->Bind(1, name);
  if (!q->Step()) return std::nullopt;
  if (!q->Text(1).empty()) {
    throw InputError({db.path(), 0, 0, "robots"},
                     "robot '" + name + "' was removed (" + q->Text(1) +
                         "): its history is kept, it takes no new work; `armsig robot restore " +
                         name + "` brings it back");
  }
  return q->Int(0);
}

}  // namespace armsig::db
