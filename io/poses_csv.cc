#include "io/poses_csv.h"

#include <fmt/format.h>

#include <algorithm>
#include <cstdio>
#include <map>
#include <optional>
#include <set>
#include <stdexcept>
#include <unordered_set>

#include "core/error.h"
#include "core/text.h"
#include "io/csv.h"

namespace armsig::io {

namespace {

// The ids of a table read row by row, 16 bytes each (a 64-bit FNV-1a hash and the line):
// a repeated id is found once the file has been read. Only rows whose hashes meet are
// compared by their text, which takes one more pass over the file (`rescan`).
class SeenIds {
 public:
  void Add(std::string_view id, int line) { seen_.push_back({Hash(id), line}); }

  // Throws InputError at the first row whose id an earlier row has. `rescan(visit)` reads
  // the table again, calling visit(id, row, table) for each row.
  using Visit = std::function<void(const std::string&, const CsvRow&, const CsvColumns&)>;
  void Check(const std::function<void(const Visit&)>& rescan, int id_column) {
    std::sort(seen_.begin(), seen_.end());
    std::unordered_set<uint64_t> met;
    for (size_t k = 1; k < seen_.size(); ++k) {
      if (seen_[k].hash == seen_[k - 1].hash) met.insert(seen_[k].hash);
    }
    seen_.clear();
    seen_.shrink_to_fit();
    if (met.empty()) return;
    std::map<std::string, int> first_line;  // ids of the rows whose hashes met
    rescan([&](const std::string& id, const CsvRow& row, const CsvColumns& table) {
      if (!met.count(Hash(id))) return;
      if (!first_line.emplace(id, row.line).second) {
        throw InputError(table.Where(row, id_column), "duplicate pose id " + Quoted(id));
      }
    });
  }

 private:
  static uint64_t Hash(std::string_view id) {
    uint64_t h = 1469598103934665603ull;
    for (unsigned char c : id) {
      h ^= c;
      h *= 1099511628211ull;
    }
    return h;
  }
  struct Entry {
    uint64_t hash;
    int line;
    bool operator<(const Entry& o) const { return hash != o.hash ? hash < o.hash : line < o.line; }
  };
  std::vector<Entry> seen_;
};

}  // namespace

void ReadPosesStreamed(const std::string& path, int num_joints, std::optional<AngleUnit> joint_unit,
                       const std::function<void(const MeasuredPose&, int line)>& sink,
                       ReadProgressFn progress) {
  CsvReader table(path, {}, std::move(progress));
  if (num_joints < 0) {
    num_joints = 0;
    while (table.FindAngleColumn("q" + std::to_string(num_joints + 1))) ++num_joints;
    if (num_joints == 0) {
      throw InputError(table.HeaderWhere(0),
                       "expected the poses header pose,q1_deg,…,qn_deg,x_mm,y_mm,z_mm (joint "
                       "columns q1, q2, … with a unit suffix _deg, _gon or _rad)");
    }
  }
  std::vector<std::string> known = {"pose", "x_mm", "y_mm", "z_mm"};
  for (int i = 1; i <= num_joints; ++i) known.push_back("q" + std::to_string(i) + "_*");
  table.RefuseUnreadUnits(known);
  const int id_col = table.Column("pose");
  std::vector<AngleColumn> q;
  for (int i = 1; i <= num_joints; ++i) {
    q.push_back(table.AngleColumnOf("q" + std::to_string(i)));
    if (joint_unit && q.back().unit != *joint_unit) {
      throw InputError(table.HeaderWhere(q.back().index),
                       "column " + Quoted(q.back().name) + " is in " +
                           std::string(AngleUnitSuffix(q.back().unit).substr(1)) +
                           " by its name, but --joint-unit " +
                           std::string(AngleUnitSuffix(*joint_unit).substr(1)) +
                           " was given: leave --joint-unit out (the suffix gives the unit)");
    }
  }
  const int x = table.Column("x_mm"), y = table.Column("y_mm"), z = table.Column("z_mm");
  if (const auto extra = table.FindAngleColumn("q" + std::to_string(num_joints + 1))) {
    throw InputError(table.HeaderWhere(extra->index),
                     "a joint column " + Quoted(extra->name) + " but the robot model has " +
                         std::to_string(num_joints) + " joints (expected q1…q" +
                         std::to_string(num_joints) + ")");
  }
  SeenIds ids;
  MeasuredPose pose;
  pose.joints_rad.resize(num_joints);
  int64_t count = 0;
  for (CsvRow row; table.Next(row);) {
    if (table.Text(row, id_col).empty()) {
      throw InputError(table.Where(row, id_col), "expected a pose id");
    }
    pose.id = table.Name(row, id_col);
    ids.Add(pose.id, row.line);
    using plausible::Quantity;
    for (int i = 0; i < num_joints; ++i) {
      pose.joints_rad(i) = table.AngleRad(row, q[i], Quantity::kJointAngle);
    }
    pose.target_in_world = {table.Number(row, x, Quantity::kCoordinate),
                            table.Number(row, y, Quantity::kCoordinate),
                            table.Number(row, z, Quantity::kCoordinate)};
    sink(pose, row.line);
    ++count;
  }
  if (count == 0)
    throw InputError({path, 0, 0, ""}, "no poses (expected data rows after the header)");
  ids.Check(
      [&](const SeenIds::Visit& visit) {
        CsvReader again(path);
        for (CsvRow row; again.Next(row);) visit(again.Text(row, id_col), row, again);
      },
      id_col);
}

std::vector<MeasuredPose> ReadPosesCsv(const std::string& path, int num_joints,
                                       std::optional<AngleUnit> joint_unit,
                                       ReadProgressFn progress) {
  std::vector<MeasuredPose> poses;
  ReadPosesStreamed(
      path, num_joints, joint_unit,
      [&](const MeasuredPose& pose, int line) {
        if (poses.size() >= static_cast<size_t>(kMaxPosesInMemory)) {
          throw InputError(
              {path, line, 0, ""},
              fmt::format("more than {} poses: a fit holds at most {} in memory (every pose adds "
                          "to its Jacobian); take every k-th row of the file, or store it with "
                          "`armsig import poses` (any length, read row by row)",
                          kMaxPosesInMemory, kMaxPosesInMemory));
        }
        poses.push_back(pose);
      },
      std::move(progress));
  return poses;
}

std::string PosesCsvHeader(int num_joints) {
  std::string out = "pose";
  for (int i = 1; i <= num_joints; ++i) out += ",q" + std::to_string(i) + "_deg";
  return out + ",x_mm,y_mm,z_mm\n";
}

std::string PosesCsvRow(const MeasuredPose& pose) {
  std::string out = CsvEscape(pose.id);
  char buffer[64];
  for (int i = 0; i < pose.joints_rad.size(); ++i) {
    std::snprintf(buffer, sizeof buffer, ",%.12g", FromRad(pose.joints_rad(i), AngleUnit::kDeg));
    out += buffer;
  }
  for (int k = 0; k < 3; ++k) {
    std::snprintf(buffer, sizeof buffer, ",%.9g", pose.target_in_world(k));
    out += buffer;
  }
  return out + '\n';
}

std::string FormatPosesCsv(const std::vector<MeasuredPose>& poses, int num_joints) {
  const int n = num_joints >= 0  ? num_joints
                : poses.empty() ? 0
                                : static_cast<int>(poses[0].joints_rad.size());
  std::string out = PosesCsvHeader(n);
  for (const auto& pose : poses) {
    if (pose.joints_rad.size() != n)
      throw std::invalid_argument("FormatPosesCsv: pose " + pose.id + " has another joint count");
    out += PosesCsvRow(pose);
  }
  return out;
}

PoseImportOptions PoseImportOptions::UrIpa() {
  PoseImportOptions o;
  o.delimiter = ';';
  o.decimal_comma = true;
  o.joint_columns = {"shoulder_pan_joint", "shoulder_lift_joint", "elbow_joint",
                     "wrist_1_joint",      "wrist_2_joint",       "wrist_3_joint"};
  o.joint_unit = AngleUnit::kRad;
  o.xyz_columns = {"measurement_x", "measurement_y", "measurement_z"};
  return o;
}

namespace {

void CheckImportOptions(const PoseImportOptions& options) {
  if (options.joint_columns.empty()) throw InputError("no joint columns given (--joint-columns)");
  if (options.xyz_columns.size() != 3) throw InputError("expected three position columns (--xyz-columns)");
  // Each column names one quantity: a joint given twice, or a column that is a joint and a
  // coordinate, is a typo that would silently calibrate nonsense.
  std::vector<std::pair<std::string, std::string>> named;  // column, option
  for (const auto& c : options.joint_columns) named.emplace_back(c, "--joint-columns");
  for (const auto& c : options.xyz_columns) named.emplace_back(c, "--xyz-columns");
  if (!options.id_column.empty()) named.emplace_back(options.id_column, "--id");
  for (size_t a = 0; a < named.size(); ++a) {
    for (size_t b = 0; b < a; ++b) {
      if (named[a].first == named[b].first) {
        throw InputError({named[a].second, 0, 0, ""}, "column " + Quoted(named[a].first) +
                                                          " is given twice (" + named[b].second +
                                                          " and " + named[a].second +
                                                          "): expected each column once");
      }
    }
  }
}

}  // namespace

void ImportPosesStreamed(const std::string& path, const PoseImportOptions& options,
                         const std::function<void(const MeasuredPose&, int line)>& sink,
                         ReadProgressFn progress) {
  CheckImportOptions(options);
  CsvOptions csv;
  csv.delimiter = options.delimiter;
  CsvReader table(path, csv, std::move(progress));
  if (options.decimal_comma && !table.decimal_comma()) {
    throw InputError({path, 1, 0, ""},
                     "decimal commas were asked for, but the file is comma-separated (a decimal "
                     "comma needs ';' or tab as the delimiter)");
  }
  std::vector<int> q;
  std::vector<AngleUnit> q_unit;
  for (const auto& name : options.joint_columns) {
    q.push_back(table.Column(name));
    const auto suffix = AngleUnitFromSuffix(name);
    if (suffix && options.joint_unit && *suffix != *options.joint_unit) {
      throw InputError(table.HeaderWhere(q.back()),
                       "column " + Quoted(name) + " is in " +
                           std::string(AngleUnitSuffix(*suffix).substr(1)) +
                           " by its name, but --joint-unit " +
                           std::string(AngleUnitSuffix(*options.joint_unit).substr(1)) +
                           " was given: leave --joint-unit out (the suffix gives the unit)");
    }
    q_unit.push_back(suffix ? *suffix : options.joint_unit.value_or(AngleUnit::kRad));
  }
  int xyz[3];
  for (int k = 0; k < 3; ++k) xyz[k] = table.Column(options.xyz_columns[k]);
  const int id_col = options.id_column.empty() ? -1 : table.Column(options.id_column);
  // The file's length unit: mm unless --length-scale says otherwise.
  const plausible::Unit length_unit{options.length_scale_to_mm == 1.0 ? "mm" : "(file units)",
                                    options.length_scale_to_mm};
  SeenIds ids;
  int64_t count = 0;
  MeasuredPose pose;
  pose.joints_rad.resize(q.size());
  for (CsvRow row; table.Next(row);) {
    ++count;
    pose.id = id_col >= 0 ? table.Name(row, id_col) : std::to_string(count);
    if (id_col >= 0) ids.Add(pose.id, row.line);
    using plausible::Quantity;
    for (size_t i = 0; i < q.size(); ++i) {
      pose.joints_rad(i) =
          table.Number(row, q[i], Quantity::kJointAngle, plausible::UnitOf(q_unit[i]));
    }
    for (int k = 0; k < 3; ++k) {
      pose.target_in_world(k) = table.Number(row, xyz[k], Quantity::kCoordinate, length_unit);
    }
    sink(pose, row.line);
  }
  if (count == 0) throw InputError({path, 0, 0, ""}, "no data rows");
  ids.Check(
      [&](const SeenIds::Visit& visit) {
        CsvReader again(path, csv);
        for (CsvRow row; again.Next(row);) visit(again.Text(row, id_col), row, again);
      },
      id_col);
}

std::vector<MeasuredPose> ImportPoses(const std::string& path, const PoseImportOptions& options) {
  std::vector<MeasuredPose> poses;
  ImportPosesStreamed(path, options, [&](const MeasuredPose& p, int) { poses.push_back(p); });
  return poses;
}

}  // namespace armsig::io
