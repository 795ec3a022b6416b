#include "io/joint_unit_check.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>

#include "core/error.h"

namespace armsig::io {

JointUnitCheck::JointUnitCheck(std::string source, std::vector<Column> columns)
    : source_(std::move(source)),
      columns_(std::move(columns)),
      min_(columns_.size(), std::numeric_limits<double>::infinity()),
      max_(columns_.size(), -std::numeric_limits<double>::infinity()) {}

void JointUnitCheck::Add(const Eigen::VectorXd& joints_rad) {
  for (size_t i = 0; i < columns_.size() && static_cast<Eigen::Index>(i) < joints_rad.size(); ++i) {
    const double v = joints_rad(static_cast<Eigen::Index>(i)) / columns_[i].unit.to_internal;
    min_[i] = std::min(min_[i], v);
    max_[i] = std::max(max_[i], v);
  }
  ++rows_;
}

void JointUnitCheck::Finish() const {
  if (rows_ < kMinRows || columns_.empty()) return;
  constexpr double kTurnRad = 2.0 * kPi;  // the bound, in the columns' own unit
  double largest = 0.0, spread = 0.0;
  for (size_t i = 0; i < columns_.size(); ++i) {
    if (std::string(columns_[i].unit.name) == "rad") return;  // nothing to contradict
    largest = std::max({largest, std::abs(min_[i]), std::abs(max_[i])});
    spread = std::max(spread, max_[i] - min_[i]);
  }
  if (largest > kTurnRad || spread <= kMinSpread) return;
  std::string names;
  for (size_t i = 0; i < columns_.size(); ++i) names += (i ? ", " : "") + columns_[i].name;
  throw InputError(
      {source_, 0, 0, ""},
      fmt::format("every value of the joint columns ({}) lies within ±2π over {} rows (the "
                  "largest {:.4g}): a calibration moves its joints by tens of degrees, so these "
                  "look like radians under a {} label; name the columns _rad (or give "
                  "--joint-unit rad); nothing stored",
                  names, rows_, largest,
                  std::string(columns_.front().unit.name) == "gon" ? "gon" : "degree"));
}

}  // namespace armsig::io
