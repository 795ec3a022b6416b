// `db push`: a cell's database copied into a central store, idempotent and resumable. The
// cell holds simulated sessions of a PUMA 760 and parameter sets the nightly job fitted;
// what the central store gives back (poses, active parameters) is read through the same
// db/ readers the commands use and compared with the cell's.
#include "db/push.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <map>

#include "calibration/synthetic.h"
#include "core/error.h"
#include "db/calibrations.h"
#include "db/database.h"
#include "db/robots.h"
#include "db/sessions.h"
#include "db/streams.h"
#include "support/simulated_sessions.h"
#include "support/stores.h"
#include "test_support.h"
#include "workflows/lifecycle.h"
#include "nightly/recalibrate.h"

namespace armsig::testing {

namespace {

nightly::RecalibrateOptions Nightly(const std::string& path) {
  nightly::RecalibrateOptions o;
  o.db_path = path;
  o.robot = "puma";
  o.residual_model = "off";
  return o;
}

// A cell: two finished sessions, one parameter set fitted on them (active).
void MakeCell(const std::string& path) {
  {
    db::Database database(path);
    AddSession(database, calibration::PaperTable3Parameters(), 60, 1);
    AddSession(database, calibration::PaperTable3Parameters(), 60, 2);
  }
  const auto fit = nightly::Recalibrate(Nightly(path));
  ASSERT_EQ(fit.outcome, nightly::RecalibrationDecision::Outcome::kStored) << fit.Describe();
}

// The cell with a third session and a second version fitted on all three (active).
void MakeCellWithTwoVersions(const std::string& path) {
  MakeCell(path);
  {
    db::Database database(path);
    AddSession(database, calibration::PaperTable3Parameters(), 60, 3);
  }
  ASSERT_EQ(nightly::Recalibrate(Nightly(path)).outcome,
            nightly::RecalibrationDecision::Outcome::kStored);
}

std::map<std::string, int64_t> Counts(db::Database& database) {
  std::map<std::string, int64_t> out;
  for (const auto& c : database.RowCounts()) out[c.table] = c.rows;
  return out;
}

db::PushSummary PushFiles(const std::string& from, const std::string& to) {
  db::Database source(from, db::OpenMode::kMustExist);
  db::Database target(to);
  return db::Push(source.connection(), target.connection(), {from, nullptr});
}

// The robot's measured poses as the nightly job reads them, keyed by label and in the
// order of their session's start (pose ids carry the session id, which differs).
std::vector<std::pair<std::string, Eigen::Vector3d>> Poses(const std::string& path) {
  db::Database database(path, db::OpenMode::kMustExist);
  const auto robot = db::FindRobot(database, "puma");
  EXPECT_TRUE(robot.has_value());
  std::vector<std::pair<std::string, Eigen::Vector3d>> out;
  if (!robot) return out;
  for (const auto& p : db::LoadRobotPoses(database, *robot, "")) {
    out.emplace_back(p.id.substr(p.id.find(':') + 1) + " " + std::to_string(p.joints_rad.sum()),
                     p.target_in_world);
  }
  return out;
}

// A connection that is cut after `budget` calls have reached the server (prepare, each
// run of a statement, begin, commit): every later call fails as on a dropped connection
// (the server rolls back the open transaction).
class CutConnection : public db::Connection {
 public:
  CutConnection(db::Connection& inner, int budget) : inner_(inner), budget_(budget) {}
  db::Backend backend() const override { return inner_.backend(); }
  std::unique_ptr<db::Statement> Prepare(std::string_view sql) override {
    Spend();
    return std::make_unique<CutStatement>(*this, inner_.Prepare(sql));
  }
  void Exec(std::string_view sql) override {
    Spend();
    inner_.Exec(sql);
  }
  void Begin(db::TransactionKind kind) override {
    Spend();
    inner_.Begin(kind);
  }
  void Commit() override {
    Spend();
    inner_.Commit();
  }
  void Rollback() override { inner_.Rollback(); }
  const std::string& name() const override { return inner_.name(); }

 private:
  class CutStatement : public db::Statement {
   public:
    CutStatement(CutConnection& c, std::unique_ptr<db::Statement> s) : c_(c), s_(std::move(s)) {}
    void BindNull(int i) override { s_->BindNull(i); }
    void Bind(int i, int64_t v) override { s_->Bind(i, v); }
    void Bind(int i, double v) override { s_->Bind(i, v); }
    void Bind(int i, std::string_view v) override { s_->Bind(i, v); }
    void BindBlob(int i, std::string_view v) override { s_->BindBlob(i, v); }
    bool Step() override {
      c_.Spend();
      return s_->Step();
    }
    int64_t Execute() override {
      c_.Spend();
      return s_->Execute();
    }
    int Columns() const override { return s_->Columns(); }
    std::string ColumnName(int k) const override { return s_->ColumnName(k); }
    Type ColumnType(int k) const override { return s_->ColumnType(k); }
    bool IsNull(int k) const override { return s_->IsNull(k); }
    int64_t Int(int k) const override { return s_->Int(k); }
    double Double(int k) const override { return s_->Double(k); }
    std::string Text(int k) const override { return s_->Text(k); }
    std::string Blob(int k) const override { return s_->Blob(k); }

   private:
    CutConnection& c_;
    std::unique_ptr<db::Statement> s_;
  };
  void Spend() {
    if (--budget_ < 0) throw db::DatabaseError(name() + ": connection lost", "08006", false);
  }
  db::Connection& inner_;
  int budget_;
};

}  // namespace

// The central store on either backend (a cell is always a SQLite file).
class Push : public ::testing::TestWithParam<db::Backend> {};

// Pushed twice: the second push stores nothing. The central store reads back the same
// poses and the same active parameters as the cell.
TEST_P(Push, TwiceDoublesNothingAndTheStoreReadsBackTheCell) {
  TempDir dir;
  const std::string cell = dir.File("cell.db"), central = NewStore(GetParam(), dir, "central");
  MakeCell(cell);
  const auto first = PushFiles(cell, central);
  EXPECT_EQ(first.sessions_pushed, 2);
  EXPECT_EQ(first.poses, 120);
  EXPECT_EQ(first.points, 120);
  EXPECT_EQ(first.sets_pushed, 1);
  EXPECT_EQ(first.activated, 1);
  EXPECT_EQ(first.robots_created, 1);
  const auto second = PushFiles(cell, central);
  EXPECT_EQ(second.sessions_pushed, 0);
  EXPECT_EQ(second.sets_pushed, 0);
  EXPECT_EQ(second.sessions_present, 2);
  EXPECT_EQ(second.sets_present, 1);
  EXPECT_EQ(second.activated, 0);

  db::Database a(cell, db::OpenMode::kMustExist), b(central, db::OpenMode::kMustExist);
  auto from = Counts(a), to = Counts(b);
  for (const char* table : {"robots", "sessions", "poses", "points", "observations", "calibrations",
                            "calibration_parameters", "validation_residuals"}) {
    EXPECT_EQ(to[table], from[table]) << table;
  }
  EXPECT_EQ(Poses(central), Poses(cell));
  const auto robot_a = db::FindRobot(a, "puma"), robot_b = db::FindRobot(b, "puma");
  ASSERT_TRUE(robot_a && robot_b);
  const auto active_a = db::ActiveCalibration(a, *robot_a),
             active_b = db::ActiveCalibration(b, *robot_b);
  ASSERT_TRUE(active_a && active_b);
  ASSERT_EQ(active_b->parameters.size(), active_a->parameters.size());
  for (size_t k = 0; k < active_a->parameters.size(); ++k) {
    EXPECT_EQ(active_b->parameters[k].name, active_a->parameters[k].name);
    EXPECT_EQ(active_b->parameters[k].value, active_a->parameters[k].value);
  }
  EXPECT_TRUE(active_b->world_from_base->isApprox(*active_a->world_from_base, 0.0));
  EXPECT_EQ(active_b->covariance, active_a->covariance);
  // The set's inputs name the server's sessions.
  const auto inputs = nlohmann::json::parse(active_b->inputs_json);
  const auto server_sessions = db::SessionIds(b);
  for (const auto& id : inputs["sessions"]) {
    EXPECT_NE(std::find(server_sessions.begin(), server_sessions.end(), id.get<int64_t>()),
              server_sessions.end());
  }
  // The activation on the server is the cell's: who made the set active, when and why.
  const auto history = db::ActivationHistory(b, *robot_b);
  const auto history_a = db::ActivationHistory(a, *robot_a);
  ASSERT_EQ(history.size(), 1u);
  ASSERT_EQ(history_a.size(), 1u);
  EXPECT_EQ(history[0].activated_by, "recalibrate");
  EXPECT_EQ(history[0].note, history_a[0].note);
  EXPECT_EQ(history[0].activated_at, history_a[0].activated_at);
}

// The connection is cut at every possible statement in turn: each push leaves whole
// sessions and sets or nothing of them, and the next one completes the store, every row
// once.
TEST_P(Push, ACutConnectionLeavesWholeItemsAndTheNextPushCompletes) {
  TempDir dir;
  const std::string cell = dir.File("cell.db");
  MakeCell(cell);
  std::map<std::string, int64_t> want;
  {
    db::Database a(cell, db::OpenMode::kMustExist);
    want = Counts(a);
  }
  int cuts = 0;
  for (int budget = 0;; budget += 13) {
    const std::string central = NewStore(GetParam(), dir, "central" + std::to_string(budget));
    bool was_cut = false;
    {
      db::Database source(cell, db::OpenMode::kMustExist);
      db::Database target(central);
      CutConnection cut(target.connection(), budget);
      try {
        db::Push(source.connection(), cut, {cell, nullptr});
      } catch (const db::DatabaseError& e) {
        was_cut = true;
        EXPECT_NE(std::string(e.what()).find("connection lost"), std::string::npos) << e.what();
      }
      // Whatever was stored is whole: each stored session has all of its poses.
      const int64_t sessions = target.connection().QueryInt(
          "SELECT count(*) FROM sessions s WHERE (SELECT count(*) FROM poses p WHERE "
          "p.session_id = s.id) <> 60");
      EXPECT_EQ(sessions, 0) << "budget " << budget;
      const int64_t sets = target.connection().QueryInt(
          "SELECT count(*) FROM calibrations c WHERE NOT EXISTS (SELECT 1 FROM "
          "calibration_parameters p WHERE p.calibration_id = c.id)");
      EXPECT_EQ(sets, 0) << "budget " << budget;
    }
    PushFiles(cell, central);
    db::Database b(central, db::OpenMode::kMustExist);
    auto to = Counts(b);
    for (const char* table : {"robots", "sessions", "poses", "points", "observations",
                              "calibrations", "calibration_parameters", "validation_residuals"}) {
      EXPECT_EQ(to[table], want[table]) << table << ", cut after " << budget << " statements";
    }
    EXPECT_EQ(to["activations"], 1) << budget;
    if (!was_cut) break;
    ++cuts;
  }
  EXPECT_GT(cuts, 20);  // the cut fell in every part of the push
}

// Open sessions wait; a robot with another model on the server is refused by name.
TEST_P(Push, OpenSessionsWaitAndAnotherModelIsRefused) {
  TempDir dir;
  const std::string cell = dir.File("cell.db"), central = NewStore(GetParam(), dir, "central");
  MakeCell(cell);
  {
    db::Database a(cell, db::OpenMode::kMustExist);
    db::SetSessionState(a, 2, db::SessionState::kPaused);
  }
  auto s = PushFiles(cell, central);
  EXPECT_EQ(s.sessions_pushed, 1);
  ASSERT_EQ(s.open_sessions.size(), 1u);
  EXPECT_EQ(s.open_sessions[0], "session 2 (paused)");
  {
    db::Database a(cell, db::OpenMode::kMustExist);
    db::SetSessionState(a, 2, db::SessionState::kCompleted);
  }
  s = PushFiles(cell, central);
  EXPECT_EQ(s.sessions_pushed, 1);
  EXPECT_EQ(s.sessions_present, 1);
  EXPECT_TRUE(s.open_sessions.empty());

  const std::string other = NewStore(GetParam(), dir, "other");
  {
    db::Database b(other);
    b.connection().Exec(
        "INSERT INTO robots(name, model_name, model_yaml) VALUES ('puma', 'x', 'x')");
  }
  try {
    PushFiles(cell, other);
    ADD_FAILURE() << "pushed onto another model";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("robot puma has another model"), std::string::npos)
        << e.what();
  }
  db::Database b(other, db::OpenMode::kMustExist);
  EXPECT_EQ(b.connection().QueryInt("SELECT count(*) FROM sessions"), 0);
}

// The activation history as it is in the cell — every activation with who made it, when,
// why and what it replaced (in the server's version numbers) — and the cell's active set,
// also after a roll-back there; a second push changes nothing.
TEST_P(Push, CarriesEveryActivationAndTheActiveStateOnce) {
  TempDir dir;
  const std::string cell = dir.File("cell.db"), central = NewStore(GetParam(), dir, "central");
  MakeCellWithTwoVersions(cell);
  {
    db::Database database(cell);
    workflows::Activate(database, "puma", 1, "version 2 moved the tool");  // a roll-back
    // Activating the active version changes nothing and records nothing.
    const int64_t robot = *db::FindRobot(database, "puma");
    const size_t recorded = db::ActivationHistory(database, robot).size();
    EXPECT_EQ(workflows::Activate(database, "puma", 1, "again"), 1);
    EXPECT_EQ(db::ActivationHistory(database, robot).size(), recorded);
  }
  const auto first = PushFiles(cell, central);
  EXPECT_EQ(first.activations_pushed, 3);
  EXPECT_EQ(first.activated, 1);
  const auto second = PushFiles(cell, central);
  EXPECT_EQ(second.activations_pushed, 0);
  EXPECT_EQ(second.activated, 0);
  db::Database a(cell, db::OpenMode::kMustExist), b(central, db::OpenMode::kMustExist);
  const auto history_a = db::ActivationHistory(a, *db::FindRobot(a, "puma"));
  const auto history_b = db::ActivationHistory(b, *db::FindRobot(b, "puma"));
  ASSERT_EQ(history_b.size(), history_a.size());
  for (size_t k = 0; k < history_a.size(); ++k) {
    // One push into an empty server: the versions keep their numbers.
    EXPECT_EQ(history_b[k].version, history_a[k].version) << k;
    EXPECT_EQ(history_b[k].previous_version, history_a[k].previous_version) << k;
    EXPECT_EQ(history_b[k].activated_by, history_a[k].activated_by) << k;
    EXPECT_EQ(history_b[k].activated_at, history_a[k].activated_at) << k;
    EXPECT_EQ(history_b[k].note, history_a[k].note) << k;
  }
  EXPECT_EQ(history_b.back().activated_by, "activate");
  EXPECT_EQ(history_b.back().note, "version 2 moved the tool");
  const auto active_b = db::ActiveCalibration(b, *db::FindRobot(b, "puma"));
  ASSERT_TRUE(active_b.has_value());
  EXPECT_EQ(active_b->version, 1);
}

// Issue 38 (clocks): "a later activation" was decided by comparing the two machines' clock
// texts, so a cell whose clock runs two days ahead undid an operator's roll-back on the
// server at every push, and no activation row said so. The server's own order decides: a
// roll-back made there stands until the cell activates something new, which then follows as
// a row of its own.
TEST_P(Push, ARollBackOnTheServerStandsWhateverTheCellsClock) {
  TempDir dir;
  const std::string cell = dir.File("cell.db"), central = NewStore(GetParam(), dir, "central");
  MakeCellWithTwoVersions(cell);
  {
    db::Database database(cell);  // the cell's clock two days ahead when it activated
    database.connection().Exec("UPDATE activations SET activated_at = '2099-01-01T00:00:00.000Z'");
  }
  PushFiles(cell, central);
  auto active_on_server = [&] {
    db::Database b(central, db::OpenMode::kMustExist);
    return db::ActiveCalibration(b, *db::FindRobot(b, "puma"))->version;
  };
  ASSERT_EQ(active_on_server(), 2);
  {
    db::Database b(central, db::OpenMode::kMustExist);
    workflows::Activate(b, "puma", 1, "version 2 moved the tool (operator on the server)");
  }
  const auto again = PushFiles(cell, central);
  EXPECT_EQ(again.activated, 0);
  EXPECT_EQ(active_on_server(), 1);  // the roll-back stands
  // The cell activates again: that is news, carried as its own row and followed.
  {
    db::Database database(cell);
    workflows::Activate(database, "puma", 1, "the cell agrees");
    workflows::Activate(database, "puma", 2, "the cell goes back to 2");
  }
  const auto news = PushFiles(cell, central);
  EXPECT_EQ(news.activations_pushed, 2);
  EXPECT_EQ(news.activated, 1);
  EXPECT_EQ(active_on_server(), 2);
  db::Database b(central, db::OpenMode::kMustExist);
  const auto history = db::ActivationHistory(b, *db::FindRobot(b, "puma"));
  ASSERT_FALSE(history.empty());
  EXPECT_EQ(history.back().note, "the cell goes back to 2");
}

// A session measured on the move carries its raw streams (joint packages, tracker records,
// what broke the beam), its clock estimate and each paired point's clock share to the
// server: the server reads the same streams and weighs the points alike.
TEST_P(Push, ASweptSessionCarriesItsStreamsClockAndWeights) {
  TempDir dir;
  const std::string cell = dir.File("cell.db"), central = NewStore(GetParam(), dir, "central");
  MakeCell(cell);
  db::StreamSegment segment;
  for (int k = 0; k < 70; ++k) {  // more than one batch of rows
    segment.joints.push_back({0.008 * k, Eigen::VectorXd::Constant(6, 0.01 * k),
                              Eigen::VectorXd::Constant(6, 1.25)});
    segment.points.push_back({"T1", 100.0 + 0.05 * k, 0.1 * k, 1.5, 2000.0 + k, k % 2});
  }
  segment.events.push_back({"T1", 101.5, 9, "ES_RS_NoDistanceSet"});
  const std::string sync = R"({"mode":"on_the_move","offset_ms":145.4,"paired":true})";
  {
    db::Database a(cell, db::OpenMode::kMustExist);
    db::WriteTransaction tx(a);
    db::InsertStreamSegment(a, 1, segment);
    segment.segment = 1;
    db::InsertStreamSegment(a, 1, segment);
    db::SetSessionSync(a, 1, sync);
    a.connection().Exec("UPDATE points SET sync_sigma_mm = 0.004 * id WHERE session_id = 1");
    tx.commit();
  }
  const auto pushed = PushFiles(cell, central);
  EXPECT_EQ(pushed.sessions_pushed, 2);
  EXPECT_EQ(pushed.stream_rows, 2 * (70 + 70 + 1));
  db::Database a(cell, db::OpenMode::kMustExist), b(central, db::OpenMode::kMustExist);
  auto uuid = a.connection().Prepare("SELECT uuid FROM sessions WHERE id = 1");
  ASSERT_TRUE(uuid->Step());
  auto by_uuid = b.connection().Prepare("SELECT id FROM sessions WHERE uuid = ?");
  by_uuid->Bind(1, uuid->Text(0));
  ASSERT_TRUE(by_uuid->Step());
  const int64_t server = by_uuid->Int(0);
  EXPECT_EQ(db::SessionSync(b, server), sync);
  const db::SessionStreams from = db::LoadSessionStreams(a, 1), to = db::LoadSessionStreams(b, server);
  ASSERT_EQ(to.joints.size(), from.joints.size());
  ASSERT_EQ(to.points.size(), from.points.size());
  ASSERT_EQ(to.events.size(), from.events.size());
  for (size_t k = 0; k < from.joints.size(); ++k) {
    EXPECT_EQ(to.joints[k].t_s, from.joints[k].t_s);
    EXPECT_EQ(to.joints[k].q_rad, from.joints[k].q_rad);
  }
  for (size_t k = 0; k < from.points.size(); ++k) {
    EXPECT_EQ(to.points[k].station, from.points[k].station);
    EXPECT_EQ(to.points[k].segment, from.points[k].segment);
    EXPECT_EQ(to.points[k].t_s, from.points[k].t_s);
    EXPECT_EQ(to.points[k].distance_mm, from.points[k].distance_mm);
    EXPECT_EQ(to.points[k].status, from.points[k].status);
  }
  EXPECT_EQ(to.events[0].what, "ES_RS_NoDistanceSet");
  // Each point's clock share (the estimator's weight comes from it) is the cell's.
  const auto shares = [](db::Database& d, int64_t id) {
    auto q = d.connection().Prepare(
        "SELECT p.sync_sigma_mm FROM points p JOIN poses o ON o.id = p.pose_id "
        "WHERE p.session_id = ? ORDER BY o.seq");
    q->Bind(1, id);
    std::vector<double> out;
    while (q->Step()) out.push_back(q->IsNull(0) ? -1.0 : q->Double(0));
    return out;
  };
  const auto from_shares = shares(a, 1);
  ASSERT_EQ(from_shares.size(), 60u);
  EXPECT_GT(*std::min_element(from_shares.begin(), from_shares.end()), 0.0);
  EXPECT_EQ(shares(b, server), from_shares);
  EXPECT_EQ(PushFiles(cell, central).stream_rows, 0);  // and once only
}

ARMSIG_BOTH_BACKENDS(Push);

}  // namespace armsig::testing
