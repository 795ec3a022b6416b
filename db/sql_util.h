// Small binding helpers shared by the db/ table families (not part of the public API).
#pragma once

#include <SQLiteCpp/Statement.h>

#include <Eigen/Core>
#include <cmath>
#include <cstdio>
#include <limits>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

namespace armsig::db {

// Binds a finite value, NULL otherwise (NaN and ±inf mean "not known").
inline void BindOptional(SQLite::Statement& s, int index, double value) {
  if (std::isfinite(value))
    s.bind(index, value);
  else
    s.bind(index);
}

inline void BindOptional(SQLite::Statement& s, int index, const std::optional<double>& value) {
  BindOptional(s, index, value.value_or(std::numeric_limits<double>::quiet_NaN()));
}
// A column as an optional number (NULL = absent).
inline std::optional<double> OptionalDouble(const SQLite::Column& column) {
  if (column.isNull()) return std::nullopt;
  return column.getDouble();
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
