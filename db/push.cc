#include "db/push.h"

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <boost/uuid/random_generator.hpp>
#include <boost/uuid/uuid_io.hpp>
#include <functional>
#include <map>
#include <set>
#include <nlohmann/json.hpp>
#include <optional>
#include <variant>

#include "core/error.h"
#include "core/text.h"
#include "db/database.h"
#include "db/stored_json.h"

namespace armsig::db {

namespace {

// A column copied as it is: its name and how it is read and bound.
enum class Kind { kInt, kReal, kText };
struct Column {
  const char* name;
  Kind kind;
};

void CopyValue(const Statement& from, int column, Statement& to, int index, Kind kind) {
  if (from.IsNull(column)) {
    to.BindNull(index);
    return;
  }
  switch (kind) {
    case Kind::kInt:
      to.Bind(index, from.Int(column));
      break;
    case Kind::kReal:
      to.Bind(index, from.Double(column));
      break;
    case Kind::kText:
      to.Bind(index, from.Text(column));
      break;
  }
}

// A value read from the cell, kept until its batch is written.
using Value = std::variant<std::monostate, int64_t, double, std::string>;

Value ValueOf(const Statement& from, int column, Kind kind) {
  if (from.IsNull(column)) return std::monostate{};
  switch (kind) {
    case Kind::kInt:
      return from.Int(column);
    case Kind::kReal:
      return from.Double(column);
    case Kind::kText:
      return from.Text(column);
  }
  return std::monostate{};
}

Value ValueOf(std::optional<int64_t> id) {
  return id ? Value(*id) : Value(std::monostate{});
}

// Rows of one table written kRows at a time: one multi-row INSERT, one round trip to a
// server instead of one per row (a session's observations are thousands of rows).
class BatchedInsert {
 public:
  static constexpr int kRows = 64;
  // `head`: "INSERT INTO table(columns…)"; every row has `columns` values. With
  // `returning` ("RETURNING id, seq"), `on_returned` is called with each returned row.
  BatchedInsert(Connection& target, std::string head, int columns, std::string returning = "",
                std::function<void(const Statement&)> on_returned = {})
      : target_(target),
        head_(std::move(head)),
        columns_(columns),
        returning_(std::move(returning)),
        on_returned_(std::move(on_returned)) {}
  void Row(std::vector<Value> values) {
    values_.insert(values_.end(), std::make_move_iterator(values.begin()),
                   std::make_move_iterator(values.end()));
    if (static_cast<int>(values_.size()) == kRows * columns_) Flush();
  }
  void Flush() {
    const int rows = static_cast<int>(values_.size()) / columns_;
    if (rows == 0) return;
    std::string sql = head_ + " VALUES ";
    std::string marks = "(";
    for (int c = 0; c < columns_; ++c) marks += c ? ",?" : "?";
    marks += ")";
    for (int r = 0; r < rows; ++r) sql += (r ? "," : "") + marks;
    if (!returning_.empty()) sql += " " + returning_;
    auto& statement = statements_[rows];
    if (!statement) statement = target_.Prepare(sql);
    for (size_t k = 0; k < values_.size(); ++k) {
      const int index = static_cast<int>(k) + 1;
      std::visit(
          [&](const auto& v) {
            using T = std::decay_t<decltype(v)>;
            if constexpr (std::is_same_v<T, std::monostate>)
              statement->BindNull(index);
            else
              statement->Bind(index, v);
          },
          values_[k]);
    }
    if (returning_.empty()) {
      statement->Execute();
    } else {
      while (statement->Step()) on_returned_(*statement);
    }
    values_.clear();
  }

 private:
  Connection& target_;
  std::string head_;
  int columns_;
  std::string returning_;
  std::function<void(const Statement&)> on_returned_;
  std::vector<Value> values_;
  std::map<int, std::unique_ptr<Statement>> statements_;  // by rows
};

// The copied columns of each table, beside its id and the ids that are mapped.
constexpr Column kInstrumentColumns[] = {
    {"kind", Kind::kText},           {"protocol", Kind::kText},
    {"port", Kind::kText},           {"serial_number", Kind::kText},
    {"firmware", Kind::kText},       {"sigma_hz_arcsec", Kind::kReal},
    {"sigma_v_arcsec", Kind::kReal}, {"sigma_distance_mm", Kind::kReal},
    {"created_at", Kind::kText}};
constexpr Column kSessionColumns[] = {{"lab_yaml", Kind::kText},
                                      {"plan_json", Kind::kText},
                                      {"state", Kind::kText},
                                      {"note", Kind::kText},
                                      {"started_at", Kind::kText},
                                      {"finished_at", Kind::kText},
                                      {"kind", Kind::kText},
                                      {"controller_model", Kind::kText},
                                      {"controller_serial", Kind::kText},
                                      {"controller_software", Kind::kText},
                                      {"kinematics_checksum", Kind::kText},
                                      {"kinematics_json", Kind::kText},
                                      {"sync_json", Kind::kText}};
constexpr Column kSetupColumns[] = {
    {"x_mm", Kind::kReal},          {"y_mm", Kind::kReal},         {"z_mm", Kind::kReal},
    {"levelled", Kind::kInt},       {"azimuth_rad", Kind::kReal},  {"rotation_json", Kind::kText},
    {"sx_mm", Kind::kReal},         {"sy_mm", Kind::kReal},        {"sz_mm", Kind::kReal},
    {"s_azimuth_rad", Kind::kReal}, {"sigma0", Kind::kReal},       {"dof", Kind::kInt},
    {"method", Kind::kText},        {"sigma_hz_rad", Kind::kReal}, {"sigma_v_rad", Kind::kReal},
    {"created_at", Kind::kText}};
constexpr Column kPoseColumns[] = {{"seq", Kind::kInt},          {"label", Kind::kText},
                                   {"joints_json", Kind::kText}, {"status", Kind::kText},
                                   {"attempts", Kind::kInt},     {"captured_at", Kind::kText},
                                   {"controller_time_s", Kind::kReal}};
constexpr Column kObservationColumns[] = {{"point", Kind::kText},
                                          {"hz_rad", Kind::kReal},
                                          {"v_rad", Kind::kReal},
                                          {"distance_mm", Kind::kReal},
                                          {"face", Kind::kInt},
                                          {"sigma_hz_arcsec", Kind::kReal},
                                          {"sigma_v_arcsec", Kind::kReal},
                                          {"sigma_distance_mm", Kind::kReal},
                                          {"return_code", Kind::kInt},
                                          {"measured_at", Kind::kText},
                                          {"temperature_c", Kind::kReal},
                                          {"pressure_hpa", Kind::kReal},
                                          {"humidity_percent", Kind::kReal},
                                          {"note", Kind::kText}};
constexpr Column kPointColumns[] = {{"point", Kind::kText},  {"x_mm", Kind::kReal},
                                    {"y_mm", Kind::kReal},   {"z_mm", Kind::kReal},
                                    {"sx_mm", Kind::kReal},  {"sy_mm", Kind::kReal},
                                    {"sz_mm", Kind::kReal},  {"covariance_json", Kind::kText},
                                    {"rays", Kind::kInt},    {"rejected_rays", Kind::kInt},
                                    {"sigma0", Kind::kReal}, {"miss_mm", Kind::kReal},
                                    {"flags", Kind::kText},  {"reduced_at", Kind::kText},
                                    {"rx_rad", Kind::kReal}, {"ry_rad", Kind::kReal},
                                    {"rz_rad", Kind::kReal}, {"sigma_rx_rad", Kind::kReal},
                                    {"sigma_ry_rad", Kind::kReal},
                                    {"sigma_rz_rad", Kind::kReal},
                                    {"sync_sigma_mm", Kind::kReal}};
// A session measured on the move: its raw streams (db/streams.h), station ids mapped.
constexpr Column kStreamJointColumns[] = {
    {"segment", Kind::kInt}, {"t_s", Kind::kReal}, {"q_json", Kind::kText}, {"qd_json", Kind::kText}};
constexpr Column kStreamPointColumns[] = {{"t_s", Kind::kReal},         {"hz_rad", Kind::kReal},
                                          {"v_rad", Kind::kReal},       {"distance_mm", Kind::kReal},
                                          {"status", Kind::kInt},       {"segment", Kind::kInt}};
constexpr Column kStreamEventColumns[] = {{"t_s", Kind::kReal},
                                          {"status", Kind::kInt},
                                          {"what", Kind::kText},
                                          {"segment", Kind::kInt}};
constexpr Column kCalibrationColumns[] = {
    {"params_spec", Kind::kText},        {"inputs_json", Kind::kText},
    {"options_json", Kind::kText},       {"rank", Kind::kInt},
    {"poses_fit", Kind::kInt},           {"poses_validation", Kind::kInt},
    {"nominal_mean_mm", Kind::kReal},    {"nominal_max_mm", Kind::kReal},
    {"nominal_rms_mm", Kind::kReal},     {"fit_mean_mm", Kind::kReal},
    {"fit_max_mm", Kind::kReal},         {"fit_rms_mm", Kind::kReal},
    {"validation_mean_mm", Kind::kReal}, {"validation_max_mm", Kind::kReal},
    {"validation_rms_mm", Kind::kReal},  {"report_json", Kind::kText},
    {"created_at", Kind::kText},         {"world_from_base_json", Kind::kText},
    {"covariance_json", Kind::kText},    {"drift_json", Kind::kText},
    {"residual_map_json", Kind::kText},  {"tool_rotation_json", Kind::kText},
    {"validity_json", Kind::kText}};
constexpr Column kParameterColumns[] = {{"name", Kind::kText},
                                        {"value", Kind::kReal},
                                        {"unit", Kind::kText},
                                        {"identified", Kind::kInt},
                                        {"sigma", Kind::kReal},
                                        {"seq", Kind::kInt}};
constexpr Column kResidualColumns[] = {{"pose_label", Kind::kText},
                                       {"role", Kind::kText},
                                       {"dx_mm", Kind::kReal},
                                       {"dy_mm", Kind::kReal},
                                       {"dz_mm", Kind::kReal},
                                       {"distance_mm", Kind::kReal},
                                       {"nominal_distance_mm", Kind::kReal}};

template <size_t N>
std::string Names(const Column (&columns)[N]) {
  std::string out;
  for (const auto& c : columns) out += std::string(out.empty() ? "" : ", ") + c.name;
  return out;
}
// The placeholders of the copied columns and `extra` more.
template <size_t N>
std::string Marks(const Column (&)[N], int extra) {
  std::string out;
  for (size_t k = 0; k < N + static_cast<size_t>(extra); ++k) out += k ? ",?" : "?";
  return out;
}
// Binds columns [first, first + N) of `from` as parameters [index, index + N) of `to`.
template <size_t N>
void CopyColumns(const Statement& from, int first, Statement& to, int index,
                 const Column (&columns)[N]) {
  for (size_t k = 0; k < N; ++k)
    CopyValue(from, first + static_cast<int>(k), to, index + static_cast<int>(k), columns[k].kind);
}

int64_t InsertedId(Statement& insert, const Connection& target, const std::string& what) {
  return db::InsertedId(insert, target.name() + ": " + what);
}

std::string NewUuid() {
  static thread_local boost::uuids::random_generator generator;
  return boost::uuids::to_string(generator());
}

// The server's ids of the cell's robots, stations and instruments (by name), created on the
// server when new.
class NameMap {
 public:
  NameMap(Connection& source, Connection& target, PushSummary& summary)
      : source_(source), target_(target), summary_(summary) {}

  int64_t Robot(int64_t local) {
    if (auto it = robots_.find(local); it != robots_.end()) return it->second;
    auto s =
        source_.Prepare("SELECT name, model_name, model_yaml, created_at FROM robots WHERE id = ?");
    s->Bind(1, local);
    if (!s->Step())
      throw DatabaseError(source_.name() + ": no robot " + std::to_string(local), "", false);
    const std::string name = s->Text(0), model_yaml = s->Text(2);
    auto t = target_.Prepare("SELECT id, model_yaml FROM robots WHERE name = ?");
    t->Bind(1, name);
    int64_t id = 0;
    if (t->Step()) {
      if (t->Text(1) != model_yaml) {
        throw InputError({source_.name(), 0, 0, "robots"},
                         fmt::format("robot {} has another model on {} than in this cell's "
                                     "database: nothing of it is pushed (compare `armsig robot "
                                     "list` on both; a robot renamed in the cell is pushed under "
                                     "its new name)",
                                     name, target_.name()));
      }
      id = t->Int(0);
    } else {
      auto insert = target_.Prepare(
          "INSERT INTO robots(name, model_name, model_yaml, created_at) VALUES (?,?,?,?) "
          "RETURNING id");
      insert->Bind(1, name);
      insert->Bind(2, s->Text(1));
      insert->Bind(3, model_yaml);
      insert->Bind(4, s->Text(3));
      id = InsertedId(*insert, target_, "robot " + name);
      ++summary_.robots_created;
    }
    {
      // The arm's controller identity (kept where the server has one) and its newest
      // kinematics (schema v14).
      auto c = source_.Prepare(
          "SELECT controller_model, controller_serial, kinematics_checksum, kinematics_json "
          "FROM robots WHERE id = ? AND controller_serial IS NOT NULL");
      c->Bind(1, local);
      if (c->Step()) {
        auto u = target_.Prepare(
            "UPDATE robots SET controller_model = coalesce(controller_model, ?), "
            "controller_serial = coalesce(controller_serial, ?), kinematics_checksum = "
            "coalesce(?, kinematics_checksum), kinematics_json = coalesce(?, kinematics_json) "
            "WHERE id = ?");
        for (int k = 0; k < 4; ++k) CopyValue(*c, k, *u, k + 1, Kind::kText);
        u->Bind(5, id);
        u->Execute();
      }
    }
    robots_[local] = id;
    return id;
  }

  std::optional<int64_t> Instrument(std::optional<int64_t> local) {
    if (!local) return std::nullopt;
    if (auto it = instruments_.find(*local); it != instruments_.end()) return it->second;
    auto s = source_.Prepare("SELECT name, " + Names(kInstrumentColumns) +
                             " FROM instruments WHERE id = ?");
    s->Bind(1, *local);
    if (!s->Step()) return std::nullopt;
    const int64_t id = Ensure("instruments", "name", s->Text(0), [&] {
      auto insert = target_.Prepare("INSERT INTO instruments(name, " + Names(kInstrumentColumns) +
                                    ") VALUES (" + Marks(kInstrumentColumns, 1) + ") RETURNING id");
      insert->Bind(1, s->Text(0));
      CopyColumns(*s, 1, *insert, 2, kInstrumentColumns);
      return insert;
    });
    instruments_[*local] = id;
    return id;
  }

  int64_t Station(int64_t local) {
    if (auto it = stations_.find(local); it != stations_.end()) return it->second;
    auto s = source_.Prepare("SELECT code, instrument_id, description FROM stations WHERE id = ?");
    s->Bind(1, local);
    if (!s->Step())
      throw DatabaseError(source_.name() + ": no station " + std::to_string(local), "", false);
    const std::string code = s->Text(0);
    const auto instrument = Instrument(s->OptionalInt(1));
    const int64_t id = Ensure("stations", "code", code, [&] {
      auto insert = target_.Prepare(
          "INSERT INTO stations(code, instrument_id, description) VALUES (?,?,?) RETURNING id");
      insert->Bind(1, code);
      insert->Bind(2, instrument);
      if (s->IsNull(2))
        insert->BindNull(3);
      else
        insert->Bind(3, s->Text(2));
      return insert;
    });
    stations_[local] = id;
    return id;
  }

  // A new transaction on the server may have rolled back rows this map created: forget them.
  void Forget() {
    robots_.clear();
    stations_.clear();
    instruments_.clear();
  }

 private:
  template <typename MakeInsert>
  int64_t Ensure(const std::string& table, const std::string& key, const std::string& value,
                 MakeInsert make_insert) {
    auto t = target_.Prepare("SELECT id FROM " + table + " WHERE " + key + " = ?");
    t->Bind(1, value);
    if (t->Step()) return t->Int(0);
    auto insert = make_insert();
    return InsertedId(*insert, target_, table + " " + value);
  }

  Connection& source_;
  Connection& target_;
  PushSummary& summary_;
  std::map<int64_t, int64_t> robots_, stations_, instruments_;
};

// Gives every finished session and every parameter set of the cell a UUID (one local
// transaction): their identity on every server they are pushed to.
void AssignUuids(Connection& source) {
  Transaction tx(source, TransactionKind::kWrite);
  for (const char* table : {"sessions", "calibrations", "activations"}) {
    std::vector<int64_t> ids;
    auto q = source.Prepare(
        std::string("SELECT id FROM ") + table + " WHERE uuid IS NULL" +
        (std::string(table) == "sessions" ? " AND state IN ('completed','aborted')" : ""));
    while (q->Step()) ids.push_back(q->Int(0));
    auto u = source.Prepare(std::string("UPDATE ") + table + " SET uuid = ? WHERE id = ?");
    for (const int64_t id : ids) {
      u->Bind(1, NewUuid());
      u->Bind(2, id);
      u->Execute();
    }
  }
  tx.Commit();
}

std::optional<int64_t> ServerIdOf(Connection& target, const char* table, const std::string& uuid) {
  auto t = target.Prepare(std::string("SELECT id FROM ") + table + " WHERE uuid = ?");
  t->Bind(1, uuid);
  if (t->Step()) return t->Int(0);
  return std::nullopt;
}

// One session with everything measured in it, in one server transaction.
// The raw streams of a session measured on the move (none for a stationary one), in the
// caller's transaction; returns the rows copied.
int64_t PushStreams(Connection& source, Connection& target, NameMap& names, int64_t local,
                    int64_t session) {
  int64_t rows = 0;
  {
    auto q = source.Prepare("SELECT " + Names(kStreamJointColumns) +
                            " FROM stream_joints WHERE session_id = ? ORDER BY id");
    q->Bind(1, local);
    BatchedInsert w(target, "INSERT INTO stream_joints(session_id, " + Names(kStreamJointColumns) + ")",
                    1 + static_cast<int>(std::size(kStreamJointColumns)));
    while (q->Step()) {
      std::vector<Value> row = {session};
      for (size_t k = 0; k < std::size(kStreamJointColumns); ++k)
        row.push_back(ValueOf(*q, static_cast<int>(k), kStreamJointColumns[k].kind));
      w.Row(std::move(row));
      ++rows;
    }
    w.Flush();
  }
  // Points and events: the station by its code on the server.
  const auto with_station = [&](const char* table, const auto& columns) {
    auto q = source.Prepare("SELECT station_id, " + Names(columns) + " FROM " + table +
                            " WHERE session_id = ? ORDER BY id");
    q->Bind(1, local);
    BatchedInsert w(target,
                    std::string("INSERT INTO ") + table + "(session_id, station_id, " +
                        Names(columns) + ")",
                    2 + static_cast<int>(std::size(columns)));
    while (q->Step()) {
      std::vector<Value> row = {session, names.Station(q->Int(0))};
      for (size_t k = 0; k < std::size(columns); ++k)
        row.push_back(ValueOf(*q, 1 + static_cast<int>(k), columns[k].kind));
      w.Row(std::move(row));
      ++rows;
    }
    w.Flush();
  };
  with_station("stream_points", kStreamPointColumns);
  with_station("stream_events", kStreamEventColumns);
  return rows;
}

void PushSession(Connection& source, Connection& target, NameMap& names, int64_t local,
                 const std::string& uuid, PushSummary& summary) {
  Transaction tx(target, TransactionKind::kWrite);
  names.Forget();
  auto s =
      source.Prepare("SELECT robot_id, " + Names(kSessionColumns) + " FROM sessions WHERE id = ?");
  s->Bind(1, local);
  if (!s->Step()) return;
  const int64_t robot = names.Robot(s->Int(0));
  auto insert = target.Prepare("INSERT INTO sessions(robot_id, " + Names(kSessionColumns) +
                               ", uuid) VALUES (" + Marks(kSessionColumns, 2) + ") RETURNING id");
  insert->Bind(1, robot);
  CopyColumns(*s, 1, *insert, 2, kSessionColumns);
  insert->Bind(static_cast<int>(std::size(kSessionColumns)) + 2, uuid);
  const int64_t session = InsertedId(*insert, target, "a session");

  {
    auto q = source.Prepare("SELECT station_id, " + Names(kSetupColumns) +
                            " FROM station_setups WHERE session_id = ? ORDER BY id");
    q->Bind(1, local);
    auto w = target.Prepare("INSERT INTO station_setups(station_id, session_id, " +
                            Names(kSetupColumns) + ") VALUES (" + Marks(kSetupColumns, 2) + ")");
    while (q->Step()) {
      w->Bind(1, names.Station(q->Int(0)));
      w->Bind(2, session);
      CopyColumns(*q, 1, *w, 3, kSetupColumns);
      w->Execute();
    }
  }
  std::map<int64_t, int64_t> poses;  // the cell's pose id → the server's
  {
    // A session's poses are told apart by their plan index (unique per session): the
    // server's ids come back with it.
    auto q = source.Prepare("SELECT id, " + Names(kPoseColumns) +
                            " FROM poses WHERE session_id = ? ORDER BY id");
    q->Bind(1, local);
    std::map<int64_t, int64_t> local_by_seq, server_by_seq;
    BatchedInsert w(target, "INSERT INTO poses(session_id, " + Names(kPoseColumns) + ")",
                    1 + static_cast<int>(std::size(kPoseColumns)), "RETURNING seq, id",
                    [&](const Statement& r) { server_by_seq[r.Int(0)] = r.Int(1); });
    static_assert(std::string_view(kPoseColumns[0].name) == "seq");
    while (q->Step()) {
      local_by_seq[q->Int(1)] = q->Int(0);
      std::vector<Value> row = {session};
      for (size_t k = 0; k < std::size(kPoseColumns); ++k)
        row.push_back(ValueOf(*q, 1 + static_cast<int>(k), kPoseColumns[k].kind));
      w.Row(std::move(row));
      ++summary.poses;
    }
    w.Flush();
    for (const auto& [seq, id] : local_by_seq) {
      const auto it = server_by_seq.find(seq);
      if (it == server_by_seq.end())
        throw DatabaseError(target.name() + ": no id for the pose of plan index " +
                                std::to_string(seq),
                            "", false);
      poses[id] = it->second;
    }
  }
  auto pose_of = [&](const Statement& q, int column) -> std::optional<int64_t> {
    if (q.IsNull(column)) return std::nullopt;
    const auto it = poses.find(q.Int(column));
    if (it == poses.end()) return std::nullopt;  // a pose of another session: not linked
    return it->second;
  };
  {
    auto q =
        source.Prepare("SELECT pose_id, station_id, instrument_id, " + Names(kObservationColumns) +
                       " FROM observations WHERE session_id = ? ORDER BY id");
    q->Bind(1, local);
    BatchedInsert w(target,
                    "INSERT INTO observations(session_id, pose_id, station_id, instrument_id, " +
                        Names(kObservationColumns) + ")",
                    4 + static_cast<int>(std::size(kObservationColumns)));
    while (q->Step()) {
      std::vector<Value> row = {session, ValueOf(pose_of(*q, 0)), names.Station(q->Int(1)),
                                ValueOf(names.Instrument(q->OptionalInt(2)))};
      for (size_t k = 0; k < std::size(kObservationColumns); ++k)
        row.push_back(ValueOf(*q, 3 + static_cast<int>(k), kObservationColumns[k].kind));
      w.Row(std::move(row));
      ++summary.observations;
    }
    w.Flush();
  }
  {
    auto q = source.Prepare("SELECT pose_id, " + Names(kPointColumns) +
                            " FROM points WHERE session_id = ? ORDER BY id");
    q->Bind(1, local);
    BatchedInsert w(target, "INSERT INTO points(session_id, pose_id, " + Names(kPointColumns) + ")",
                    2 + static_cast<int>(std::size(kPointColumns)));
    while (q->Step()) {
      std::vector<Value> row = {session, ValueOf(pose_of(*q, 0))};
      for (size_t k = 0; k < std::size(kPointColumns); ++k)
        row.push_back(ValueOf(*q, 1 + static_cast<int>(k), kPointColumns[k].kind));
      w.Row(std::move(row));
      ++summary.points;
    }
    w.Flush();
  }
  summary.stream_rows += PushStreams(source, target, names, local, session);
  tx.Commit();
  ++summary.sessions_pushed;
}

// The session ids a parameter set's inputs name, as the server's (ids of sessions that
// were not pushed, open ones, are left as they were and so are the digest's).
std::string ServerInputs(Connection& source, Connection& target, const std::string& inputs_json,
                         int64_t calibration) {
  auto j =
      ParseStoredJson(inputs_json, {source.name(), "calibrations", calibration, "inputs_json"});
  if (!j.is_object() || !j.contains("sessions") || !j["sessions"].is_array()) return inputs_json;
  auto on_server = [&](nlohmann::json& id) {
    if (!id.is_number_integer()) return;
    auto s = source.Prepare("SELECT uuid FROM sessions WHERE id = ?");
    s->Bind(1, id.get<int64_t>());
    if (!s->Step() || s->IsNull(0)) return;
    if (const auto server = ServerIdOf(target, "sessions", s->Text(0))) id = *server;
  };
  for (auto& id : j["sessions"]) on_server(id);
  // The change point the set was fitted after (the nightly job's window starts there).
  if (j.contains("floor_session")) on_server(j["floor_session"]);
  return JsonText(j);
}

// One parameter set with its parameters and residuals, in one server transaction; the
// robot's next version there. Returns the server's version.
int PushCalibration(Connection& source, Connection& target, NameMap& names, int64_t local,
                    const std::string& uuid, PushSummary& summary) {
  Transaction tx(target, TransactionKind::kWrite);
  names.Forget();
  auto s = source.Prepare("SELECT robot_id, version, " + Names(kCalibrationColumns) +
                          " FROM calibrations WHERE id = ?");
  s->Bind(1, local);
  if (!s->Step()) return 0;
  const int64_t robot = names.Robot(s->Int(0));
  LockRobotForWrite(target, robot);  // the next version: no other writer of the robot's sets
  auto next =
      target.Prepare("SELECT coalesce(max(version), 0) + 1 FROM calibrations WHERE robot_id = ?");
  next->Bind(1, robot);
  next->Step();
  const int version = static_cast<int>(next->Int(0));
  auto insert = target.Prepare("INSERT INTO calibrations(robot_id, version, active, " +
                               Names(kCalibrationColumns) + ", uuid) VALUES (" +
                               Marks(kCalibrationColumns, 4) + ") RETURNING id");
  insert->Bind(1, robot);
  insert->Bind(2, version);
  insert->Bind(3, 0);
  CopyColumns(*s, 2, *insert, 4, kCalibrationColumns);
  // inputs_json (the second copied column) with the server's session ids
  insert->Bind(5, ServerInputs(source, target, s->Text(3), local));
  insert->Bind(static_cast<int>(std::size(kCalibrationColumns)) + 4, uuid);
  const int64_t calibration = InsertedId(*insert, target, "a parameter set");
  {
    auto q = source.Prepare("SELECT " + Names(kParameterColumns) +
                            " FROM calibration_parameters WHERE calibration_id = ? ORDER BY seq");
    q->Bind(1, local);
    auto w =
        target.Prepare("INSERT INTO calibration_parameters(calibration_id, " +
                       Names(kParameterColumns) + ") VALUES (" + Marks(kParameterColumns, 1) + ")");
    while (q->Step()) {
      w->Bind(1, calibration);
      CopyColumns(*q, 0, *w, 2, kParameterColumns);
      w->Execute();
    }
  }
  {
    // A residual's pose on the server: the same (session, plan index) of the pushed session.
    auto q = source.Prepare(
        "SELECT s.uuid, p.seq, " + Names(kResidualColumns) +
        " FROM validation_residuals r LEFT JOIN poses p ON p.id = r.pose_id "
        "LEFT JOIN sessions s ON s.id = p.session_id WHERE r.calibration_id = ? ORDER BY r.id");
    q->Bind(1, local);
    auto find = target.Prepare(
        "SELECT p.id FROM poses p JOIN sessions s ON s.id = p.session_id "
        "WHERE s.uuid = ? AND p.seq = ?");
    auto w =
        target.Prepare("INSERT INTO validation_residuals(calibration_id, pose_id, " +
                       Names(kResidualColumns) + ") VALUES (" + Marks(kResidualColumns, 2) + ")");
    while (q->Step()) {
      std::optional<int64_t> pose;
      if (!q->IsNull(0) && !q->IsNull(1)) {
        find->Bind(1, q->Text(0));
        find->Bind(2, q->Int(1));
        if (find->Step()) pose = find->Int(0);
      }
      w->Bind(1, calibration);
      w->Bind(2, pose);
      CopyColumns(*q, 2, *w, 3, kResidualColumns);
      w->Execute();
    }
  }
  tx.Commit();
  ++summary.sets_pushed;
  return version;
}

// The cell's activation history of one robot — every activation with who made it, when,
// why and what it replaced, in the server's version numbers — and its active state, which
// the server takes unless it holds a later activation of its own. Activations already on
// the server (by UUID) are not repeated.
void PushActivations(Connection& source, Connection& target, NameMap& names, int64_t local_robot,
                     PushSummary& summary) {
  std::map<int, std::string> uuid_of;  // the cell's version → its set's UUID
  std::optional<std::string> active_uuid;
  {
    auto q = source.Prepare("SELECT version, uuid, active FROM calibrations WHERE robot_id = ?");
    q->Bind(1, local_robot);
    while (q->Step()) {
      if (q->IsNull(1)) continue;
      uuid_of[static_cast<int>(q->Int(0))] = q->Text(1);
      if (q->Int(2) == 1) active_uuid = q->Text(1);
    }
  }
  Transaction tx(target, TransactionKind::kWrite);
  names.Forget();
  const int64_t robot = names.Robot(local_robot);
  LockRobotForWrite(target, robot);  // the history and the active set, read then changed
  auto version_there = [&](std::optional<int> local) -> std::optional<int> {
    if (!local || !uuid_of.count(*local)) return std::nullopt;
    auto v = target.Prepare("SELECT version FROM calibrations WHERE robot_id = ? AND uuid = ?");
    v->Bind(1, robot);
    v->Bind(2, uuid_of.at(*local));
    if (!v->Step()) return std::nullopt;
    return static_cast<int>(v->Int(0));
  };
  std::set<std::string> cell_activations;  // the cell's activation UUIDs
  bool carried = false;                     // this push stored one of them on the server
  auto a = source.Prepare(
      "SELECT uuid, version, previous_version, activated_at, activated_by, note FROM activations "
      "WHERE robot_id = ? ORDER BY id");
  a->Bind(1, local_robot);
  auto insert = target.Prepare(
      "INSERT INTO activations(robot_id, version, previous_version, activated_at, activated_by, "
      "note, uuid) VALUES (?,?,?,?,?,?,?)");
  while (a->Step()) {
    if (!a->IsNull(0)) cell_activations.insert(a->Text(0));
    if (a->IsNull(0) || ServerIdOf(target, "activations", a->Text(0))) continue;
    const auto version = version_there(static_cast<int>(a->Int(1)));
    if (!version) continue;  // its set is not on the server
    const auto previous =
        version_there(a->IsNull(2) ? std::nullopt : std::optional<int>(static_cast<int>(a->Int(2))));
    insert->Bind(1, robot);
    insert->Bind(2, static_cast<int64_t>(*version));
    if (previous)
      insert->Bind(3, static_cast<int64_t>(*previous));
    else
      insert->BindNull(3);
    insert->Bind(4, a->Text(3));
    insert->Bind(5, a->Text(4));
    if (a->IsNull(5))
      insert->BindNull(6);
    else
      insert->Bind(6, a->Text(5));
    insert->Bind(7, a->Text(0));
    insert->Execute();
    ++summary.activations_pushed;
    carried = true;
  }
  // The active state as in the cell when the cell activated since the last push, or when the
  // server's newest activation is still one the cell made; one made on the server since (an
  // operator's roll-back) stands. "Since" is the order the server stored the rows in, never
  // the two machines' clocks: a cell two days ahead undid a roll-back at every push.
  bool server_chose = false;
  if (!carried) {
    auto newest = target.Prepare(
        "SELECT uuid FROM activations WHERE robot_id = ? ORDER BY id DESC LIMIT 1");
    newest->Bind(1, robot);
    server_chose = newest->Step() && (newest->IsNull(0) || !cell_activations.count(newest->Text(0)));
  }
  if (active_uuid && !server_chose) {
    auto version = target.Prepare(
        "SELECT version, active FROM calibrations WHERE robot_id = ? AND uuid = ?");
    version->Bind(1, robot);
    version->Bind(2, *active_uuid);
    if (version->Step() && version->Int(1) == 0) {
      auto off =
          target.Prepare("UPDATE calibrations SET active = 0 WHERE robot_id = ? AND active = 1");
      off->Bind(1, robot);
      off->Execute();
      auto on =
          target.Prepare("UPDATE calibrations SET active = 1 WHERE robot_id = ? AND version = ?");
      on->Bind(1, robot);
      on->Bind(2, version->Int(0));
      on->Execute();
      ++summary.activated;
    }
  }
  tx.Commit();
}

}  // namespace

PushSummary Push(Connection& source, Connection& target, const PushOptions& options) {
  PushSummary summary;
  const auto stopping = [&] { return options.stop && options.stop->load(); };
  AssignUuids(source);
  NameMap names(source, target, summary);

  struct Item {
    int64_t id;
    std::string uuid, label;
  };
  std::vector<Item> sessions, sets;
  {
    auto q = source.Prepare("SELECT id, uuid, state FROM sessions ORDER BY id");
    while (q->Step()) {
      if (q->IsNull(1)) {
        summary.open_sessions.push_back(fmt::format("session {} ({})", q->Int(0), q->Text(2)));
        continue;
      }
      sessions.push_back({q->Int(0), q->Text(1), ""});
    }
    auto c = source.Prepare(
        "SELECT c.id, c.uuid, r.name, c.version FROM calibrations c JOIN robots r ON "
        "r.id = c.robot_id ORDER BY c.id");
    while (c->Step())
      sets.push_back({c->Int(0), c->Text(1), fmt::format("{} v{}", c->Text(2), c->Int(3))});
  }
  for (const auto& s : sessions) {
    if (stopping()) {
      summary.stopped = true;
      return summary;
    }
    if (ServerIdOf(target, "sessions", s.uuid)) {
      ++summary.sessions_present;
      continue;
    }
    PushSession(source, target, names, s.id, s.uuid, summary);
    spdlog::debug("push: session {} stored on {}", s.id, target.name());
  }
  for (const auto& c : sets) {
    if (stopping()) {
      summary.stopped = true;
      return summary;
    }
    if (ServerIdOf(target, "calibrations", c.uuid)) {
      ++summary.sets_present;
      continue;
    }
    const int version = PushCalibration(source, target, names, c.id, c.uuid, summary);
    summary.versions.push_back(fmt::format("{} -> v{}", c.label, version));
  }
  auto robots = source.Prepare("SELECT DISTINCT robot_id FROM calibrations ORDER BY robot_id");
  std::vector<int64_t> with_sets;
  while (robots->Step()) with_sets.push_back(robots->Int(0));
  for (const int64_t robot : with_sets) {
    if (stopping()) {
      summary.stopped = true;
      return summary;
    }
    PushActivations(source, target, names, robot, summary);
  }
  return summary;
}

}  // namespace armsig::db
