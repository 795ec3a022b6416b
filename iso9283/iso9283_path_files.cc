#include "iso9283/iso9283_path_files.h"

#include <fmt/format.h>

#include <cmath>
#include <map>
#include <stdexcept>

#include "core/error.h"
#include "core/units.h"
#include "io/csv.h"

namespace armsig::iso9283 {

namespace iso = calibration::iso9283;

namespace {

Eigen::Vector3d PositionAt(const io::CsvTable& t, const io::CsvRow& row) {
  return {t.Number(row, t.Column("x_mm")), t.Number(row, t.Column("y_mm")),
          t.Number(row, t.Column("z_mm"))};
}

nlohmann::json Value(double v) { return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(); }

}  // namespace

iso::PathFigures EvaluatePathFiles(const std::string& commanded_csv, const std::string& attained_csv,
                                   double speed_mm_s) {
  iso::PathCommand command;
  command.speed_mm_s = speed_mm_s;
  {
    const io::CsvTable t = io::ReadCsvFile(commanded_csv);
    t.RefuseUnreadUnits({"vertex", "x_mm", "y_mm", "z_mm"});
    for (const io::CsvRow& row : t.rows()) command.vertices_mm.push_back(PositionAt(t, row));
    if (command.vertices_mm.size() < 2) {
      throw InputError({commanded_csv, 0, 0, ""},
                       fmt::format("a path needs at least two vertices, got {}",
                                   command.vertices_mm.size()));
    }
  }
  std::map<int, iso::AttainedCycle> cycles;
  {
    const io::CsvTable t = io::ReadCsvFile(attained_csv);
    t.RefuseUnreadUnits({"cycle", "t_s", "x_mm", "y_mm", "z_mm"});
    const int cycle = t.Column("cycle"), time = t.Column("t_s");
    for (const io::CsvRow& row : t.rows()) {
      const int c = t.Integer(row, cycle);
      if (c < 1) throw InputError(t.Where(row, cycle), fmt::format("expected a cycle number from 1, got {}", c));
      const double ts = t.Number(row, time);
      auto& samples = cycles[c].samples;
      if (!samples.empty() && !(ts > samples.back().t_s)) {
        throw InputError(t.Where(row, time),
                         fmt::format("cycle {}: time {} s does not follow {} s (each cycle's rows in "
                                     "time order)",
                                     c, ts, samples.back().t_s));
      }
      samples.push_back({ts, PositionAt(t, row)});
    }
    if (cycles.empty()) throw InputError({attained_csv, 0, 0, ""}, "no attained samples (expected data rows)");
  }
  std::vector<iso::AttainedCycle> attained;
  for (auto& [c, cycle] : cycles) attained.push_back(std::move(cycle));
  try {
    return iso::EvaluatePath(command, attained);
  } catch (const std::invalid_argument& e) {
    throw InputError({commanded_csv, 0, 0, ""}, e.what());
  }
}

nlohmann::json PathJson(const iso::PathFigures& f) {
  nlohmann::json corners = nlohmann::json::array();
  for (const auto& c : f.corners) {
    corners.push_back({{"vertex", c.vertex},
                       {"turn_deg", c.turn_rad / kRadPerDeg},
                       {"CR_mm", Value(c.cr_max_mm)},
                       {"CO_mm", Value(c.co_max_mm)}});
  }
  return {{"cycles", f.n},
          {"length_mm", f.length_mm},
          {"planes", f.planes_used},
          {"AT_mm", Value(f.at_mm)},
          {"AT_xyz_mm", {Value(f.at_xyz_mm.x()), Value(f.at_xyz_mm.y()), Value(f.at_xyz_mm.z())}},
          {"mean_AT_mm", Value(f.mean_at_mm)},
          {"RT_mm", Value(f.rt_mm)},
          {"commanded_speed_mm_s", f.commanded_speed_mm_s},
          {"mean_speed_mm_s", Value(f.mean_speed_mm_s)},
          {"AV_percent", Value(f.av_percent)},
          {"RV_percent", Value(f.rv_percent)},
          {"FV_mm_s", Value(f.fv_mm_s)},
          {"corners", corners}};
}

std::string FormatPathFigures(const iso::PathFigures& f) {
  std::string out = fmt::format(
      "ISO 9283 path characteristics: {} cycle{} over a {:.1f} mm path, {} normal planes\n"
      "  path accuracy AT {:.4f} mm (mean over the planes {:.4f}), repeatability RT {:.4f} mm\n"
      "  velocity: commanded {:.1f} mm/s, attained {:.2f} mm/s; AV {:+.2f} %, RV ±{:.2f} %, FV "
      "{:.2f} mm/s\n",
      f.n, f.n == 1 ? "" : "s", f.length_mm, f.planes_used, f.at_mm, f.mean_at_mm, f.rt_mm,
      f.commanded_speed_mm_s, f.mean_speed_mm_s, f.av_percent, f.rv_percent, f.fv_mm_s);
  for (const auto& c : f.corners) {
    out += fmt::format("  corner at vertex {} ({:.0f}°): CR {:.4f} mm, CO {:.4f} mm\n", c.vertex + 1,
                       c.turn_rad / kRadPerDeg, c.cr_max_mm, c.co_max_mm);
  }
  return out;
}

}  // namespace armsig::iso9283
