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
#include "core/rotation.h"
#include "core/text.h"
#include "io/csv.h"
#include "io/joint_unit_check.h"

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

// Where a table keeps its poses' measured orientation: three angle columns (or none) and
// their sigma columns (or none).
struct OrientationColumns {
  int angle[3] = {-1, -1, -1};
  plausible::Unit angle_unit[3] = {plausible::kMm, plausible::kMm, plausible::kMm};
  int sigma[3] = {-1, -1, -1};
  plausible::Unit sigma_unit[3] = {plausible::kArcsec, plausible::kArcsec, plausible::kArcsec};
  bool present() const { return angle[0] >= 0; }
};

constexpr const char* kAngleNames[3] = {"rx", "ry", "rz"};

// A row's orientation: nullopt when its three angle fields (and sigma fields) are empty.
// Throws InputError at a row that gives some of the three but not all, or sigmas without
// their angles.
std::optional<MeasuredOrientation> ReadOrientation(const CsvColumns& table, const CsvRow& row,
                                                   const OrientationColumns& columns) {
  if (!columns.present()) return std::nullopt;
  auto given = [&](const int (&index)[3], int& first_missing) {
    int count = 0;
    first_missing = -1;
    for (int k = 0; k < 3; ++k) {
      if (index[k] < 0) continue;
      if (!Trim(row.fields.at(index[k]), " \t").empty()) {
        ++count;
      } else if (first_missing < 0) {
        first_missing = index[k];
      }
    }
    return count;
  };
  int missing_angle = -1, missing_sigma = -1;
  const int angles = given(columns.angle, missing_angle);
  const int sigmas = columns.sigma[0] >= 0 ? given(columns.sigma, missing_sigma) : 0;
  if (angles == 0) {
    if (sigmas > 0) {
      throw InputError(table.Where(row, missing_angle),
                       "sigmas of an orientation whose angles are empty: expected the three "
                       "angles rx, ry, rz with them (or every orientation field empty for a "
                       "position-only pose)");
    }
    return std::nullopt;
  }
  if (angles < 3) {
    throw InputError(table.Where(row, missing_angle),
                     "expected the three orientation angles rx, ry, rz together (or all three "
                     "empty for a position-only pose)");
  }
  using plausible::Quantity;
  Eigen::Vector3d a;
  for (int k = 0; k < 3; ++k) {
    a(k) = table.Number(row, columns.angle[k], Quantity::kAngle, columns.angle_unit[k]);
  }
  MeasuredOrientation orientation;
  orientation.world_from_target = RotationFromRxRyRz(a);
  if (sigmas > 0) {
    if (sigmas < 3) {
      throw InputError(table.Where(row, missing_sigma),
                       "expected the three sigmas of rx, ry, rz together (or all three empty)");
    }
    Eigen::Vector3d sigma;
    for (int k = 0; k < 3; ++k) {
      sigma(k) =
          table.Number(row, columns.sigma[k], Quantity::kSigmaAngle, columns.sigma_unit[k]);
    }
    orientation.sigma_rad = sigma;
  }
  return orientation;
}

// The poses CSV's orientation columns: rx, ry, rz with any angle unit suffix (all three or
// none) and sigma_rx_arcsec, sigma_ry_arcsec, sigma_rz_arcsec (all three or none, only with
// the angles).
OrientationColumns PosesCsvOrientation(const CsvColumns& table) {
  OrientationColumns columns;
  std::optional<AngleColumn> angle[3];
  std::optional<int> sigma[3];
  int angles = 0, sigmas = 0;
  for (int k = 0; k < 3; ++k) {
    angle[k] = table.FindAngleColumn(kAngleNames[k]);
    sigma[k] = table.FindColumn("sigma_" + std::string(kAngleNames[k]) + "_arcsec");
    angles += angle[k].has_value();
    sigmas += sigma[k].has_value();
  }
  auto refuse_partial = [&](auto& found, int count, const std::string& what,
                            const std::string& expected) {
    if (count == 0 || count == 3) return;
    for (int k = 0; k < 3; ++k) {
      if (found[k]) continue;
      throw InputError(table.HeaderWhere(0), "the header has " + std::to_string(count) + " of the " +
                                                 what + " columns: expected " + expected +
                                                 " together (or none for position-only poses)");
    }
  };
  refuse_partial(angle, angles, "orientation", "rx_deg, ry_deg and rz_deg (any angle unit)");
  refuse_partial(sigma, sigmas, "orientation sigma",
                 "sigma_rx_arcsec, sigma_ry_arcsec and sigma_rz_arcsec");
  if (sigmas == 3 && angles == 0) {
    throw InputError(table.HeaderWhere(*sigma[0]),
                     "orientation sigmas without the angles: expected rx_deg, ry_deg, rz_deg "
                     "(any angle unit) with them");
  }
  if (angles == 0) return columns;
  for (int k = 0; k < 3; ++k) {
    columns.angle[k] = angle[k]->index;
    columns.angle_unit[k] = plausible::UnitOf(angle[k]->unit);
    if (sigmas == 3) columns.sigma[k] = *sigma[k];
  }
  return columns;
}

}  // namespace

void ReadPosesStreamed(const std::string& path, int num_joints, std::optional<AngleUnit> joint_unit,
                       const std::function<void(const MeasuredPose&, int line)>& sink,
                       ReadProgressFn progress, PosesCsvLayout* layout) {
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
  for (const char* angle : kAngleNames) {
    known.push_back(std::string(angle) + "_*");
    known.push_back("sigma_" + std::string(angle) + "_arcsec");
  }
  table.RefuseUnreadUnits(known);
  const OrientationColumns orientation = PosesCsvOrientation(table);
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
  if (layout) *layout = {num_joints, orientation.present(), orientation.sigma[0] >= 0};
  SeenIds ids;
  MeasuredPose pose;
  pose.joints_rad.resize(num_joints);
  int64_t count = 0;
  std::vector<JointUnitCheck::Column> unit_columns;
  for (const auto& c : q) unit_columns.push_back({c.name, plausible::UnitOf(c.unit)});
  JointUnitCheck units(path, std::move(unit_columns));
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
    pose.orientation = ReadOrientation(table, row, orientation);
    units.Add(pose.joints_rad);
    sink(pose, row.line);
    ++count;
  }
  if (count == 0)
    throw InputError({path, 0, 0, ""}, "no poses (expected data rows after the header)");
  units.Finish();
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

PosesCsvLayout PosesCsvLayoutOf(const std::vector<MeasuredPose>& poses, int num_joints) {
  PosesCsvLayout layout;
  layout.num_joints = num_joints >= 0  ? num_joints
                      : poses.empty() ? 0
                                      : static_cast<int>(poses[0].joints_rad.size());
  for (const auto& pose : poses) {
    if (!pose.orientation) continue;
    layout.orientation = true;
    layout.orientation_sigmas |= pose.orientation->sigma_rad.has_value();
  }
  return layout;
}

std::string PosesCsvHeader(const PosesCsvLayout& layout) {
  std::string out = "pose";
  for (int i = 1; i <= layout.num_joints; ++i) out += ",q" + std::to_string(i) + "_deg";
  out += ",x_mm,y_mm,z_mm";
  if (layout.orientation) out += ",rx_deg,ry_deg,rz_deg";
  if (layout.orientation_sigmas) out += ",sigma_rx_arcsec,sigma_ry_arcsec,sigma_rz_arcsec";
  return out + '\n';
}

std::string PosesCsvRow(const MeasuredPose& pose, const PosesCsvLayout& layout) {
  if (pose.orientation && !layout.orientation) {
    throw std::invalid_argument("PosesCsvRow: pose " + pose.id +
                                " has an orientation the file's columns cannot hold");
  }
  if (pose.orientation && pose.orientation->sigma_rad && !layout.orientation_sigmas) {
    throw std::invalid_argument("PosesCsvRow: pose " + pose.id +
                                " has orientation sigmas the file's columns cannot hold");
  }
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
  if (layout.orientation) {
    if (pose.orientation) {
      const Eigen::Vector3d angles = RxRyRzFromRotation(pose.orientation->world_from_target);
      for (int k = 0; k < 3; ++k) {
        std::snprintf(buffer, sizeof buffer, ",%.12g", FromRad(angles(k), AngleUnit::kDeg));
        out += buffer;
      }
    } else {
      out += ",,,";
    }
  }
  if (layout.orientation_sigmas) {
    if (pose.orientation && pose.orientation->sigma_rad) {
      for (int k = 0; k < 3; ++k) {
        std::snprintf(buffer, sizeof buffer, ",%.9g",
                      (*pose.orientation->sigma_rad)(k) / kRadPerArcsec);
        out += buffer;
      }
    } else {
      out += ",,,";
    }
  }
  return out + '\n';
}

std::string FormatPosesCsv(const std::vector<MeasuredPose>& poses, int num_joints) {
  const PosesCsvLayout layout = PosesCsvLayoutOf(poses, num_joints);
  std::string out = PosesCsvHeader(layout);
  for (const auto& pose : poses) {
    if (pose.joints_rad.size() != layout.num_joints)
      throw std::invalid_argument("FormatPosesCsv: pose " + pose.id + " has another joint count");
    out += PosesCsvRow(pose, layout);
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
  // The T-Mac probe's orientation, in degrees, in the convention of core/rotation.h.
  o.rotation_columns = {"measurement_rx", "measurement_ry", "measurement_rz"};
  o.rotation_sigma_columns = {"measurement_std_rx", "measurement_std_ry", "measurement_std_rz"};
  o.rotation_unit = AngleUnit::kDeg;
  return o;
}

namespace {

void CheckImportOptions(const PoseImportOptions& options) {
  if (options.joint_columns.empty()) throw InputError("no joint columns given (--joint-columns)");
  if (options.xyz_columns.size() != 3) throw InputError("expected three position columns (--xyz-columns)");
  if (!options.rotation_columns.empty() && options.rotation_columns.size() != 3) {
    throw InputError("expected three orientation columns rx, ry, rz (--rotation-columns), got " +
                     std::to_string(options.rotation_columns.size()));
  }
  if (!options.rotation_sigma_columns.empty() && options.rotation_sigma_columns.size() != 3) {
    throw InputError("expected three orientation sigma columns (--rotation-sigma-columns), got " +
                     std::to_string(options.rotation_sigma_columns.size()));
  }
  if (!options.rotation_sigma_columns.empty() && options.rotation_columns.empty()) {
    throw InputError(
        "orientation sigma columns without orientation columns: give --rotation-columns too");
  }
  // Each column names one quantity: a joint given twice, or a column that is a joint and a
  // coordinate, is a typo that would silently calibrate nonsense.
  std::vector<std::pair<std::string, std::string>> named;  // column, option
  for (const auto& c : options.joint_columns) named.emplace_back(c, "--joint-columns");
  for (const auto& c : options.xyz_columns) named.emplace_back(c, "--xyz-columns");
  for (const auto& c : options.rotation_columns) named.emplace_back(c, "--rotation-columns");
  for (const auto& c : options.rotation_sigma_columns)
    named.emplace_back(c, "--rotation-sigma-columns");
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

// The unit of a named orientation column: its suffix's, else the --rotation-unit; one
// that contradicts the other is refused, and so is a column with neither.
AngleUnit RotationUnitOf(const CsvColumns& table, int column, const std::string& name,
                         std::optional<AngleUnit> unit) {
  const auto suffix = AngleUnitFromSuffix(name);
  if (suffix && unit && *suffix != *unit) {
    throw InputError(table.HeaderWhere(column),
                     "column " + Quoted(name) + " is in " +
                         std::string(AngleUnitSuffix(*suffix).substr(1)) +
                         " by its name, but --rotation-unit " +
                         std::string(AngleUnitSuffix(*unit).substr(1)) +
                         " was given: leave --rotation-unit out (the suffix gives the unit)");
  }
  if (!suffix && !unit) {
    throw InputError(table.HeaderWhere(column),
                     "column " + Quoted(name) +
                         " names no angle unit: give --rotation-unit deg, gon or rad");
  }
  return suffix ? *suffix : *unit;
}

OrientationColumns ImportedOrientation(const CsvColumns& table, const PoseImportOptions& options) {
  OrientationColumns columns;
  for (size_t k = 0; k < options.rotation_columns.size(); ++k) {
    const std::string& name = options.rotation_columns[k];
    columns.angle[k] = table.Column(name);
    columns.angle_unit[k] =
        plausible::UnitOf(RotationUnitOf(table, columns.angle[k], name, options.rotation_unit));
  }
  for (size_t k = 0; k < options.rotation_sigma_columns.size(); ++k) {
    const std::string& name = options.rotation_sigma_columns[k];
    columns.sigma[k] = table.Column(name);
    columns.sigma_unit[k] =
        plausible::UnitOf(RotationUnitOf(table, columns.sigma[k], name, options.rotation_unit));
  }
  return columns;
}

}  // namespace

void ImportPosesStreamed(const std::string& path, const PoseImportOptions& options,
                         const std::function<void(const MeasuredPose&, int line)>& sink,
                         ReadProgressFn progress, PosesCsvLayout* layout) {
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
  const OrientationColumns orientation = ImportedOrientation(table, options);
  if (layout) {
    *layout = {static_cast<int>(q.size()), orientation.present(), orientation.sigma[0] >= 0};
  }
  // The file's length unit: mm unless --length-scale says otherwise.
  const plausible::Unit length_unit{options.length_scale_to_mm == 1.0 ? "mm" : "(file units)",
                                    options.length_scale_to_mm};
  SeenIds ids;
  int64_t count = 0;
  MeasuredPose pose;
  pose.joints_rad.resize(q.size());
  std::vector<JointUnitCheck::Column> unit_columns;
  for (size_t i = 0; i < q.size(); ++i)
    unit_columns.push_back({options.joint_columns[i], plausible::UnitOf(q_unit[i])});
  JointUnitCheck units(path, std::move(unit_columns));
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
    pose.orientation = ReadOrientation(table, row, orientation);
    units.Add(pose.joints_rad);
    sink(pose, row.line);
  }
  if (count == 0) throw InputError({path, 0, 0, ""}, "no data rows");
  units.Finish();
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
