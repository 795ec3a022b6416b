// The files of an ISO 9283 test (the interface reference, "ISO 9283 tests"):
//   the plan        pose,point,cycle,approach,x_mm,y_mm,z_mm,q1_deg,…  (a capture plan:
//                   `capture --plan` reads pose and the joints, and keeps the target);
//                   a path plan (`iso9283 plan --path`) adds speed_mm_s: the row is reached
//                   by a linear move at that speed (empty: a joint move, a cycle's start);
//   commanded poses point,x_mm,y_mm,z_mm[,a_deg,b_deg,c_deg]           (one row per point);
//   attained poses  point,cycle,x_mm,y_mm,z_mm[,a_deg,b_deg,c_deg]     (one row per cycle).
// Angles take any unit suffix (_deg, _gon, _rad); the id column may be called `pose`
// instead of `point` (a poses CSV from `import poses` or `session export`, one cycle per
// pose); `cycle` may be left out (a point's rows are then its cycles 1, 2, … in file
// order); `approach` names the direction of a multi-directional test (vAP).
#pragma once

#include <Eigen/Core>
#include <optional>
#include <string>
#include <vector>

namespace armsig::iso9283 {

struct CommandedPoint {
  std::string point;
  Eigen::Vector3d position_mm = Eigen::Vector3d::Zero();
  std::optional<Eigen::Vector3d> orientation_rad;  // a, b, c
  int line = 0;
};
// Throws InputError (file:line:column) for a missing column, a number that is none, a
// duplicate point, and for a, b, c given in part.
std::vector<CommandedPoint> ReadCommandedCsv(const std::string& path);

struct AttainedRow {
  std::string point;
  int cycle = 0;
  std::string approach;  // "" when the file has no approach column (or leaves it empty)
  Eigen::Vector3d position_mm = Eigen::Vector3d::Zero();
  std::optional<Eigen::Vector3d> orientation_rad;
  int line = 0;
};
// Throws InputError as ReadCommandedCsv, and for a cycle that is not a whole number from 1
// and a (point, cycle, approach) given twice.
std::vector<AttainedRow> ReadAttainedCsv(const std::string& path);

struct Iso9283PlanRow {
  std::string pose;      // the configuration's label (capture stores it)
  std::string point;     // P1…P5; "" for a via point of the multi-directional test
  int cycle = 0;         // 0 for a via point
  std::string approach;  // "" (the one approach) or x, y, z
  Eigen::Vector3d target_mm = Eigen::Vector3d::Zero();  // in the robot frame
  Eigen::VectorXd joints_rad;
  std::optional<double> speed_mm_s;  // a path's vertex reached by a linear move
  // A circle's rows: "via" (a circular move's via point) and "circular" (its target); ""
  // for the others (the `motion` column, written when a row has one).
  std::string motion;
};
// The header and the rows only: a spreadsheet or pandas reads it as it is (the plan's
// conditions, which were '#' lines read as rows there, are on the command's output).
std::string FormatIso9283PlanCsv(const std::vector<Iso9283PlanRow>& rows);
std::vector<Iso9283PlanRow> ReadIso9283PlanCsv(const std::string& path, int num_joints);

}  // namespace armsig::iso9283
