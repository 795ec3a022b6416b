// armsig orient: station set-up by bundle adjustment.
// armsig triangulate: intersection of every target point from oriented stations.
#include <fmt/format.h>

#include <algorithm>
#include <iostream>
#include <map>
#include <set>

#include "app/command.h"
#include "core/error.h"
#include "core/units.h"
#include "io/atomic_file.h"
#include "io/csv.h"
#include "io/network_io.h"
#include "reduction/instrument_errors.h"
#include "reduction/intersection.h"
#include "reduction/orientation.h"

namespace armsig::app {

struct OrientOptions {
  std::string observations, control, out, points_out, datum_station;
  std::vector<std::string> scale_bars, unlevelled;
  double scale_bar_sigma_mm = 0.01;
  bool no_instrument_errors = false;
  bool free_datum = false;
  std::vector<std::string> datum_points;
};

struct TriangulateOptions {
  std::string stations, observations, out;
  bool no_reject = false;
  double critical_w = 3.29;
  bool no_instrument_errors = false;
};

namespace {

// Two-face reduction: estimate each station's axis errors and correct its readings.
void ReduceFaces(std::vector<reduction::Observation>& observations, bool enabled) {
  if (!enabled) return;
  const auto errors = reduction::ReduceTwoFace(observations, reduction::InstrumentDefaults{});
  for (const auto& [station, e] : errors) {
    std::cout << fmt::format(
        "station {}: {} two-face pairs: collimation {:.2f}\" ± {:.2f}, trunnion {}, vertical index "
        "{:.2f}\" ± {:.2f} (applied to all its readings)\n",
        station, e.pairs, e.collimation_rad / kRadPerArcsec,
        e.sigma_collimation_rad / kRadPerArcsec,
        e.trunnion_determined ? fmt::format("{:.2f}\" ± {:.2f}", e.trunnion_rad / kRadPerArcsec,
                                            e.sigma_trunnion_rad / kRadPerArcsec)
                              : std::string("not determinable (zenith angles too alike)"),
        e.index_rad / kRadPerArcsec, e.sigma_index_rad / kRadPerArcsec);
  }
}

std::string Describe(const reduction::ResidualReport& r) {
  static const char* kKinds[] = {"Hz", "V", "distance", "scale bar", "control"};
  const bool angle = r.kind == reduction::ResidualReport::Kind::kHz ||
                     r.kind == reduction::ResidualReport::Kind::kV;
  return fmt::format("{:<10} {:<16} v {:>9.3f}{}  w {:>6.2f}  r {:.2f}  MDB {:.3f}{}",
                     kKinds[static_cast<int>(r.kind)], r.label, r.residual, angle ? "\"" : " mm",
                     r.w, r.redundancy, r.mdb, angle ? "\"" : " mm");
}

}  // namespace

int RunOrient(const OrientOptions& options) {
  reduction::OrientationProblem problem;
  problem.observations = io::ReadObservationsCsv(options.observations);
  ReduceFaces(problem.observations, !options.no_instrument_errors);
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
  const reduction::OrientationResult result = reduction::Orient(problem);
  if (!result.ok) {
    std::string why;
    for (const auto& r : result.refusals) why += "\n  - " + r;
    throw InputError({options.observations, 0, 0, ""},
                     "the network cannot be solved:" + why + "\nnothing was written");
  }

  std::cout << fmt::format("Orientation of {} stations, {} target points ({})\n",
                           result.stations.size(), result.points.size(), result.datum);
  std::cout << fmt::format(
      "sigma0 a posteriori {:.4f} (a priori 1), {} observations, {} unknowns, "
      "{} degrees of freedom, {} iterations{}\n\n",
      result.sigma0, result.observations, result.unknowns, result.dof, result.iterations,
      result.converged ? "" : " (NOT converged)");
  std::cout << fmt::format("{:<10}{:>14}{:>14}{:>14}{:>16}{:>10}{:>10}{:>10}{:>12}\n", "station",
                           "x_mm", "y_mm", "z_mm", "azimuth_gon", "sx_mm", "sy_mm", "sz_mm",
                           "s_az_\"");
  for (const auto& s : result.stations) {
    std::cout << fmt::format(
        "{:<10}{:>14.4f}{:>14.4f}{:>14.4f}{:>16}{:>10.4f}{:>10.4f}{:>10.4f}{:>12.3f}\n", s.pose.id,
        s.pose.position_mm.x(), s.pose.position_mm.y(), s.pose.position_mm.z(),
        s.pose.levelled ? fmt::format("{:.6f}", FromRad(s.pose.azimuth_rad, AngleUnit::kGon))
                        : std::string("(rotation)"),
        s.sigma_position_mm.x(), s.sigma_position_mm.y(), s.sigma_position_mm.z(),
        s.sigma_azimuth_rad / kRadPerArcsec);
  }
  std::cout << "\nvariance components (one step: sigma0 of each group = sqrt(sum v^2 / sum r))\n";
  for (const auto& g : result.groups) {
    std::cout << fmt::format("  {:<18} {:>5} observations  redundancy {:>8.2f}  sigma0 {:.4f}\n",
                             g.group, g.count, g.redundancy, g.sigma0);
  }
  std::vector<reduction::ResidualReport> worst = result.residuals;
  std::sort(worst.begin(), worst.end(),
            [](const auto& a, const auto& b) { return std::abs(a.w) > std::abs(b.w); });
  std::cout << "\nlargest standardised residuals (|w| > 3.29 is a suspected blunder):\n";
  for (size_t k = 0; k < std::min<size_t>(8, worst.size()); ++k) {
    std::cout << "  " << Describe(worst[k]) << (std::abs(worst[k].w) > 3.29 ? "  BLUNDER?" : "")
              << "\n";
  }
  for (const auto& [id, why] : result.excluded_points) {
    std::cout << "point " << id << " not adjusted: " << why << "\n";
  }

  const std::string header = fmt::format(
      "armsig orient: {} stations from {}; datum: {}\nsigma0 {:.5f}, {} degrees of freedom",
      result.stations.size(), options.observations, result.datum, result.sigma0, result.dof);
  std::string points_csv;
  if (!options.points_out.empty()) {
    points_csv =
        "point,x_mm,y_mm,z_mm,sx_mm,sy_mm,sz_mm,ellipsoid95_a_mm,ellipsoid95_b_mm,"
        "ellipsoid95_c_mm,rays,control\n";
    for (const auto& p : result.points) {
      const auto e = reduction::EllipsoidOf(p.covariance_mm2);
      points_csv +=
          fmt::format("{},{:.6f},{:.6f},{:.6f},{:.6f},{:.6f},{:.6f},{:.6f},{:.6f},{:.6f},{},{}\n",
                      io::CsvEscape(p.id), p.position_mm.x(), p.position_mm.y(), p.position_mm.z(),
                      std::sqrt(p.covariance_mm2(0, 0)), std::sqrt(p.covariance_mm2(1, 1)),
                      std::sqrt(p.covariance_mm2(2, 2)), e.semi_axes_mm(0), e.semi_axes_mm(1),
                      e.semi_axes_mm(2), p.rays, p.control ? 1 : 0);
    }
  }
  io::WriteFileAtomically(options.out, io::FormatStationsYaml(result.stations, header));
  if (!options.points_out.empty()) io::WriteFileAtomically(options.points_out, points_csv);
  return result.converged ? kOk : kFailure;
}

int RunTriangulate(const TriangulateOptions& options) {
  const auto stations = io::ReadStationsYaml(options.stations);
  auto observations = io::ReadObservationsCsv(options.observations);
  ReduceFaces(observations, !options.no_instrument_errors);
  std::map<std::string, const reduction::Station*> by_id;
  for (const auto& s : stations) by_id[s.pose.id] = &s;
  reduction::InstrumentDefaults defaults;
  std::vector<io::TriangulatedPoint> points;
  std::map<std::string, size_t> index;
  std::vector<std::vector<reduction::Ray>> rays;
  for (size_t k = 0; k < observations.size(); ++k) {
    const auto& o = observations[k];
    auto it = by_id.find(o.station);
    if (it == by_id.end()) {
      throw InputError({options.observations, o.source_line, 0, "station"},
                       "station '" + o.station + "' is not in " + options.stations);
    }
    if (by_id.count(o.point)) continue;  // a mutual pointing: not a target point
    auto [pos, inserted] = index.emplace(o.point, points.size());
    if (inserted) {
      points.push_back({o.point, {}, {}});
      rays.emplace_back();
    }
    const reduction::EffectiveSigmas sigma = reduction::SigmasOf(o, it->second, defaults);
    reduction::Ray ray;
    ray.station_mm = it->second->pose.position_mm;
    ray.world_from_station = it->second->pose.world_from_station;
    ray.reading = o.reading;
    ray.distance_mm = o.distance_mm ? *o.distance_mm : std::numeric_limits<double>::quiet_NaN();
    ray.sigma_hz_rad = sigma.hz_rad;
    ray.sigma_v_rad = sigma.v_rad;
    ray.sigma_distance_mm = sigma.distance_mm;
    rays[pos->second].push_back(ray);
    points[pos->second].observations.push_back(static_cast<int>(k));
  }
  reduction::IntersectionOptions intersection;
  intersection.reject_blunders = !options.no_reject;
  intersection.critical_w = options.critical_w;
  int ok = 0, rejected = 0;
  for (size_t p = 0; p < points.size(); ++p) {
    reduction::Intersect(rays[p], intersection, points[p].result);
    const auto& r = points[p].result;
    if (r.status == reduction::IntersectionStatus::kOk) {
      ++ok;
      rejected += r.rejected;
      for (size_t k = 0; k < r.rays.size(); ++k) {
        if (r.rays[k].rejected) {
          const auto& o = observations[points[p].observations[k]];
          std::cerr << fmt::format(
              "armsig triangulate: point {}: ray from station {} ({}:{}) is "
              "a blunder (w = {:.1f}), rejected\n",
              points[p].id, o.station, options.observations, o.source_line,
              std::max(std::abs(r.rays[k].w_hz), std::abs(r.rays[k].w_v)));
        }
      }
      if (r.blunder_suspected) {
        std::cerr << "armsig triangulate: point " << points[p].id
                  << ": a ray fails the blunder test but too few rays remain to reject it\n";
      }
    } else {
      std::cerr << "armsig triangulate: point " << points[p].id << " not intersected: " << r.reason
                << "\n";
    }
  }
  io::WriteFileAtomically(options.out, io::FormatPointsCsv(points));
  std::cout << fmt::format("{} points intersected, {} not, {} rays rejected as blunders -> {}\n",
                           ok, points.size() - ok, rejected, options.out);
  return kOk;
}

void SetupOrientCommand(CLI::App& parent, const GlobalOptions&, Runner& run) {
  auto o = std::make_shared<OrientOptions>();
  auto* sub = parent.add_subcommand("orient", "Orient the stations (bundle adjustment)");
  sub->add_option("--observations", o->observations, "Angle observations CSV")->required();
  sub->add_option("--scale-bar", o->scale_bars, "A:B=LEN_MM, repeatable");
  sub->add_option("--scale-bar-sigma-mm", o->scale_bar_sigma_mm, "Sigma of every scale-bar length")
      ->capture_default_str();
  sub->add_option("--control", o->control, "Control points CSV: point,x_mm,y_mm,z_mm[,sx_mm,...]");
  sub->add_option("--unlevelled", o->unlevelled, "Stations whose rotation is free (not levelled)");
  sub->add_option("--datum-station", o->datum_station,
                  "Station at the origin (default: the first)");
  sub->add_flag("--free-datum", o->free_datum,
                "Free network: precisions by inner constraints (minimum trace) over all points");
  sub->add_option("--datum-points", o->datum_points,
                  "Free network over these points and stations only (implies --free-datum)")
      ->delimiter(',');
  sub->add_option("--out", o->out, "Stations YAML to write")->required();
  sub->add_option("--points", o->points_out, "Also write the adjusted target points (CSV)");
  sub->add_flag("--no-instrument-errors", o->no_instrument_errors,
                "Do not estimate and apply axis errors from two-face readings");
  sub->callback([&run, o] { run = [o] { return RunOrient(*o); }; });
}

void SetupTriangulateCommand(CLI::App& parent, const GlobalOptions&, Runner& run) {
  auto o = std::make_shared<TriangulateOptions>();
  auto* sub = parent.add_subcommand("triangulate", "Intersect the rays of every target point");
  sub->add_option("--stations", o->stations, "Stations YAML")->required();
  sub->add_option("--observations", o->observations, "Angle observations CSV")->required();
  sub->add_option("--out", o->out, "Points CSV to write")->required();
  sub->add_flag("--no-reject", o->no_reject, "Report blunders but keep every ray");
  sub->add_flag("--no-instrument-errors", o->no_instrument_errors,
                "Do not estimate and apply axis errors from two-face readings");
  sub->add_option("--critical-w", o->critical_w, "Critical standardised residual")
      ->capture_default_str();
  sub->callback([&run, o] { run = [o] { return RunTriangulate(*o); }; });
}

}  // namespace armsig::app
