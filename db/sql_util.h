// Small binding helpers shared by the db/ table families (not part of the public API).
#pragma once

#include <Eigen/Core>
#include <cmath>
#include <cstdio>
#include <limits>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "db/connection.h"
#include "db/database.h"
#include "db/stored_json.h"

namespace armsig::db {

// The store's statement for `sql` (written once for both backends, `?` placeholders).
inline std::unique_ptr<Statement> Sql(Database& db, std::string_view sql) {
  return db.connection().Prepare(sql);
}

// A JSON array of n doubles printed exactly (%.17g).
inline std::string JsonArray(const double* v, int n) {
  std::string out = "[";
  char buffer[32];
  for (int i = 0; i < n; ++i) {
    std::snprintf(buffer, sizeof buffer, "%s%.17g", i ? "," : "", v[i]);
    out += buffer;
  }
  return out + "]";
}

// A stored 3x3 row-major matrix (a point's covariance in mm², a station's rotation);
// nullopt when empty. Throws InputError naming the cell when it is not nine numbers
// (db/stored_json.h).
inline std::optional<Eigen::Matrix3d> ParseMatrix3(const std::string& text, const JsonCell& cell) {
  if (text.empty()) return std::nullopt;
  const auto j = ParseStoredJson(text, cell);
  if (!j.is_array() || j.size() != 9) RefuseStoredJson(cell, "expected nine numbers");
  Eigen::Matrix3d c;
  for (int k = 0; k < 9; ++k) {
    if (!j[k].is_number()) RefuseStoredJson(cell, "expected nine numbers");
    c(k / 3, k % 3) = j[k].get<double>();
  }
  return c;
}

// A stored list of joint angles (rad). Throws InputError naming the cell when it is not a
// list of numbers.
inline Eigen::VectorXd ParseJoints(const std::string& text, const JsonCell& cell) {
  const auto j = ParseStoredJson(text, cell);
  if (!j.is_array() || j.empty()) RefuseStoredJson(cell, "expected a list of joint angles");
  Eigen::VectorXd q(static_cast<Eigen::Index>(j.size()));
  for (std::size_t k = 0; k < j.size(); ++k) {
    if (!j[k].is_number()) RefuseStoredJson(cell, "expected a list of joint angles (numbers)");
    q(static_cast<Eigen::Index>(k)) = j[k].get<double>();
  }
  return q;
}

}  // namespace armsig::db
