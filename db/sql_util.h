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

// A stored 3x3 row-major covariance (mm²); nullopt when empty or not nine numbers.
inline std::optional<Eigen::Matrix3d> ParseCovariance(const std::string& text) {
  if (text.empty()) return std::nullopt;
  const auto j = nlohmann::json::parse(text, nullptr, /*allow_exceptions=*/false);
  if (!j.is_array() || j.size() != 9) return std::nullopt;
  Eigen::Matrix3d c;
  for (int k = 0; k < 9; ++k) {
    if (!j[k].is_number()) return std::nullopt;
    c(k / 3, k % 3) = j[k].get<double>();
  }
  return c;
}

}  // namespace armsig::db
