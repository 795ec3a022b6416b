#include "iso9283/iso9283_csv.h"

#include <fmt/format.h>

#include <algorithm>
#include <map>
#include <set>
#include <tuple>

#include "core/error.h"
#include "core/text.h"
#include "core/units.h"
#include "io/csv.h"

namespace armsig::iso9283 {

namespace {

using plausible::Quantity;

// The id column: `point`, else `pose`.
int IdColumn(const io::CsvTable& t) {
  if (const auto c = t.FindColumn("point")) return *c;
  if (const auto c = t.FindColumn("pose")) return *c;
  throw InputError({t.source(), t.header_line(), 0, ""},
                   "missing column 'point' (or 'pose'): expected point,x_mm,y_mm,z_mm");
}

struct PositionColumns {
  int x = -1, y = -1, z = -1;
  std::optional<io::AngleColumn> a, b, c;
};

PositionColumns PositionColumnsOf(const io::CsvTable& t) {
  t.RefuseUnreadUnits(
      {"point", "pose", "cycle", "approach", "x_mm", "y_mm", "z_mm", "a_*", "b_*", "c_*"});
  PositionColumns p;
  p.x = t.Column("x_mm");
  p.y = t.Column("y_mm");
  p.z = t.Column("z_mm");
  p.a = t.FindAngleColumn("a");
  p.b = t.FindAngleColumn("b");
  p.c = t.FindAngleColumn("c");
  const int angles = !!p.a + !!p.b + !!p.c;
  if (angles != 0 && angles != 3) {
    throw InputError({t.source(), t.header_line(), 0, ""},
                     "give the orientation as all of a, b and c (e.g. a_deg, b_deg, c_deg), or "
                     "none of them");
  }
  return p;
}

Eigen::Vector3d PositionOf(const io::CsvTable& t, const io::CsvRow& row, const PositionColumns& p) {
  return {t.Number(row, p.x, Quantity::kCoordinate), t.Number(row, p.y, Quantity::kCoordinate),
          t.Number(row, p.z, Quantity::kCoordinate)};
}

std::optional<Eigen::Vector3d> OrientationOf(const io::CsvTable& t, const io::CsvRow& row,
                                             const PositionColumns& p) {
  if (!p.a) return std::nullopt;
  return Eigen::Vector3d(t.AngleRad(row, *p.a), t.AngleRad(row, *p.b), t.AngleRad(row, *p.c));
}

// A name that may be left empty (a via point's point, the one approach).
std::string OptionalName(const io::CsvTable& t, const io::CsvRow& row, int column) {
  return t.Text(row, column).empty() ? std::string() : t.Name(row, column);
}

const std::string& PointName(const io::CsvTable& t, const io::CsvRow& row, int column) {
  const std::string& name = t.Name(row, column);
  if (name.empty()) throw InputError(t.Where(row, column), "expected a point name");
  return name;
}

}  // namespace

std::vector<CommandedPoint> ReadCommandedCsv(const std::string& path) {
  const io::CsvTable t = io::ReadCsvFile(path);
  const int id = IdColumn(t);
  const PositionColumns p = PositionColumnsOf(t);
  std::vector<CommandedPoint> out;
  std::set<std::string> seen;
  for (const io::CsvRow& row : t.rows()) {
    CommandedPoint c;
    c.point = PointName(t, row, id);
    if (!seen.insert(c.point).second)
      throw InputError(t.Where(row, id), "point " + Quoted(c.point) + " is commanded twice");
    c.position_mm = PositionOf(t, row, p);
    c.orientation_rad = OrientationOf(t, row, p);
    c.line = row.line;
    out.push_back(std::move(c));
  }
  if (out.empty()) throw InputError({path, 0, 0, ""}, "no commanded points (expected data rows)");
  return out;
}

std::vector<AttainedRow> ReadAttainedCsv(const std::string& path) {
  const io::CsvTable t = io::ReadCsvFile(path);
  const int id = IdColumn(t);
  const PositionColumns p = PositionColumnsOf(t);
  const std::optional<int> cycle = t.FindColumn("cycle");
  const std::optional<int> approach = t.FindColumn("approach");
  std::vector<AttainedRow> out;
  std::map<std::tuple<std::string, int, std::string>, int> seen;  // → line
  std::map<std::pair<std::string, std::string>, int> counted;     // cycles without a column
  for (const io::CsvRow& row : t.rows()) {
    AttainedRow a;
    a.point = PointName(t, row, id);
    if (approach) a.approach = OptionalName(t, row, *approach);
    if (cycle) {
      a.cycle = t.Integer(row, *cycle);
      if (a.cycle < 1)
        throw InputError(t.Where(row, *cycle),
                         fmt::format("expected a cycle number from 1, got {}", a.cycle));
    } else {
      a.cycle = ++counted[{a.point, a.approach}];
    }
    a.position_mm = PositionOf(t, row, p);
    a.orientation_rad = OrientationOf(t, row, p);
    a.line = row.line;
    const auto [it, fresh] = seen.emplace(std::make_tuple(a.point, a.cycle, a.approach), row.line);
    if (!fresh) {
      throw InputError(
          t.Where(row, cycle.value_or(id)),
          fmt::format("point {} cycle {}{} is given twice (first on line {})", Quoted(a.point),
                      a.cycle, a.approach.empty() ? "" : " approach " + Quoted(a.approach),
                      it->second));
    }
    out.push_back(std::move(a));
  }
  if (out.empty()) throw InputError({path, 0, 0, ""}, "no attained poses (expected data rows)");
  return out;
}

std::string FormatIso9283PlanCsv(const std::vector<Iso9283PlanRow>& rows) {
  std::string out;
  const int n = rows.empty() ? 0 : static_cast<int>(rows[0].joints_rad.size());
  const bool speeds = std::any_of(rows.begin(), rows.end(),
                                  [](const Iso9283PlanRow& r) { return r.speed_mm_s.has_value(); });
  out += "pose,point,cycle,approach,x_mm,y_mm,z_mm";
  for (int i = 1; i <= n; ++i) out += fmt::format(",q{}_deg", i);
  const bool motions = std::any_of(rows.begin(), rows.end(),
                                   [](const Iso9283PlanRow& r) { return !r.motion.empty(); });
  if (speeds) out += ",speed_mm_s";
  if (motions) out += ",motion";
  out += "\n";
  for (const auto& r : rows) {
    out += fmt::format("{},{},{},{},{:.6f},{:.6f},{:.6f}", io::CsvEscape(r.pose), io::CsvEscape(r.point),
                       r.cycle > 0 ? std::to_string(r.cycle) : std::string(), io::CsvEscape(r.approach),
                       r.target_mm.x(), r.target_mm.y(), r.target_mm.z());
    for (int i = 0; i < n; ++i) out += fmt::format(",{:.8f}", r.joints_rad(i) / kRadPerDeg);
    if (speeds) out += r.speed_mm_s ? fmt::format(",{:g}", *r.speed_mm_s) : std::string(",");
    if (motions) out += "," + r.motion;
    out += "\n";
  }
  return out;
}

std::vector<Iso9283PlanRow> ReadIso9283PlanCsv(const std::string& path, int num_joints) {
  const io::CsvTable t = io::ReadCsvFile(path);
  std::vector<std::string> known = {"pose",     "point", "cycle", "approach",
                                    "x_mm",     "y_mm",  "z_mm",  "speed_mm_s", "motion"};
  for (int i = 1; i <= num_joints; ++i) known.push_back("q" + std::to_string(i) + "_*");
  t.RefuseUnreadUnits(known);
  const int pose = t.Column("pose"), point = t.Column("point"), cycle = t.Column("cycle");
  const std::optional<int> approach = t.FindColumn("approach");
  const std::optional<int> speed = t.FindColumn("speed_mm_s");
  const std::optional<int> motion = t.FindColumn("motion");
  const int x = t.Column("x_mm"), y = t.Column("y_mm"), z = t.Column("z_mm");
  std::vector<io::AngleColumn> q;
  for (int i = 1; i <= num_joints; ++i) q.push_back(t.AngleColumnOf("q" + std::to_string(i)));
  std::vector<Iso9283PlanRow> out;
  std::set<std::string> labels;
  for (const io::CsvRow& row : t.rows()) {
    Iso9283PlanRow r;
    r.pose = t.Name(row, pose);
    if (r.pose.empty()) throw InputError(t.Where(row, pose), "expected a pose label");
    if (!labels.insert(r.pose).second)
      throw InputError(t.Where(row, pose), "duplicate pose " + Quoted(r.pose));
    r.point = OptionalName(t, row, point);
    if (!r.point.empty()) {
      r.cycle = t.Integer(row, cycle);
      if (r.cycle < 1)
        throw InputError(t.Where(row, cycle),
                         fmt::format("expected a cycle number from 1, got {}", r.cycle));
    }
    if (approach) r.approach = OptionalName(t, row, *approach);
    r.target_mm = {t.Number(row, x, Quantity::kCoordinate), t.Number(row, y, Quantity::kCoordinate),
                   t.Number(row, z, Quantity::kCoordinate)};
    r.joints_rad.resize(num_joints);
    for (int i = 0; i < num_joints; ++i)
      r.joints_rad(i) = t.AngleRad(row, q[i], Quantity::kJointAngle);
    if (speed) r.speed_mm_s = t.OptionalNumber(row, *speed);
    if (motion) r.motion = t.Text(row, *motion);
    out.push_back(std::move(r));
  }
  if (out.empty()) throw InputError({path, 0, 0, ""}, "empty plan");
  return out;
}

}  // namespace armsig::iso9283
