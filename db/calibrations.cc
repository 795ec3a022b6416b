#include "db/calibrations.h"

#include <cmath>
#include <nlohmann/json.hpp>
#include <stdexcept>

#include "core/error.h"
#include "core/plausibility.h"
#include "core/text.h"
#include "db/sql_util.h"

namespace armsig::db {

namespace {

std::string MatrixJson(const Eigen::Isometry3d& t) {
  nlohmann::json rows = nlohmann::json::array();
  for (int r = 0; r < 4; ++r)
    rows.push_back({t.matrix()(r, 0), t.matrix()(r, 1), t.matrix()(r, 2), t.matrix()(r, 3)});
  return JsonText(rows);
}

Eigen::Isometry3d MatrixFromJson(const std::string& text, const JsonCell& cell) {
  const auto rows = ParseStoredJson(text, cell);
  if (!rows.is_array() || rows.size() != 4) RefuseStoredJson(cell, "expected a 4x4 matrix");
  Eigen::Isometry3d t = Eigen::Isometry3d::Identity();
  for (int r = 0; r < 4; ++r) {
    if (!rows[r].is_array() || rows[r].size() != 4) RefuseStoredJson(cell, "expected a 4x4 matrix");
    for (int c = 0; c < 4; ++c) {
      if (!rows[r][c].is_number()) RefuseStoredJson(cell, "expected a 4x4 matrix of numbers");
      t.matrix()(r, c) = rows[r][c].get<double>();
    }
  }
  return t;
}

std::string CovarianceJson(const std::vector<std::string>& names, const Eigen::MatrixXd& m) {
  if (names.empty()) return "";
  nlohmann::json rows = nlohmann::json::array();
  for (int r = 0; r < m.rows(); ++r) {
    nlohmann::json row = nlohmann::json::array();
    for (int c = 0; c < m.cols(); ++c) row.push_back(m(r, c));
    rows.push_back(row);
  }
  return JsonText(nlohmann::json{{"parameters", names}, {"matrix", rows}});
}

void CovarianceFromJson(const std::string& text, const JsonCell& cell, StoredCalibration& c) {
  const auto j = ParseStoredJson(text, cell);
  const auto fail = [&] { RefuseStoredJson(cell, "expected {parameters, matrix}"); };
  if (!j.is_object() || !j.contains("parameters") || !j.contains("matrix")) fail();
  const auto& names = j["parameters"];
  const auto& rows = j["matrix"];
  if (!names.is_array() || !rows.is_array() || rows.size() != names.size()) fail();
  const int k = static_cast<int>(names.size());
  c.covariance.resize(k, k);
  for (int r = 0; r < k; ++r) {
    if (!names[r].is_string() || !rows[r].is_array() || static_cast<int>(rows[r].size()) != k)
      fail();
    c.covariance_parameters.push_back(names[r].get<std::string>());
    for (int col = 0; col < k; ++col) {
      if (!rows[r][col].is_number()) fail();
      c.covariance(r, col) = rows[r][col].get<double>();
    }
  }
}

// A stored parameter set is input like any file: an edited or damaged database could hold
// inf, NaN or 1e300 where a parameter belongs, and predict, compensate, export and the drift
// test would print it as a result. Refused on load (an InputError naming the file, the robot
// and the version), so that no command computes with it.
void CheckStoredValues(Database& db, int64_t robot_id, const StoredCalibration& c) {
  auto refuse = [&](const std::string& what) {
    std::string robot = "id " + std::to_string(robot_id);
    auto name = Sql(db, "SELECT name FROM robots WHERE id = ?");
    name->Bind(1, robot_id);
    if (name->Step()) robot = Quoted(name->Text(0));
    throw InputError({db.path(), 0, 0, ""},
                     "robot " + robot + ", parameter set version " + std::to_string(c.version) +
                         ": " + what +
                         "; the database was edited or damaged (activate another version, or "
                         "recalibrate)");
  };
  for (const auto& p : c.parameters) {
    const bool angle = p.unit == "rad";
    if (!angle && p.unit != "mm") {
      refuse("parameter " + Quoted(p.name) + " has the unit " + Quoted(p.unit) +
             " (expected mm or rad)");
    }
    const auto quantity = angle ? plausible::Quantity::kAngle : plausible::Quantity::kLength;
    const auto unit = angle ? plausible::UnitOf(AngleUnit::kRad) : plausible::kMm;
    if (auto why = plausible::Check(quantity, p.value, unit)) {
      refuse("parameter " + Quoted(p.name) + ": " + *why);
    }
    if (p.identified && !(std::isnan(p.sigma) || (std::isfinite(p.sigma) && p.sigma >= 0))) {
      refuse("parameter " + Quoted(p.name) + " has the sigma " + std::to_string(p.sigma) +
             " (expected a finite sigma ≥ 0)");
    }
  }
  if (c.world_from_base && !c.world_from_base->matrix().allFinite()) {
    refuse("its measuring frame (world_from_base) is not finite");
  }
  if (!c.covariance.allFinite()) refuse("its covariance is not finite");
}

}  // namespace

std::pair<int64_t, int> InsertCalibration(Database& db, const CalibrationRecord& c) {
  // The next version and the active flag are read, then written: no other writer of this
  // robot's sets in between (PostgreSQL; SQLite's write transaction already excludes).
  LockRobotForWrite(db, c.robot_id);
  auto next = Sql(db, "SELECT coalesce(max(version), 0) + 1 FROM calibrations WHERE robot_id = ?");
  next->Bind(1, c.robot_id);
  next->Step();
  const int version = static_cast<int>(next->Int(0));
  if (c.active) {
    auto off = Sql(db, "UPDATE calibrations SET active = 0 WHERE robot_id = ?");
    off->Bind(1, c.robot_id);
    off->Execute();
  }
  auto s = Sql(db,
      "INSERT INTO calibrations(robot_id, version, active, params_spec, inputs_json, options_json, "
      "rank, "
      "poses_fit, poses_validation, nominal_mean_mm, nominal_max_mm, nominal_rms_mm, fit_mean_mm, "
      "fit_max_mm, fit_rms_mm, validation_mean_mm, validation_max_mm, validation_rms_mm, "
      "report_json, world_from_base_json, covariance_json, drift_json, residual_map_json, "
      "tool_rotation_json, validity_json) VALUES (?,?,?,?,?,?,?,?,?,?,?,?,?,?,?,?,?,?,?,?,?,?,?,?,?) "
      "RETURNING id");
  s->Bind(1, c.robot_id);
  s->Bind(2, version);
  s->Bind(3, c.active ? 1 : 0);
  s->Bind(4, c.params_spec);
  s->Bind(5, c.inputs_json);
  s->Bind(6, c.options_json);
  s->Bind(7, c.rank);
  s->Bind(8, c.poses_fit);
  s->Bind(9, c.poses_validation);
  const double stats[9] = {c.nominal_mean_mm,    c.nominal_max_mm,    c.nominal_rms_mm,
                           c.fit_mean_mm,        c.fit_max_mm,        c.fit_rms_mm,
                           c.validation_mean_mm, c.validation_max_mm, c.validation_rms_mm};
  for (int k = 0; k < 9; ++k) s->Bind(10 + k, stats[k]);
  s->Bind(19, c.report_json);
  s->Bind(20, MatrixJson(c.world_from_base));
  if (c.covariance_parameters.empty())
    s->BindNull(21);
  else
    s->Bind(21, CovarianceJson(c.covariance_parameters, c.covariance));
  if (c.drift_json.empty())
    s->BindNull(22);
  else
    s->Bind(22, c.drift_json);
  if (c.residual_map_json.empty())
    s->BindNull(23);
  else
    s->Bind(23, c.residual_map_json);
  if (c.tool_rotation) {
    const Eigen::Matrix<double, 3, 3, Eigen::RowMajor> rows = *c.tool_rotation;
    s->Bind(24, JsonArray(rows.data(), 9));
  } else {
    s->BindNull(24);
  }
  if (c.validity_json.empty())
    s->BindNull(25);
  else
    s->Bind(25, c.validity_json);
  const int64_t id = InsertedId(*s, db.path() + ": a parameter set");
  auto p = Sql(db,
                      "INSERT INTO calibration_parameters(calibration_id, name, value, unit, "
                      "identified, sigma, seq) VALUES (?,?,?,?,?,?,?)");
  int seq = 0;
  for (const auto& param : c.parameters) {
    p->Bind(1, id);
    p->Bind(2, param.name);
    p->Bind(3, param.value);
    p->Bind(4, param.unit);
    p->Bind(5, param.identified ? 1 : 0);
    p->Bind(6, param.sigma);
    p->Bind(7, ++seq);
    p->Execute();
  }
  auto r = Sql(db,
                      "INSERT INTO validation_residuals(calibration_id, pose_label, role, dx_mm, "
                      "dy_mm, dz_mm, distance_mm, "
                      "nominal_distance_mm) VALUES (?,?,?,?,?,?,?,?)");
  for (const auto& res : c.residuals) {
    r->Bind(1, id);
    r->Bind(2, res.pose_label);
    r->Bind(3, res.role);
    r->Bind(4, res.error_mm.x());
    r->Bind(5, res.error_mm.y());
    r->Bind(6, res.error_mm.z());
    r->Bind(7, res.error_mm.norm());
    r->Bind(8, res.nominal_distance_mm);
    r->Execute();
  }
  return {id, version};
}

void SetDriftJson(Database& db, int64_t calibration_id, const std::string& drift_json) {
  auto q = Sql(db, "UPDATE calibrations SET drift_json = ? WHERE id = ?");
  q->Bind(1, drift_json);
  q->Bind(2, calibration_id);
  q->Execute();
}

std::vector<StoredCalibration> CalibrationHistory(Database& db, int64_t robot_id) {
  std::vector<StoredCalibration> out;
  auto q = Sql(db,
      "SELECT id, version, active, created_at, params_spec, inputs_json, coalesce(report_json,''), "
      "validation_mean_mm, validation_max_mm, world_from_base_json, covariance_json, options_json, "
      "rank, poses_fit, poses_validation, fit_mean_mm, coalesce(drift_json, ''), "
      "coalesce(residual_map_json, ''), validation_rms_mm, coalesce(tool_rotation_json, ''), "
      "coalesce(validity_json, '') FROM calibrations "
      "WHERE robot_id = ? ORDER BY version");
  q->Bind(1, robot_id);
  while (q->Step()) {
    StoredCalibration c;
    c.id = q->Int(0);
    c.version = static_cast<int>(q->Int(1));
    c.active = static_cast<int>(q->Int(2)) != 0;
    c.created_at = q->Text(3);
    c.params_spec = q->Text(4);
    c.inputs_json = q->Text(5);
    c.report_json = q->Text(6);
    if (!q->IsNull(7)) c.validation_mean_mm = q->Double(7);
    if (!q->IsNull(8)) c.validation_max_mm = q->Double(8);
    auto cell = [&](const char* column) {
      return JsonCell{db.path(), "calibrations", c.id, column};
    };
    if (!q->IsNull(9)) c.world_from_base = MatrixFromJson(q->Text(9), cell("world_from_base_json"));
    if (!q->IsNull(10)) CovarianceFromJson(q->Text(10), cell("covariance_json"), c);
    c.options_json = q->Text(11);
    c.rank = static_cast<int>(q->Int(12));
    c.poses_fit = static_cast<int>(q->Int(13));
    c.poses_validation = static_cast<int>(q->Int(14));
    if (!q->IsNull(15)) c.fit_mean_mm = q->Double(15);
    c.drift_json = q->Text(16);
    c.residual_map_json = q->Text(17);
    if (!q->IsNull(18)) c.validation_rms_mm = q->Double(18);
    c.tool_rotation = ParseMatrix3(q->Text(19), cell("tool_rotation_json"));
    c.validity_json = q->Text(20);
    // Kept as text and read where they are used: bounded now, so that any later parse or
    // print of them is.
    CheckStoredJsonText(c.inputs_json, cell("inputs_json"));
    CheckStoredJsonText(c.report_json, cell("report_json"));
    CheckStoredJsonText(c.options_json, cell("options_json"));
    CheckStoredJsonText(c.drift_json, cell("drift_json"));
    CheckStoredJsonText(c.residual_map_json, cell("residual_map_json"));
    CheckStoredJsonText(c.validity_json, cell("validity_json"));
    auto p = Sql(db,
                        "SELECT name, value, unit, identified, sigma FROM calibration_parameters "
                        "WHERE calibration_id = ? "
                        "ORDER BY seq");
    p->Bind(1, c.id);
    while (p->Step()) {
      CalibrationRecord::Parameter param;
      param.name = p->Text(0);
      param.value = p->Double(1);
      param.unit = p->Text(2);
      param.identified = static_cast<int>(p->Int(3)) != 0;
      param.sigma = p->IsNull(4) ? NAN : p->Double(4);
      c.parameters.push_back(param);
    }
    CheckStoredValues(db, robot_id, c);
    out.push_back(std::move(c));
  }
  return out;
}

std::optional<StoredCalibration> ActiveCalibration(Database& db, int64_t robot_id) {
  for (auto& c : CalibrationHistory(db, robot_id)) {
    if (c.active) return c;
  }
  return std::nullopt;
}

bool SetActiveVersion(Database& db, int64_t robot_id, int version) {
  LockRobotForWrite(db, robot_id);
  auto exists = Sql(db,
                           "SELECT 1 FROM calibrations WHERE robot_id = ? AND version = ?");
  exists->Bind(1, robot_id);
  exists->Bind(2, version);
  if (!exists->Step()) return false;
  auto s = Sql(db,
                      "UPDATE calibrations SET active = CASE WHEN version = ? THEN 1 ELSE 0 END "
                      "WHERE robot_id = ?");
  s->Bind(1, version);
  s->Bind(2, robot_id);
  s->Execute();
  return true;
}

void RecordActivation(Database& db, int64_t robot_id, const Activation& a) {
  auto s = Sql(db,
                      "INSERT INTO activations(robot_id, version, previous_version, activated_by, "
                      "note) VALUES (?,?,?,?,?)");
  s->Bind(1, robot_id);
  s->Bind(2, a.version);
  if (a.previous_version)
    s->Bind(3, *a.previous_version);
  else
    s->BindNull(3);
  s->Bind(4, a.activated_by);
  s->Bind(5, a.note);
  s->Execute();
}

std::vector<Activation> ActivationHistory(Database& db, int64_t robot_id) {
  std::vector<Activation> out;
  auto q = Sql(db,
                      "SELECT version, previous_version, activated_at, activated_by, "
                      "coalesce(note, '') FROM activations WHERE robot_id = ? ORDER BY id");
  q->Bind(1, robot_id);
  while (q->Step()) {
    Activation a;
    a.version = static_cast<int>(q->Int(0));
    if (!q->IsNull(1)) a.previous_version = static_cast<int>(q->Int(1));
    a.activated_at = q->Text(2);
    a.activated_by = q->Text(3);
    a.note = q->Text(4);
    out.push_back(std::move(a));
  }
  return out;
}

}  // namespace armsig::db
