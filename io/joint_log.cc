#include "io/joint_log.h"

#include <fmt/format.h>

#include <initializer_list>

#include "core/error.h"
#include "core/plausibility.h"
#include "io/csv.h"
#include "io/joint_unit_check.h"

namespace armsig::io {

namespace {

// The first of `names` the header has.
std::optional<int> FirstColumnOf(const CsvTable& table, std::initializer_list<const char*> names) {
  for (const char* name : names) {
    if (auto column = table.FindColumn(name)) return column;
  }
  return std::nullopt;
}

struct JointColumn {
  int index;
  plausible::Unit unit;
};

// The joint columns in joint order: the ones named in the options (in their unit), or
// q1, q2, … by their unit suffixes; with the robot's joint count known, exactly that many.
std::vector<JointColumn> JointColumnsOf(const CsvTable& table, const JointLogOptions& options,
                                        const std::string& path) {
  std::vector<JointColumn> joints;
  if (!options.joint_columns.empty()) {
    for (const auto& name : options.joint_columns)
      joints.push_back({table.Column(name), plausible::UnitOf(options.joint_unit)});
    return joints;
  }
  for (int i = 1;; ++i) {
    const std::string base = "q" + std::to_string(i);
    if (options.num_joints > 0 && i > options.num_joints) {
      if (table.FindAngleColumn(base)) {
        throw InputError({path, 1, 0, ""},
                         fmt::format("has a column {} but the robot model has {} joints",
                                     table.FindAngleColumn(base)->name, options.num_joints));
      }
      break;
    }
    const auto column = options.num_joints > 0 ? std::optional(table.AngleColumnOf(base))
                                               : table.FindAngleColumn(base);
    if (!column) break;
    joints.push_back({column->index, plausible::UnitOf(column->unit)});
  }
  if (joints.empty()) {
    throw InputError({path, 1, 0, ""},
                     "no joint columns: expected q1_deg, q2_deg, … (any of _deg, _gon, _rad) or "
                     "--joint-columns");
  }
  return joints;
}

// One reading: its id and/or time (at least one of them) and its joints in radians.
JointLogRow ReadingOf(const CsvTable& table, const CsvRow& row, std::optional<int> id_col,
                      std::optional<int> time_col, const std::vector<JointColumn>& joints,
                      const std::string& path) {
  JointLogRow r;
  r.line = row.line;
  if (id_col) {
    const std::string& id = table.Text(row, *id_col);
    if (!id.empty()) r.id = table.Name(row, *id_col);
  }
  if (time_col) {
    r.time = ParseTimeStamp(table.Text(row, *time_col));
    if (!r.time) {
      throw InputError(table.Where(row, *time_col),
                       fmt::format("expected a time stamp (ISO 8601 such as "
                                   "2024-03-05T10:15:30.25, or seconds), got '{}'",
                                   table.Text(row, *time_col)));
    }
  }
  if (!r.id && !r.time) {
    throw InputError({path, row.line, 0, ""}, "a joint reading without an id or a time");
  }
  r.joints_rad.resize(static_cast<int>(joints.size()));
  for (size_t i = 0; i < joints.size(); ++i) {
    r.joints_rad(static_cast<int>(i)) =
        table.Number(row, joints[i].index, plausible::Quantity::kJointAngle, joints[i].unit);
  }
  return r;
}

}  // namespace

JointLog ReadJointLog(const std::string& path, const JointLogOptions& options) {
  const CsvTable table = ReadCsvFile(path);
  const std::optional<int> id_col =
      FirstColumnOf(table, {"pose", "point", "id", "name", "label", "pose_id", "point_id"});
  const std::optional<int> time_col =
      FirstColumnOf(table, {"time", "timestamp", "time_stamp", "datetime", "time_s", "t_s"});
  if (!id_col && !time_col) {
    throw InputError({path, 1, 0, ""},
                     "expected a pose id column (pose, point, id, name or label) or a time "
                     "column (time, timestamp, time_s) in the header");
  }
  const std::vector<JointColumn> joints = JointColumnsOf(table, options, path);
  JointLog log;
  log.source = path;
  log.has_ids = id_col.has_value();
  log.has_times = time_col.has_value();
  std::vector<JointUnitCheck::Column> unit_columns;
  for (const auto& j : joints) unit_columns.push_back({table.header()[j.index], j.unit});
  JointUnitCheck units(path, std::move(unit_columns));
  for (const CsvRow& row : table.rows()) {
    log.rows.push_back(ReadingOf(table, row, id_col, time_col, joints, path));
    units.Add(log.rows.back().joints_rad);
  }
  units.Finish();
  if (log.rows.empty()) throw InputError({path, 0, 0, ""}, "no joint readings after the header");
  return log;
}

}  // namespace armsig::io
