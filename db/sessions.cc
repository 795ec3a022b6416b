#include "db/sessions.h"

#include <nlohmann/json.hpp>

#include "db/sql_util.h"

namespace armsig::db {

int64_t CreateSession(Database& db, int64_t robot_id, const std::string& lab_yaml,
                      const std::string& plan_json, const std::string& state,
                      const std::string& note) {
  SQLite::Statement s(db.sql(),
                      "INSERT INTO sessions(robot_id, lab_yaml, plan_json, state, note, "
                      "finished_at) VALUES (?,?,?,?,?, CASE WHEN ?4 IN ('completed','aborted') "
                      "THEN strftime('%Y-%m-%dT%H:%M:%fZ','now') END)");
  s.bind(1, robot_id);
  s.bind(2, lab_yaml);
  s.bind(3, plan_json);
  s.bind(4, state);
  s.bind(5, note);
  s.exec();
  return db.sql().getLastInsertRowid();
}

void SetSessionState(Database& db, int64_t session_id, const std::string& state) {
  SQLite::Statement s(
      db.sql(),
      "UPDATE sessions SET state = ?, finished_at = CASE WHEN ? IN ('completed','aborted') "
      "THEN strftime('%Y-%m-%dT%H:%M:%fZ','now') END WHERE id = ?");
  s.bind(1, state);
  s.bind(2, state);
  s.bind(3, session_id);
  s.exec();
}

void SetSessionOwner(Database& db, int64_t session_id, const SessionOwner& owner) {
  SQLite::Statement s(
      db.sql(),
      "UPDATE sessions SET owner_pid = ?, owner_host = ?, owner_started = ? WHERE id = ?");
  s.bind(1, owner.pid);
  s.bind(2, owner.host);
  s.bind(3, owner.started);
  s.bind(4, session_id);
  s.exec();
}

namespace {

std::optional<SessionOwner> OwnerOf(SQLite::Statement& q, int pid_column) {
  if (q.getColumn(pid_column).isNull()) return std::nullopt;
  return SessionOwner{q.getColumn(pid_column).getInt64(), q.getColumn(pid_column + 1).getString(),
                      q.getColumn(pid_column + 2).getString()};
}

}  // namespace

std::vector<int64_t> SessionIds(Database& db) {
  std::vector<int64_t> out;
  SQLite::Statement s(db.sql(), "SELECT id FROM sessions ORDER BY id");
  while (s.executeStep()) out.push_back(s.getColumn(0).getInt64());
  return out;
}

bool SessionExists(Database& db, int64_t session_id) {
  SQLite::Statement s(db.sql(), "SELECT 1 FROM sessions WHERE id = ?");
  s.bind(1, session_id);
  return s.executeStep();
}

int64_t InsertPose(Database& db, int64_t session_id, int seq, const std::string& label,
                   const std::optional<Eigen::VectorXd>& joints_rad, const std::string& status,
                   int attempts) {
  SQLite::Statement s(db.sql(),
                      "INSERT INTO poses(session_id, seq, label, joints_json, status, attempts) "
                      "VALUES (?,?,?,?,?,?)");
  s.bind(1, session_id);
  s.bind(2, seq);
  s.bind(3, label);
  if (joints_rad)
    s.bind(4, JsonArray(joints_rad->data(), static_cast<int>(joints_rad->size())));
  else
    s.bind(4);
  s.bind(5, status);
  s.bind(6, attempts);
  s.exec();
  return db.sql().getLastInsertRowid();
}

std::optional<SessionRow> LoadSession(Database& db, int64_t session_id) {
  SQLite::Statement s(db.sql(),
                      "SELECT s.id, r.name, coalesce(s.lab_yaml,''), coalesce(s.plan_json,''), "
                      "s.state, coalesce(s.note,''), s.owner_pid, coalesce(s.owner_host, ''), "
                      "coalesce(s.owner_started, '') "
                      "FROM sessions s JOIN robots r ON r.id = s.robot_id WHERE s.id = ?");
  s.bind(1, session_id);
  if (!s.executeStep()) return std::nullopt;
  return SessionRow{s.getColumn(0).getInt64(),  s.getColumn(1).getString(),
                    s.getColumn(2).getString(), s.getColumn(3).getString(),
                    s.getColumn(4).getString(), s.getColumn(5).getString(),
                    OwnerOf(s, 6)};
}

std::vector<int> StoredSeqs(Database& db, int64_t session_id) {
  std::vector<int> out;
  SQLite::Statement s(db.sql(), "SELECT seq FROM poses WHERE session_id = ? ORDER BY seq");
  s.bind(1, session_id);
  while (s.executeStep()) out.push_back(s.getColumn(0).getInt());
  return out;
}

std::vector<MeasuredPose> LoadRobotPoses(Database& db, int64_t robot_id, const std::string& since,
                                         int64_t* max_pose_row) {
  SQLite::Statement q(
      db.sql(),
      "SELECT s.id, p.label, p.joints_json, pt.x_mm, pt.y_mm, pt.z_mm, p.id FROM poses p "
      "JOIN sessions s ON s.id = p.session_id JOIN points pt ON pt.pose_id = p.id "
      "WHERE s.robot_id = ? AND p.status = 'measured' AND pt.x_mm IS NOT NULL "
      "AND p.joints_json IS NOT NULL AND (? = '' OR s.started_at >= ?) ORDER BY p.id");
  q.bind(1, robot_id);
  q.bind(2, since);
  q.bind(3, since);
  std::vector<MeasuredPose> out;
  int64_t newest = 0;
  while (q.executeStep()) {
    MeasuredPose pose;
    pose.frame = q.getColumn(0).getInt64();
    pose.id = std::to_string(pose.frame) + ":" + q.getColumn(1).getString();
    const auto joints =
        nlohmann::json::parse(q.getColumn(2).getString()).get<std::vector<double>>();
    pose.joints_rad = Eigen::Map<const Eigen::VectorXd>(joints.data(), joints.size());
    pose.target_in_world = {q.getColumn(3).getDouble(), q.getColumn(4).getDouble(),
                            q.getColumn(5).getDouble()};
    newest = std::max<int64_t>(newest, q.getColumn(6).getInt64());
    out.push_back(std::move(pose));
  }
  if (max_pose_row) *max_pose_row = newest;
  return out;
}

std::vector<MeasuredPose> LoadSessionPoses(Database& db, int64_t session_id,
                                           std::vector<Eigen::Matrix3d>* covariances) {
  SQLite::Statement q(
      db.sql(),
      "SELECT p.label, p.joints_json, pt.x_mm, pt.y_mm, pt.z_mm, "
      "coalesce(pt.covariance_json, '') FROM poses p JOIN points pt ON pt.pose_id = p.id "
      "WHERE p.session_id = ? AND pt.x_mm IS NOT NULL AND p.joints_json IS NOT NULL "
      "ORDER BY p.seq");
  q.bind(1, session_id);
  std::vector<MeasuredPose> out;
  while (q.executeStep()) {
    MeasuredPose pose;
    pose.id = q.getColumn(0).getString();
    pose.frame = session_id;
    const auto joints =
        nlohmann::json::parse(q.getColumn(1).getString()).get<std::vector<double>>();
    pose.joints_rad = Eigen::Map<const Eigen::VectorXd>(joints.data(), joints.size());
    pose.target_in_world = {q.getColumn(2).getDouble(), q.getColumn(3).getDouble(),
                            q.getColumn(4).getDouble()};
    if (covariances) {
      covariances->push_back(
          ParseCovariance(q.getColumn(5).getString()).value_or(Eigen::Matrix3d::Constant(NAN)));
    }
    out.push_back(std::move(pose));
  }
  return out;
}

std::vector<SessionSummary> ListSessions(Database& db, std::optional<int64_t> robot_id) {
  SQLite::Statement q(
      db.sql(),
      "SELECT s.id, r.name, s.state, coalesce(s.note, ''), s.started_at, "
      "coalesce(s.finished_at, ''), "
      "(SELECT count(*) FROM poses p WHERE p.session_id = s.id AND p.status = 'measured'), "
      "(SELECT count(*) FROM poses p WHERE p.session_id = s.id AND p.status = 'skipped'), "
      "(SELECT count(*) FROM points t WHERE t.session_id = s.id AND t.x_mm IS NOT NULL), "
      "(SELECT count(*) FROM points t WHERE t.session_id = s.id AND t.x_mm IS NOT NULL AND "
      "coalesce(t.flags, '') <> ''), s.owner_pid, coalesce(s.owner_host, ''), "
      "coalesce(s.owner_started, '') "
      "FROM sessions s JOIN robots r ON r.id = s.robot_id WHERE ?1 IS NULL OR s.robot_id = ?1 "
      "ORDER BY s.id");
  if (robot_id)
    q.bind(1, *robot_id);
  else
    q.bind(1);
  std::vector<SessionSummary> out;
  while (q.executeStep()) {
    SessionSummary s;
    s.id = q.getColumn(0).getInt64();
    s.robot = q.getColumn(1).getString();
    s.state = q.getColumn(2).getString();
    s.note = q.getColumn(3).getString();
    s.started_at = q.getColumn(4).getString();
    s.finished_at = q.getColumn(5).getString();
    s.measured = q.getColumn(6).getInt();
    s.skipped = q.getColumn(7).getInt();
    s.usable = q.getColumn(8).getInt();
    s.flagged = q.getColumn(9).getInt();
    s.owner = OwnerOf(q, 10);
    out.push_back(std::move(s));
  }
  return out;
}

std::string LatestLabYaml(Database& db, int64_t robot_id) {
  SQLite::Statement q(db.sql(),
                      "SELECT lab_yaml FROM sessions WHERE robot_id = ? AND coalesce(lab_yaml, '') "
                      "<> '' ORDER BY id DESC LIMIT 1");
  q.bind(1, robot_id);
  return q.executeStep() ? q.getColumn(0).getString() : std::string();
}

}  // namespace armsig::db
