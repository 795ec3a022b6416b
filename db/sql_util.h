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

#include "core/rotation.h"
#include "core/types.h"
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

// The columns of a target's measured orientation, in this order (schema v12).
inline constexpr const char* kOrientationColumns =
    "rx_rad, ry_rad, rz_rad, sigma_rx_rad, sigma_ry_rad, sigma_rz_rad";

// Binds an orientation to the six parameters from `first` (NULL for none).
inline void BindOrientation(Statement& s, int first,
                            const std::optional<MeasuredOrientation>& orientation) {
  for (int k = 0; k < 6; ++k) s.BindNull(first + k);
  if (!orientation) return;
  const Eigen::Vector3d angles = RxRyRzFromRotation(orientation->world_from_target);
  for (int k = 0; k < 3; ++k) s.Bind(first + k, angles(k));
  if (orientation->sigma_rad) {
    for (int k = 0; k < 3; ++k) s.Bind(first + 3 + k, (*orientation->sigma_rad)(k));
  }
}

// The orientation in the six result columns from `first`: nullopt when its angles are NULL.
// Throws InputError naming the cell when only some of the angles or of the sigmas are
// stored, or a sigma is not positive.
inline std::optional<MeasuredOrientation> OrientationAt(const Statement& s, int first,
                                                        const JsonCell& cell) {
  int angles = 0, sigmas = 0;
  for (int k = 0; k < 3; ++k) {
    angles += !s.IsNull(first + k);
    sigmas += !s.IsNull(first + 3 + k);
  }
  if (angles == 0 && sigmas == 0) return std::nullopt;
  if (angles != 3 || (sigmas != 0 && sigmas != 3)) {
    RefuseStoredJson(cell,
                     "expected the three angles rx, ry, rz (and none or all three of their "
                     "sigmas)");
  }
  MeasuredOrientation orientation;
  orientation.world_from_target = RotationFromRxRyRz(
      Eigen::Vector3d(s.Double(first), s.Double(first + 1), s.Double(first + 2)));
  if (sigmas == 3) {
    const Eigen::Vector3d sigma(s.Double(first + 3), s.Double(first + 4), s.Double(first + 5));
    if (!(sigma.minCoeff() > 0.0) || !sigma.allFinite())
      RefuseStoredJson(cell, "expected positive sigmas of rx, ry, rz");
    orientation.sigma_rad = sigma;
  }
  return orientation;
}

}  // namespace armsig::db
