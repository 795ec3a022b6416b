// Joint columns whose values contradict their unit. A calibration moves every joint by tens
// of degrees; a file whose degree (or gon) columns never leave ±2π over many rows is almost
// certainly radians under a degree label — and read as degrees, every configuration would
// be a few degrees from zero, a robot that did not move. Refused with the figures, before
// anything read is kept.
#pragma once

#include <Eigen/Core>
#include <string>
#include <vector>

#include "core/plausibility.h"

namespace armsig::io {

class JointUnitCheck {
 public:
  // `source`: the file (for the message); one entry per joint column, in joint order.
  struct Column {
    std::string name;
    plausible::Unit unit;  // deg, gon or rad
  };
  JointUnitCheck(std::string source, std::vector<Column> columns);
  // One row's joints, in rad as read.
  void Add(const Eigen::VectorXd& joints_rad);
  // InputError when every column is in degrees (or gon), there are at least kMinRows rows,
  // some joint moved by more than kMinSpread in its unit, and no value leaves ±2π.
  void Finish() const;
  static constexpr int kMinRows = 10;
  static constexpr double kMinSpread = 0.5;

 private:
  std::string source_;
  std::vector<Column> columns_;
  std::vector<double> min_, max_;  // in each column's unit
  int rows_ = 0;
};

}  // namespace armsig::io
