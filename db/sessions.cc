#include "db/sessions.h"

#include <nlohmann/json.hpp>
#include <stdexcept>

#include "core/enum_words.h"
#include "db/schema.h"
#include "db/sql_util.h"

namespace armsig::db {

namespace {

// finished_at of a session that goes into `state`: now when it is finished, else NULL.
std::string FinishedAtSql(Database& db) {
  return "CASE WHEN ? IN ('completed','aborted') THEN " +
         std::string(NowIsoSql(db.backend())) + " END";
}

}  // namespace

namespace {
constexpr EnumWord<SessionState> kSessionStates[] = {
    {SessionState::kRunning, "running"},
    {SessionState::kPaused, "paused"},
    {SessionState::kCompleted, "completed"},
    {SessionState::kAborted, "aborted"},
};
constexpr EnumWord<SessionKind> kSessionKinds[] = {
    {SessionKind::kCalibration, "calibration"},
    {SessionKind::kTest, "test"},
    {SessionKind::kCheck, "check"},
};
}  // namespace

const char* ToString(SessionState state) { return WordOf(kSessionStates, state); }

SessionState SessionStateOf(const std::string& text) {
  if (const auto state = ValueNamed(kSessionStates, text)) return *state;
  throw std::invalid_argument("session state '" + text +
                              "': expected running, paused, completed or aborted");
}

const char* ToString(SessionKind kind) { return WordOf(kSessionKinds, kind); }
std::optional<SessionKind> SessionKindNamed(const std::string& text) {
  return ValueNamed(kSessionKinds, text);
}

int64_t CreateSession(Database& db, int64_t robot_id, const std::string& lab_yaml,
                      const std::string& plan_json, SessionState state, const std::string& note) {
  auto s = Sql(db,
               "INSERT INTO sessions(robot_id, lab_yaml, plan_json, state, note, finished_at) "
               "VALUES (?,?,?,?,?, " +
                   FinishedAtSql(db) + ") RETURNING id");
  s->Bind(1, robot_id);
  s->Bind(2, lab_yaml);
  s->Bind(3, plan_json);
  s->Bind(4, std::string(ToString(state)));
  s->Bind(5, note);
  s->Bind(6, std::string(ToString(state)));
  return InsertedId(*s, db.path() + ": a session");
}

void SetSessionKind(Database& db, int64_t session_id, SessionKind kind) {
  auto s = Sql(db, "UPDATE sessions SET kind = ? WHERE id = ?");
  s->Bind(1, std::string(ToString(kind)));
  s->Bind(2, session_id);
  s->Step();
}

void SetSessionState(Database& db, int64_t session_id, SessionState state) {
  auto s = Sql(db, "UPDATE sessions SET state = ?, finished_at = " + FinishedAtSql(db) +
                       " WHERE id = ?");
  s->Bind(1, std::string(ToString(state)));
  s->Bind(2, std::string(ToString(state)));
  s->Bind(3, session_id);
  s->Execute();
}

void AppendSessionNote(Database& db, int64_t session_id, const std::string& text) {
  auto s = Sql(db,
               "UPDATE sessions SET note = CASE WHEN coalesce(note, '') = '' THEN ? "
               "ELSE note || '; ' || ? END WHERE id = ?");
  s->Bind(1, text);
  s->Bind(2, text);
  s->Bind(3, session_id);
  s->Execute();
}

void DiscardSession(Database& db, int64_t session_id, const std::string& reason) {
  auto s = Sql(db, "UPDATE sessions SET state = 'aborted', finished_at = coalesce(finished_at, " +
                       std::string(NowIsoSql(db.backend())) + ") WHERE id = ?");
  s->Bind(1, session_id);
  s->Execute();
  AppendSessionNote(db, session_id, "discarded: " + reason);
}

void SetSessionOwner(Database& db, int64_t session_id, const SessionOwner& owner) {
  auto s = Sql(db, "UPDATE sessions SET owner_pid = ?, owner_host = ?, owner_started = ? "
                   "WHERE id = ?");
  s->Bind(1, owner.pid);
  s->Bind(2, owner.host);
  s->Bind(3, owner.started);
  s->Bind(4, session_id);
  s->Execute();
}

namespace {

std::optional<SessionOwner> OwnerOf(const Statement& q, int pid_column) {
  if (q.IsNull(pid_column)) return std::nullopt;
  return SessionOwner{q.Int(pid_column), q.Text(pid_column + 1), q.Text(pid_column + 2)};
}

}  // namespace

std::vector<int64_t> SessionIds(Database& db) {
  std::vector<int64_t> out;
  auto s = Sql(db, "SELECT id FROM sessions ORDER BY id");
  while (s->Step()) out.push_back(s->Int(0));
  return out;
}

bool SessionExists(Database& db, int64_t session_id) {
  auto s = Sql(db, "SELECT 1 FROM sessions WHERE id = ?");
  s->Bind(1, session_id);
  return s->Step();
}

int64_t InsertPose(Database& db, int64_t session_id, int seq, const std::string& label,
                   const std::optional<Eigen::VectorXd>& joints_rad, const std::string& status,
                   int attempts, std::optional<double> controller_time_s) {
  auto s = Sql(db,
               "INSERT INTO poses(session_id, seq, label, joints_json, status, attempts, "
               "controller_time_s) VALUES (?,?,?,?,?,?,?) RETURNING id");
  s->Bind(1, session_id);
  s->Bind(2, seq);
  s->Bind(3, label);
  if (joints_rad)
    s->Bind(4, JsonArray(joints_rad->data(), static_cast<int>(joints_rad->size())));
  else
    s->BindNull(4);
  s->Bind(5, status);
  s->Bind(6, attempts);
  s->Bind(7, controller_time_s);
  return InsertedId(*s, db.path() + ": a pose");
}

namespace {

// The sessions table's columns as SessionRow holds them (ReadSession), joined to the robots.
constexpr const char* kSessionColumns =
    "s.id, r.name, coalesce(s.lab_yaml,''), coalesce(s.plan_json,''), s.state, "
    "coalesce(s.note,''), s.started_at, coalesce(s.finished_at, ''), s.kind, s.owner_pid, "
    "coalesce(s.owner_host, ''), coalesce(s.owner_started, '')";
constexpr int kSessionColumnCount = 12;
constexpr const char* kSessionsWithRobots = " FROM sessions s JOIN robots r ON r.id = s.robot_id ";

void ReadSession(const Statement& q, SessionRow& out) {
  out.id = q.Int(0);
  out.robot = q.Text(1);
  out.lab_yaml = q.Text(2);
  out.plan_json = q.Text(3);
  out.state = SessionStateOf(q.Text(4));  // the schema's CHECK allows no other word
  out.note = q.Text(5);
  out.started_at = q.Text(6);
  out.finished_at = q.Text(7);
  // The schema's CHECK allows no other word.
  out.kind = SessionKindNamed(q.Text(8)).value_or(SessionKind::kCalibration);
  out.owner = OwnerOf(q, 9);
}

}  // namespace

std::optional<SessionRow> LoadSession(Database& db, int64_t session_id) {
  auto s =
      Sql(db, std::string("SELECT ") + kSessionColumns + kSessionsWithRobots + "WHERE s.id = ?");
  s->Bind(1, session_id);
  if (!s->Step()) return std::nullopt;
  SessionRow row;
  ReadSession(*s, row);
  return row;
}

std::vector<int> StoredSeqs(Database& db, int64_t session_id) {
  std::vector<int> out;
  auto s = Sql(db, "SELECT seq FROM poses WHERE session_id = ? ORDER BY seq");
  s->Bind(1, session_id);
  while (s->Step()) out.push_back(static_cast<int>(s->Int(0)));
  return out;
}

// Points are joined to their poses on both columns: the points' (session_id, pose_id, point)
// index answers the join. On pose_id alone SQLite scanned every point of the table for each
// pose: a session of 41,595 poses loaded in 380 s, now 0.07 s.
const char* const kRobotPosesQuery =
    "SELECT s.id, p.label, p.joints_json, pt.x_mm, pt.y_mm, pt.z_mm, p.id, pt.id, "
    "pt.rx_rad, pt.ry_rad, pt.rz_rad, pt.sigma_rx_rad, pt.sigma_ry_rad, "
    "pt.sigma_rz_rad, pt.sync_sigma_mm, coalesce(pt.covariance_json, '') FROM poses p "
    "JOIN sessions s ON s.id = p.session_id "
    "JOIN points pt ON pt.session_id = p.session_id AND pt.pose_id = p.id "
    "WHERE s.robot_id = ? AND s.state <> 'aborted' AND p.status = 'measured' "
    "AND pt.x_mm IS NOT NULL AND p.joints_json IS NOT NULL AND s.started_at >= ? "
    "ORDER BY p.id";
const char* const kSessionPosesQuery =
    "SELECT p.label, p.joints_json, pt.x_mm, pt.y_mm, pt.z_mm, "
    "coalesce(pt.covariance_json, ''), p.id, pt.id, pt.rx_rad, pt.ry_rad, pt.rz_rad, "
    "pt.sigma_rx_rad, pt.sigma_ry_rad, pt.sigma_rz_rad, pt.sync_sigma_mm FROM poses p "
    "JOIN points pt ON pt.session_id = p.session_id AND pt.pose_id = p.id "
    "WHERE p.session_id = ? AND pt.x_mm IS NOT NULL AND p.joints_json IS NOT NULL "
    "ORDER BY p.seq";

namespace {

// A paired point's weight (MeasuredPose::weight) from its clock share and its covariance (which
// includes the share): σ² / (σ² + σ_sync²), σ² the covariance's mean variance without it.
double SyncWeight(std::optional<double> sync_sigma_mm, const std::optional<Eigen::Matrix3d>& covariance) {
  if (!sync_sigma_mm || !(*sync_sigma_mm > 0.0) || !covariance || !covariance->allFinite()) return 1.0;
  const double share = *sync_sigma_mm * *sync_sigma_mm;
  const double own = std::max(covariance->trace() / 3.0 - share, 1e-12);
  return own / (own + share);
}

}  // namespace

std::vector<MeasuredPose> LoadRobotPoses(Database& db, int64_t robot_id, const std::string& since,
                                         int64_t* max_pose_row) {
  auto q = Sql(db, kRobotPosesQuery);
  q->Bind(1, robot_id);
  q->Bind(2, since);  // "" is before every time stamp
  std::vector<MeasuredPose> out;
  int64_t newest = 0;
  while (q->Step()) {
    MeasuredPose pose;
    pose.frame = q->Int(0);
    pose.id = std::to_string(pose.frame) + ":" + q->Text(1);
    pose.joints_rad = ParseJoints(q->Text(2), {db.path(), "poses", q->Int(6), "joints_json"});
    pose.target_in_world = {q->Double(3), q->Double(4), q->Double(5)};
    pose.orientation = OrientationAt(*q, 8, {db.path(), "points", q->Int(7), "rx_rad"});
    if (!q->IsNull(14)) {
      pose.weight = SyncWeight(q->Double(14), ParseMatrix3(q->Text(15), {db.path(), "points", q->Int(7),
                                                                          "covariance_json"}));
    }
    newest = std::max<int64_t>(newest, q->Int(6));
    out.push_back(std::move(pose));
  }
  if (max_pose_row) *max_pose_row = newest;
  return out;
}

std::vector<MeasuredPose> LoadSessionPoses(Database& db, int64_t session_id,
                                           std::vector<Eigen::Matrix3d>* covariances) {
  auto q = Sql(db, kSessionPosesQuery);
  q->Bind(1, session_id);
  std::vector<MeasuredPose> out;
  while (q->Step()) {
    MeasuredPose pose;
    pose.id = q->Text(0);
    pose.frame = session_id;
    pose.joints_rad = ParseJoints(q->Text(1), {db.path(), "poses", q->Int(6), "joints_json"});
    pose.target_in_world = {q->Double(2), q->Double(3), q->Double(4)};
    pose.orientation = OrientationAt(*q, 8, {db.path(), "points", q->Int(7), "rx_rad"});
    const auto covariance =
        ParseMatrix3(q->Text(5), {db.path(), "points", q->Int(7), "covariance_json"});
    if (!q->IsNull(14)) pose.weight = SyncWeight(q->Double(14), covariance);
    if (covariances) covariances->push_back(covariance.value_or(Eigen::Matrix3d::Constant(NAN)));
    out.push_back(std::move(pose));
  }
  return out;
}

std::vector<SessionSummary> ListSessions(Database& db, std::optional<int64_t> robot_id) {
  auto q = Sql(
      db,
      std::string("SELECT ") + kSessionColumns +
          ", (SELECT count(*) FROM poses p WHERE p.session_id = s.id AND p.status = 'measured'), "
          "(SELECT count(*) FROM poses p WHERE p.session_id = s.id AND p.status = 'skipped'), "
          "(SELECT count(*) FROM points t WHERE t.session_id = s.id AND t.x_mm IS NOT NULL), "
          "(SELECT count(*) FROM points t WHERE t.session_id = s.id AND t.x_mm IS NOT NULL AND "
          "coalesce(t.flags, '') <> ''), "
          "(SELECT count(DISTINCT j.segment) FROM stream_joints j WHERE j.session_id = s.id)" +
          kSessionsWithRobots + (robot_id ? "WHERE s.robot_id = ? " : "") + "ORDER BY s.id");
  if (robot_id) q->Bind(1, *robot_id);
  std::vector<SessionSummary> out;
  while (q->Step()) {
    SessionSummary s;
    ReadSession(*q, s);
    s.measured = static_cast<int>(q->Int(kSessionColumnCount));
    s.skipped = static_cast<int>(q->Int(kSessionColumnCount + 1));
    s.usable = static_cast<int>(q->Int(kSessionColumnCount + 2));
    s.flagged = static_cast<int>(q->Int(kSessionColumnCount + 3));
    s.sweep_segments = static_cast<int>(q->Int(kSessionColumnCount + 4));
    out.push_back(std::move(s));
  }
  return out;
}

std::optional<SessionLab> LatestLabYaml(Database& db, int64_t robot_id) {
  auto q = Sql(db,
               "SELECT id, lab_yaml FROM sessions WHERE robot_id = ? AND coalesce(lab_yaml, '') "
               "<> '' ORDER BY id DESC LIMIT 1");
  q->Bind(1, robot_id);
  if (!q->Step()) return std::nullopt;
  return SessionLab{q->Int(0), q->Text(1)};
}

}  // namespace armsig::db
