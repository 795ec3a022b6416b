#include "workflows/network.h"

#include <fmt/format.h>

#include <set>
#include <stdexcept>

#include "core/error.h"
#include "io/csv.h"
#include "reduction/intersection.h"

namespace armsig::workflows {

OrientRun OrientFiles(const OrientFilesOptions& options) {
  OrientRun run;
  reduction::OrientationProblem problem;
  problem.observations = io::ReadObservationsCsv(options.observations);
  if (options.instrument_errors) {
    run.instrument_errors =
        reduction::ReduceTwoFace(problem.observations, reduction::InstrumentDefaults{});
  }
  for (const auto& text : options.scale_bars) {
    problem.scale_bars.push_back(io::ParseScaleBar(text, options.scale_bar_sigma_mm));
  }
  if (!options.control.empty()) problem.control = io::ReadControlCsv(options.control);
  // Station order: the datum station first, then in order of appearance.
  std::set<std::string> seen;
  if (!options.datum_station.empty()) {
    problem.station_ids.push_back(options.datum_station);
    seen.insert(options.datum_station);
  }
  for (const auto& o : problem.observations) {
    if (seen.insert(o.station).second) problem.station_ids.push_back(o.station);
  }
  if (!options.datum_station.empty()) {
    bool observed = false;
    for (const auto& o : problem.observations) observed |= o.station == options.datum_station;
    if (!observed) {
      throw InputError(
          {"--datum-station", 0, 0, ""},
          "station '" + options.datum_station + "' has no observations in " + options.observations);
    }
  }
  for (const auto& id : options.unlevelled) {
    if (!seen.count(id)) {
      throw InputError({"--unlevelled", 0, 0, ""}, "unknown station '" + id + "'");
    }
    problem.unlevelled.insert(id);
  }
  problem.free_datum = options.free_datum || !options.datum_points.empty();
  problem.datum_points.insert(options.datum_points.begin(), options.datum_points.end());
  run.result = reduction::Orient(problem);
  if (!run.result.refusals.empty()) {
    std::string why;
    for (const auto& r : run.result.refusals) why += "\n  - " + r;
    throw InputError({options.observations, 0, 0, ""},
                     "the network cannot be solved:" + why + "\nnothing was written");
  }
  if (run.result.status.code == SolveCode::kNonFinite) {
    // Exit code 1, and no stations file of numbers that are not results.
    throw std::runtime_error("orientation failed: " + run.result.status.message +
                             "; nothing was written");
  }
  return run;
}

std::string FormatAdjustedPointsCsv(const std::vector<reduction::PointEstimate>& points) {
  std::string csv =
      "point,x_mm,y_mm,z_mm,sx_mm,sy_mm,sz_mm,ellipsoid95_a_mm,ellipsoid95_b_mm,"
      "ellipsoid95_c_mm,rays,control\n";
  for (const auto& p : points) {
    const auto e = reduction::EllipsoidOf(p.covariance_mm2);
    csv += fmt::format("{},{:.6f},{:.6f},{:.6f},{:.6f},{:.6f},{:.6f},{:.6f},{:.6f},{:.6f},{},{}\n",
                       io::CsvEscape(p.id), p.position_mm.x(), p.position_mm.y(), p.position_mm.z(),
                       std::sqrt(p.covariance_mm2(0, 0)), std::sqrt(p.covariance_mm2(1, 1)),
                       std::sqrt(p.covariance_mm2(2, 2)), e.semi_axes_mm(0), e.semi_axes_mm(1),
                       e.semi_axes_mm(2), p.rays, p.control ? 1 : 0);
  }
  return csv;
}

TriangulateRun TriangulateFiles(const TriangulateFilesOptions& options) {
  TriangulateRun run;
  const auto stations = io::ReadStationsYaml(options.stations);
  run.observations = io::ReadObservationsCsv(options.observations);
  if (options.instrument_errors) {
    run.instrument_errors =
        reduction::ReduceTwoFace(run.observations, reduction::InstrumentDefaults{});
  }
  std::map<std::string, const reduction::Station*> by_id;
  for (const auto& s : stations) by_id[s.pose.id] = &s;
  const reduction::InstrumentDefaults defaults;
  std::map<std::string, size_t> index;
  std::vector<reduction::RayGroup> groups;
  for (size_t k = 0; k < run.observations.size(); ++k) {
    const auto& o = run.observations[k];
    auto it = by_id.find(o.station);
    if (it == by_id.end()) {
      throw InputError({options.observations, o.source_line, 0, "station"},
                       "station '" + o.station + "' is not in " + options.stations);
    }
    if (by_id.count(o.point)) continue;  // a mutual pointing: not a target point
    auto [pos, inserted] = index.emplace(o.point, run.points.size());
    if (inserted) {
      run.points.push_back({o.point, {}, {}});
      groups.emplace_back();
    }
    groups[pos->second].rays.push_back(reduction::RayOf(o, *it->second, defaults));
    run.points[pos->second].observations.push_back(static_cast<int>(k));
  }
  reduction::PointOptions point_options;  // no tolerances: no miss or repeat checks
  point_options.intersection.reject_blunders = options.reject_blunders;
  point_options.intersection.critical_w = options.critical_w;
  reduction::ReducedPoint reduced;
  for (size_t p = 0; p < run.points.size(); ++p) {
    reduction::IntersectPoint(groups[p], point_options, reduced);
    run.points[p].result = std::move(reduced.result);
    if (run.points[p].result.status.ok()) {
      ++run.intersected;
      run.rejected_rays += run.points[p].result.rejected;
    }
  }
  return run;
}

}  // namespace armsig::workflows
