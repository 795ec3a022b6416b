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

Eigen::Isometry3d MatrixFromJson(const std::string& text, int64_t calibration_id) {
  const auto rows = nlohmann::json::parse(text, nullptr, false);
  if (!rows.is_array() || rows.size() != 4)
    throw std::runtime_error("calibration " + std::to_string(calibration_id) +
                             ": world_from_base is not a 4x4 matrix");
  Eigen::Isometry3d t = Eigen::Isometry3d::Identity();
  for (int r = 0; r < 4; ++r) {
    if (!rows[r].is_array() || rows[r].size() != 4)
      throw std::runtime_error("calibration " + std::to_string(calibration_id) +
                               ": world_from_base is not a 4x4 matrix");
    for (int c = 0; c < 4; ++c) {
      if (!rows[r][c].is_number()) {
        throw std::runtime_error("calibration " + std::to_string(calibration_id) +
                                 ": world_from_base holds something that is not a number");
      }
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

void CovarianceFromJson(const std::string& text, int64_t calibration_id, StoredCalibration& c) {
  const auto j = nlohmann::json::parse(text, nullptr, false);
  const auto fail = [&] {
    throw std::runtime_error("calibration " + std::to_string(calibration_id) +
                             ": covariance_json is not {parameters, matrix}");
  };
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
    SQLite::Statement name(db.sql(), "SELECT name FROM robots WHERE id = ?");
    name.bind(1, robot_id);
    if (name.executeStep()) robot = Quoted(name.getColumn(0).getString());
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
  SQLite::Statement next(
      db.sql(), "SELECT coalesce(max(version), 0) + 1 FROM calibrations WHERE robot_id = ?");
  next.bind(1, c.robot_id);
  next.executeStep();
  const int version = next.getColumn(0).getInt();
  if (c.active) {
    SQLite::Statement off(db.sql(), "UPDATE calibrations SET active = 0 WHERE robot_id = ?");
    off.bind(1, c.robot_id);
    off.exec();
  }
  SQLite::Statement s(
      db.sql(),
      "INSERT INTO calibrations(robot_id, version, active, params_spec, inputs_json, options_json, "
      "rank, "
      "poses_fit, poses_validation, nominal_mean_mm, nominal_max_mm, nominal_rms_mm, fit_mean_mm, "
      "fit_max_mm, fit_rms_mm, validation_mean_mm, validation_max_mm, validation_rms_mm, "
      "report_json, world_from_base_json, covariance_json, drift_json, residual_map_json) "
      "VALUES (?,?,?,?,?,?,?,?,?,?,?,?,?,?,?,?,?,?,?,?,?,?,?)");
  s.bind(1, c.robot_id);
  s.bind(2, version);
  s.bind(3, c.active ? 1 : 0);
  s.bind(4, c.params_spec);
  s.bind(5, c.inputs_json);
  s.bind(6, c.options_json);
  s.bind(7, c.rank);
  s.bind(8, c.poses_fit);
  s.bind(9, c.poses_validation);
  const double stats[9] = {c.nominal_mean_mm,    c.nominal_max_mm,    c.nominal_rms_mm,
                           c.fit_mean_mm,        c.fit_max_mm,        c.fit_rms_mm,
                           c.validation_mean_mm, c.validation_max_mm, c.validation_rms_mm};
  for (int k = 0; k < 9; ++k) BindOptional(s, 10 + k, stats[k]);
  s.bind(19, c.report_json);
  s.bind(20, MatrixJson(c.world_from_base));
  if (c.covariance_parameters.empty())
    s.bind(21);
  else
    s.bind(21, CovarianceJson(c.covariance_parameters, c.covariance));
  if (c.drift_json.empty())
    s.bind(22);
  else
    s.bind(22, c.drift_json);
  if (c.residual_map_json.empty())
    s.bind(23);
  else
    s.bind(23, c.residual_map_json);
  s.exec();
  const int64_t id = db.sql().getLastInsertRowid();
  SQLite::Statement p(db.sql(),
                      "INSERT INTO calibration_parameters(calibration_id, name, value, unit, "
                      "identified, sigma) VALUES (?,?,?,?,?,?)");
  for (const auto& param : c.parameters) {
    p.reset();
    p.bind(1, id);
    p.bind(2, param.name);
    p.bind(3, param.value);
    p.bind(4, param.unit);
    p.bind(5, param.identified ? 1 : 0);
    BindOptional(p, 6, param.sigma);
    p.exec();
  }
  SQLite::Statement r(db.sql(),
                      "INSERT INTO validation_residuals(calibration_id, pose_label, role, dx_mm, "
                      "dy_mm, dz_mm, distance_mm, "
                      "nominal_distance_mm) VALUES (?,?,?,?,?,?,?,?)");
  for (const auto& res : c.residuals) {
    r.reset();
    r.bind(1, id);
    r.bind(2, res.pose_label);
    r.bind(3, res.role);
    r.bind(4, res.error_mm.x());
    r.bind(5, res.error_mm.y());
    r.bind(6, res.error_mm.z());
    r.bind(7, res.error_mm.norm());
    BindOptional(r, 8, res.nominal_distance_mm);
    r.exec();
  }
  return {id, version};
}

std::vector<StoredCalibration> CalibrationHistory(Database& db, int64_t robot_id) {
  std::vector<StoredCalibration> out;
  SQLite::Statement q(
      db.sql(),
      "SELECT id, version, active, created_at, params_spec, inputs_json, coalesce(report_json,''), "
      "validation_mean_mm, validation_max_mm, world_from_base_json, covariance_json, options_json, "
      "rank, poses_fit, poses_validation, fit_mean_mm, coalesce(drift_json, ''), "
      "coalesce(residual_map_json, '') FROM calibrations "
      "WHERE robot_id = ? ORDER BY version");
  q.bind(1, robot_id);
  while (q.executeStep()) {
    StoredCalibration c;
    c.id = q.getColumn(0).getInt64();
    c.version = q.getColumn(1).getInt();
    c.active = q.getColumn(2).getInt() != 0;
    c.created_at = q.getColumn(3).getString();
    c.params_spec = q.getColumn(4).getString();
    c.inputs_json = q.getColumn(5).getString();
    c.report_json = q.getColumn(6).getString();
    if (!q.getColumn(7).isNull()) c.validation_mean_mm = q.getColumn(7).getDouble();
    if (!q.getColumn(8).isNull()) c.validation_max_mm = q.getColumn(8).getDouble();
    if (!q.getColumn(9).isNull())
      c.world_from_base = MatrixFromJson(q.getColumn(9).getString(), c.id);
    if (!q.getColumn(10).isNull()) CovarianceFromJson(q.getColumn(10).getString(), c.id, c);
    c.options_json = q.getColumn(11).getString();
    c.rank = q.getColumn(12).getInt();
    c.poses_fit = q.getColumn(13).getInt();
    c.poses_validation = q.getColumn(14).getInt();
    if (!q.getColumn(15).isNull()) c.fit_mean_mm = q.getColumn(15).getDouble();
    c.drift_json = q.getColumn(16).getString();
    c.residual_map_json = q.getColumn(17).getString();
    SQLite::Statement p(db.sql(),
                        "SELECT name, value, unit, identified, sigma FROM calibration_parameters "
                        "WHERE calibration_id = ? "
                        "ORDER BY rowid");
    p.bind(1, c.id);
    while (p.executeStep()) {
      CalibrationRecord::Parameter param;
      param.name = p.getColumn(0).getString();
      param.value = p.getColumn(1).getDouble();
      param.unit = p.getColumn(2).getString();
      param.identified = p.getColumn(3).getInt() != 0;
      param.sigma = p.getColumn(4).isNull() ? NAN : p.getColumn(4).getDouble();
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
  SQLite::Statement exists(db.sql(),
                           "SELECT 1 FROM calibrations WHERE robot_id = ? AND version = ?");
  exists.bind(1, robot_id);
  exists.bind(2, version);
  if (!exists.executeStep()) return false;
  SQLite::Statement s(db.sql(),
                      "UPDATE calibrations SET active = (version = ?) WHERE robot_id = ?");
  s.bind(1, version);
  s.bind(2, robot_id);
  s.exec();
  return true;
}

void RecordActivation(Database& db, int64_t robot_id, const Activation& a) {
  SQLite::Statement s(db.sql(),
                      "INSERT INTO activations(robot_id, version, previous_version, activated_by, "
                      "note) VALUES (?,?,?,?,?)");
  s.bind(1, robot_id);
  s.bind(2, a.version);
  if (a.previous_version)
    s.bind(3, *a.previous_version);
  else
    s.bind(3);
  s.bind(4, a.activated_by);
  s.bind(5, a.note);
  s.exec();
}

std::vector<Activation> ActivationHistory(Database& db, int64_t robot_id) {
  std::vector<Activation> out;
  SQLite::Statement q(db.sql(),
                      "SELECT version, previous_version, activated_at, activated_by, "
                      "coalesce(note, '') FROM activations WHERE robot_id = ? ORDER BY id");
  q.bind(1, robot_id);
  while (q.executeStep()) {
    Activation a;
    a.version = q.getColumn(0).getInt();
    if (!q.getColumn(1).isNull()) a.previous_version = q.getColumn(1).getInt();
    a.activated_at = q.getColumn(2).getString();
    a.activated_by = q.getColumn(3).getString();
    a.note = q.getColumn(4).getString();
    out.push_back(std::move(a));
  }
  return out;
}

}  // namespace armsig::db
