// armsig orient: station set-up by bundle adjustment.
// armsig triangulate: intersection of every target point from oriented stations.
#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <iostream>
#include <map>
#include <set>

#include "app/command.h"
#include "core/error.h"
#include "core/plausibility.h"
#include "core/units.h"
#include "io/atomic_file.h"
#include "io/csv.h"
#include "io/network_io.h"
#include "reduction/instrument_errors.h"
#include "reduction/intersection.h"
#include "reduction/orientation.h"
#include "workflows/network.h"

namespace armsig::app {

struct OrientOptions {
  workflows::OrientFilesOptions files;
  std::string out, points_out;
  bool no_instrument_errors = false;
};

struct TriangulateOptions {
  workflows::TriangulateFilesOptions files;
  std::string out;
  bool no_reject = false, no_instrument_errors = false;
};

namespace {

void PrintInstrumentErrors(const std::map<std::string, reduction::InstrumentErrors>& errors) {
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

int RunOrient(OrientOptions options) {
  options.files.instrument_errors = !options.no_instrument_errors;
  const auto run = workflows::OrientFiles(options.files);
  PrintInstrumentErrors(run.instrument_errors);
  const reduction::OrientationResult& result = run.result;
  std::cout << fmt::format("Orientation of {} stations, {} target points ({})\n",
                           result.stations.size(), result.points.size(), result.datum);
  std::cout << fmt::format(
      "sigma0 a posteriori {:.4f} (a priori 1), {} observations, {} unknowns, "
      "{} degrees of freedom, {} iterations{}\n\n",
      result.sigma0, result.observations, result.unknowns, result.dof, result.iterations,
      result.status.ok() ? "" : " (NOT converged: " + result.status.message + ")");
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
      result.stations.size(), options.files.observations, result.datum, result.sigma0, result.dof);
  io::WriteFileAtomically(options.out, io::FormatStationsYaml(result.stations, header));
  if (!options.points_out.empty()) {
    io::WriteFileAtomically(options.points_out, workflows::FormatAdjustedPointsCsv(result.points));
  }
  return result.status.ok() ? kOk : kFailure;
}

int RunTriangulate(TriangulateOptions options) {
  options.files.reject_blunders = !options.no_reject;
  options.files.instrument_errors = !options.no_instrument_errors;
  const auto run = workflows::TriangulateFiles(options.files);
  PrintInstrumentErrors(run.instrument_errors);
  const auto& points = run.points;
  const auto& observations = run.observations;
  for (size_t p = 0; p < points.size(); ++p) {
    const auto& r = points[p].result;
    if (r.status.ok()) {
      for (size_t k = 0; k < r.rays.size(); ++k) {
        if (r.rays[k].rejected) {
          const auto& o = observations[points[p].observations[k]];
          spdlog::warn(
              "triangulate: point {}: ray from station {} ({}:{}) is a blunder (w = {:.1f}), "
              "rejected",
              points[p].id, o.station, options.files.observations, o.source_line,
              std::max(std::abs(r.rays[k].w_hz), std::abs(r.rays[k].w_v)));
        }
      }
      if (r.flags.Has(reduction::PointFlag::kBlunderSuspected)) {
        spdlog::warn(
            "triangulate: point {}: a ray fails the blunder test but too few rays remain to "
            "reject it ({})",
            points[p].id, reduction::ToString(reduction::PointFlag::kBlunderSuspected));
      }
    } else {
      spdlog::warn("triangulate: point {} not intersected: {} ({})", points[p].id, r.status.message,
                   reduction::ToString(r.flags));
    }
  }
  io::WriteFileAtomically(options.out, io::FormatPointsCsv(points));
  std::cout << fmt::format("{} points intersected, {} not, {} rays rejected as blunders -> {}\n",
                           run.intersected, points.size() - run.intersected, run.rejected_rays,
                           options.out);
  return kOk;
}

void SetupOrientCommand(CLI::App& parent, const GlobalOptions&, Runner& run) {
  auto o = std::make_shared<OrientOptions>();
  auto* sub = parent.add_subcommand("orient", "Orient the stations (bundle adjustment)");
  sub->add_option("--observations", o->files.observations, "Angle observations CSV")->required();
  sub->add_option("--scale-bar", o->files.scale_bars, "A:B=LEN_MM, repeatable");
  sub->add_option("--scale-bar-sigma-mm", o->files.scale_bar_sigma_mm,
                  "Sigma of every scale-bar length")
      ->check(CLI::Range(1e-9, plausible::kMaxSigmaMm))  // a sigma: > 0, finite
      ->capture_default_str();
  sub->add_option("--control", o->files.control,
                  "Control points CSV: point,x_mm,y_mm,z_mm[,sx_mm,...]");
  sub->add_option("--unlevelled", o->files.unlevelled,
                  "Stations whose rotation is free (not levelled)");
  sub->add_option("--datum-station", o->files.datum_station,
                  "Station at the origin (default: the first)");
  sub->add_flag("--free-datum", o->files.free_datum,
                "Free network: precisions by inner constraints (minimum trace) over all points");
  sub->add_option("--datum-points", o->files.datum_points,
                  "Free network over these points and stations only (implies --free-datum)")
      ->delimiter(',');
  OutputFile(sub->add_option("--out", o->out, "Stations YAML to write"))->required();
  OutputFile(
      sub->add_option("--points", o->points_out, "Also write the adjusted target points (CSV)"));
  sub->add_flag("--no-instrument-errors", o->no_instrument_errors,
                "Do not estimate and apply axis errors from two-face readings");
  sub->callback([&run, o] { run = [o] { return RunOrient(*o); }; });
}

void SetupTriangulateCommand(CLI::App& parent, const GlobalOptions&, Runner& run) {
  auto o = std::make_shared<TriangulateOptions>();
  auto* sub = parent.add_subcommand("triangulate", "Intersect the rays of every target point");
  sub->add_option("--stations", o->files.stations, "Stations YAML")->required();
  sub->add_option("--observations", o->files.observations, "Angle observations CSV")->required();
  OutputFile(sub->add_option("--out", o->out, "Points CSV to write"))->required();
  sub->add_flag("--no-reject", o->no_reject, "Report blunders but keep every ray");
  sub->add_flag("--no-instrument-errors", o->no_instrument_errors,
                "Do not estimate and apply axis errors from two-face readings");
  sub->add_option("--critical-w", o->files.critical_w, "Critical standardised residual")
      ->capture_default_str();
  sub->callback([&run, o] { run = [o] { return RunTriangulate(*o); }; });
}

}  // namespace armsig::app
