#include "core/wording.h"
#include "workflows/orient_triangulate.h"

#include <limits>
#include <fmt/format.h>
#include <nlohmann/json.hpp>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <cmath>
#include <set>
#include <stdexcept>

#include "calibration/statistics.h"
#include "core/error.h"
#include "core/text.h"
#include "core/units.h"
#include "io/atomic_file.h"
#include "io/csv.h"
#include "reduction/intersection.h"

namespace armsig::workflows {

std::vector<reduction::Station> OrientedStations(const reduction::OrientationProblem& problem,
                                                 const reduction::OrientationResult& result) {
  const std::set<std::string> stations(problem.station_ids.begin(), problem.station_ids.end());
  bool mutual = false, distances = false;
  for (const auto& o : problem.observations) {
    mutual |= stations.count(o.point) > 0;
    distances |= o.distance_mm.has_value();
  }
  std::vector<std::string> parts;
  if (mutual) parts.push_back("mutual");
  if (!problem.scale_bars.empty()) parts.push_back("scale_bar");
  if (!problem.control.empty()) parts.push_back("control");
  if (distances) parts.push_back("distances");
  if (problem.free_datum) parts.push_back("free_datum");
  std::string method;
  for (const auto& p : parts) method += (method.empty() ? "" : "+") + p;
  std::vector<reduction::Station> out = result.stations;
  for (auto& s : out) {
    s.orientation_sigma0 = result.sigma0;
    s.orientation_dof = result.dof;
    s.orientation_method = method.empty() ? std::string("orient") : method;
  }
  return out;
}

namespace {

constexpr double kGlobalTestAlpha = 0.05;
constexpr double kSuspectSigma0 = 5.0;  // the default gate: warned about when it is lifted

using Kind = reduction::ResidualReport::Kind;

bool IsAngle(Kind kind) { return kind == Kind::kHz || kind == Kind::kV; }

std::string Describe(const reduction::ResidualReport& r) {
  const bool angle = IsAngle(r.kind);
  return fmt::format("{:<10} {:<16} v {:>9.3f}{}  w {:>6.2f}  r {:.2f}  MDB {:.3f}{}",
                     reduction::KindName(r.kind), r.label, r.residual, angle ? "\"" : " mm", r.w,
                     r.redundancy, r.mdb, angle ? "\"" : " mm");
}

// "Hz 1->202 (obs.csv:4)": a reading with its file and line, a scale bar or control point.
std::string Named(Kind kind, const std::string& label, int observation, const OrientRun& run) {
  std::string text = std::string(reduction::KindName(kind)) + " " + label;
  if (kind != Kind::kScaleBar && kind != Kind::kControl && observation >= 0 &&
      observation < static_cast<int>(run.lines.size()) && run.lines[observation] > 0)
    text += fmt::format(" ({}:{})", run.observations, run.lines[observation]);
  return text;
}

// The observations --keep names: "STATION->POINT" (every reading of that sighting), "A:B"
// (a scale bar, either way round) or a control point's id.
reduction::KeptObservations KeptFrom(const std::vector<std::string>& keep,
                                     const reduction::OrientationProblem& problem,
                                     const std::string& observations) {
  reduction::KeptObservations kept;
  for (const std::string& what : keep) {
    bool found = false;
    if (const size_t arrow = what.find("->"); arrow != std::string::npos) {
      const std::string station = what.substr(0, arrow), point = what.substr(arrow + 2);
      for (size_t k = 0; k < problem.observations.size(); ++k) {
        if (problem.observations[k].station == station && problem.observations[k].point == point) {
          kept.observations.insert(static_cast<int>(k));
          found = true;
        }
      }
    } else if (const size_t colon = what.find(':'); colon != std::string::npos) {
      const std::string a = what.substr(0, colon), b = what.substr(colon + 1);
      for (size_t k = 0; k < problem.scale_bars.size(); ++k) {
        const auto& bar = problem.scale_bars[k];
        if ((bar.from == a && bar.to == b) || (bar.from == b && bar.to == a)) {
          kept.scale_bars.insert(static_cast<int>(k));
          found = true;
        }
      }
    } else {
      for (size_t k = 0; k < problem.control.size(); ++k) {
        if (problem.control[k].id == what) {
          kept.control.insert(static_cast<int>(k));
          found = true;
        }
      }
    }
    if (!found) {
      throw InputError({"--keep", 0, 0, ""},
                       "--keep " + Quoted(what) + ": no such sighting in " + observations +
                           ", scale bar or control point (expected STATION->POINT, A:B or a "
                           "control point's id" +
                           (!what.empty() && what.back() == '-'
                                ? std::string("; quote it, --keep 'S->P': the shell takes an "
                                              "unquoted > for a redirection")
                                : std::string()) +
                           ")");
    }
  }
  return kept;
}

// The snooping gate: observations that fail the test and stay (said, not removed) would
// distort the stations; nothing is written and they are named.
std::string UndecidedGate(const OrientRun& run) {
  std::string named;
  for (const auto& u : run.result.undecided) {
    if (u.why == reduction::Undecided::kRejectionOff) continue;
    named += "\n  - " + Named(u.observation.kind, u.observation.label, u.observation.observation, run) +
             fmt::format(" w {:.2f}: {}", u.observation.w, reduction::Explain(u.why));
    if (!u.twins.empty()) {
      std::string twins;
      for (const auto& t : u.twins)
        twins += (twins.empty() ? "" : ", ") + Named(t.kind, t.label, t.observation, run);
      named += " (cannot be told from " + twins + ")";
    }
  }
  if (named.empty()) return {};
  return "observations fail the blunder test and could not be removed:" + named +
         "\nCheck them: correct or remove them (or the scale bar), or --keep those that are "
         "right; nothing was written";
}

// "data snooping: alpha 0.1 % for the adjustment, 359 tests at 2.8e-06 (critical |w| 4.69),
// beta0 80 % (delta0 5.53), 2 adjustments".
std::string SnoopingSummary(const OrientRun& run) {
  const auto& r = run.result;
  const reduction::DataSnooping defaults;
  return fmt::format(
      "data snooping{}: alpha {:g} % for the adjustment, {} tests at {:.2g} each (critical |w| "
      "{:.2f}), beta0 {:g} % (delta0 {:.2f}), {} adjustment{}",
      run.reject ? "" : " (test only, --no-reject)",
      run.alpha * 100.0, r.levels.tests, r.levels.alpha0, r.levels.critical_w,
      defaults.beta0 * 100.0, r.levels.delta0, r.adjustments, r.adjustments == 1 ? "" : "s");
}

// One removed observation: "Hz 1->202 (obs.csv:4) w -63.85 r 0.25, error +328.6\"".
std::string RemovedLine(const reduction::RemovedObservation& m, const OrientRun& run) {
  std::string text = Named(m.kind, m.label, m.observation, run) +
                     fmt::format(" w {:.2f} r {:.2f}, error {:+.{}f}{}", m.w, m.redundancy, m.error,
                                 IsAngle(m.kind) ? 1 : 3, IsAngle(m.kind) ? "\"" : " mm");
  if (m.round == 0) text += " [a mistake: set aside at the robust start, its test from the rest]";
  if (!m.twins.empty()) {
    std::string twins;
    for (const auto& t : m.twins) twins += (twins.empty() ? "" : ", ") + t;
    text += " [with " + twins + ": the data cannot tell which of them is wrong]";
  }
  return text;
}

// The stations file's header lines on data snooping.
std::string SnoopingHeader(const OrientRun& run) {
  std::string text = "\n" + SnoopingSummary(run);
  if (run.result.removed.empty()) return text + "; nothing removed";
  text += fmt::format("; {} removed (error = observed - adjusted):", run.result.removed.size());
  for (const auto& m : run.result.removed) text += "\n  " + RemovedLine(m, run);
  return text;
}

// The result with its station sigmas and point covariances scaled (a posteriori).
reduction::OrientationResult Scaled(reduction::OrientationResult result, double scale) {
  for (auto& st : result.stations) {
    st.sigma_position_mm *= scale;
    st.sigma_azimuth_rad *= scale;
    st.sigma_rotation_rad *= scale;
  }
  for (auto& p : result.points) p.covariance_mm2 *= scale * scale;
  return result;
}

// Two instruments on tripods cannot stand closer than this (their heads alone are larger).
constexpr double kMinStationSpacingMm = 200.0;

// A network whose scale puts two instruments closer than they can stand was scaled by a
// length in the wrong unit (a 1 m bar typed as 1, for millimetres): refused, naming the
// scale's source.
void CheckStationSpacing(const reduction::OrientationResult& result,
                         const OrientFilesOptions& options) {
  double closest = std::numeric_limits<double>::infinity();
  std::string a, b;
  for (size_t i = 0; i < result.stations.size(); ++i) {
    for (size_t j = i + 1; j < result.stations.size(); ++j) {
      const double d =
          (result.stations[i].pose.position_mm - result.stations[j].pose.position_mm).norm();
      if (d < closest) closest = d, a = result.stations[i].pose.id, b = result.stations[j].pose.id;
    }
  }
  if (!(closest < kMinStationSpacingMm)) return;
  std::string scale = "the control points (--control, mm)";
  if (!options.scale_bars.empty()) {
    scale = "the scale bar" + std::string(options.scale_bars.size() > 1 ? "s " : " ");
    for (size_t k = 0; k < options.scale_bars.size(); ++k)
      scale += (k ? ", " : "") + options.scale_bars[k];
    scale += " (--scale-bar A:B=LEN_MM takes millimetres: a 1 m bar is =1000)";
  }
  throw InputError({"--scale-bar", 0, 0, ""},
                   fmt::format("the network's scale puts stations {} and {} {:.3g} mm apart, "
                               "closer than two instruments can stand ({:g} mm): a length in "
                               "the wrong unit? The scale comes from {}; nothing was written",
                               Quoted(a), Quoted(b), closest, kMinStationSpacingMm, scale));
}

}  // namespace

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
      throw InputError({"--datum-station", 0, 0, ""}, "station " + Quoted(options.datum_station) +
                                                          " has no observations in " +
                                                          options.observations);
    }
  }
  for (const auto& id : options.unlevelled) {
    if (!seen.count(id)) {
      throw InputError({"--unlevelled", 0, 0, ""}, "unknown station " + Quoted(id));
    }
    problem.unlevelled.insert(id);
  }
  problem.free_datum = options.free_datum || !options.datum_points.empty();
  problem.datum_points.insert(options.datum_points.begin(), options.datum_points.end());
  reduction::OrientationOptions adjustment;
  adjustment.snooping.reject = options.reject;
  adjustment.snooping.alpha = options.alpha;
  adjustment.keep = KeptFrom(options.keep, problem, options.observations);
  run.observations = options.observations;
  run.alpha = options.alpha;
  run.reject = options.reject;
  for (const auto& o : problem.observations) run.lines.push_back(o.source_line);
  run.result = reduction::Orient(problem, adjustment);
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
  const auto& result = run.result;
  if (result.status.ok()) CheckStationSpacing(result, options);
  spdlog::debug("orient: {} stations, {} points, {} observations, {} unknowns, sigma0 {:.4f}, {} "
                "iterations ({})",
                result.stations.size(), result.points.size(), result.observations,
                result.unknowns, result.sigma0, result.iterations, result.datum);
  if (!result.status.ok()) {
    spdlog::error("orient: the adjustment did not converge ({}): nothing was written",
                  result.status.message);
    return run;
  }
  // The global test of the adjustment; a failed one scales the sigmas it writes.
  if (result.dof > 0) {
    run.global_test_p =
        calibration::ChiSquareSurvival(result.sigma0 * result.sigma0 * result.dof, result.dof);
    if (run.global_test_p < kGlobalTestAlpha && result.sigma0 > 1.0)
      run.sigma_scale = result.sigma0;
  }
  auto write_json = [&] {
    if (!options.json_out.empty())
      io::WriteFileAtomically(options.json_out, FormatOrientJson(run));
  };
  run.gate_failure = UndecidedGate(run);
  if (run.gate_failure.empty() && options.max_sigma0 > 0.0 && result.dof > 0 &&
      result.sigma0 > options.max_sigma0) {
    std::vector<reduction::ResidualReport> worst = result.residuals;
    std::sort(worst.begin(), worst.end(),
              [](const auto& a, const auto& b) { return std::abs(a.w) > std::abs(b.w); });
    std::string suspects;
    for (size_t k = 0; k < std::min<size_t>(3, worst.size()); ++k)
      suspects += "\n  - " + Describe(worst[k]);
    run.gate_failure = fmt::format(
        "sigma0 a posteriori {:.2f} is more than {:g} times the a priori sigmas of the readings "
        "({} degrees of freedom): a blunder in {}, or sigmas that are not the instruments'. The "
        "largest standardised residuals:{}\nCorrect or remove the observation and orient "
        "again (or give --max-sigma0 to accept); nothing was written",
        result.sigma0, options.max_sigma0, result.dof, options.observations, suspects);
  }
  write_json();
  if (!run.gate_failure.empty()) {
    spdlog::debug("orient: {}", run.gate_failure);
    return run;
  }
  if (result.sigma0 > kSuspectSigma0) {
    spdlog::warn("orient: sigma0 {:.2f}: the readings scatter {:.0f} times more than their a "
                 "priori sigmas (a blunder, or sigmas that are not the instruments'); the "
                 "stations are written as asked (--max-sigma0 {:g})",
                 result.sigma0, result.sigma0, options.max_sigma0);
  }
  const reduction::OrientationResult scaled = Scaled(result, run.sigma_scale);
  // Both files are written in full before either is put in place: a full disk leaves
  // neither, not a stations file without its points.
  std::vector<io::PreparedFile> outputs;
  if (!options.out.empty()) {
    std::string header = fmt::format(
        "armsig orient: {} from {}; datum: {}\nsigma0 {:.5f}, {}",
        Count(static_cast<int64_t>(result.stations.size()), "station"),
        Printable(options.observations), result.datum, result.sigma0,
        Count(result.dof, "degree of freedom", "degrees of freedom"));
    if (run.sigma_scale != 1.0) {
      header += fmt::format(
          "\nglobal test failed (p = {:.2g}): sigmas a posteriori (a priori x {:.4f})",
          run.global_test_p, run.sigma_scale);
    }
    header += SnoopingHeader(run);
    outputs.emplace_back(options.out, io::FormatStationsYaml(OrientedStations(problem, scaled),
                                                             header, result.removed));
  }
  if (!options.points_out.empty())
    outputs.emplace_back(options.points_out, FormatAdjustedPointsCsv(scaled.points));
  for (auto& output : outputs) output.Commit();
  return run;
}

std::string FormatInstrumentErrors(
    const std::map<std::string, reduction::InstrumentErrors>& errors) {
  std::string text;
  for (const auto& [station, e] : errors) {
    text += fmt::format(
        "station {}: {} two-face pairs: collimation {:.2f}\" ± {:.2f}, trunnion {}, vertical index "
        "{:.2f}\" ± {:.2f} (applied to all its readings)\n",
        station, e.pairs, e.collimation_rad / kRadPerArcsec,
        e.sigma_collimation_rad / kRadPerArcsec,
        e.trunnion_determined ? fmt::format("{:.2f}\" ± {:.2f}", e.trunnion_rad / kRadPerArcsec,
                                            e.sigma_trunnion_rad / kRadPerArcsec)
                              : std::string("not determinable (zenith angles too alike)"),
        e.index_rad / kRadPerArcsec, e.sigma_index_rad / kRadPerArcsec);
  }
  return text;
}

std::string FormatOrientReport(const OrientRun& run) {
  const reduction::OrientationResult& result = run.result;
  std::string text = FormatInstrumentErrors(run.instrument_errors);
  text += fmt::format("Orientation of {}, {} ({})\n",
                      Count(static_cast<int64_t>(result.stations.size()), "station"),
                      Count(static_cast<int64_t>(result.points.size()), "target point"),
                      result.datum);
  text += fmt::format(
      "sigma0 a posteriori {:.4f} (a priori 1), {}, {}, {}, {}{}\n", result.sigma0,
      Count(result.observations, "observation"), Count(result.unknowns, "unknown"),
      Count(result.dof, "degree of freedom", "degrees of freedom"),
      Count(result.iterations, "iteration"),
      result.status.ok() ? "" : " (NOT converged: " + result.status.message + ")");
  if (result.dof > 0) {
    text += fmt::format("global test: P(chi2 > {:.1f}) = {:.3g}{}\n", result.sigma0 * result.sigma0 * result.dof,
                        run.global_test_p,
                        run.sigma_scale != 1.0
                            ? fmt::format(": failed, sigmas a posteriori (a priori x {:.4f})",
                                          run.sigma_scale)
                            : std::string(": passed"));
  }
  text += "\n";
  const reduction::OrientationResult scaled = Scaled(result, run.sigma_scale);
  text += fmt::format("{:<10}{:>14}{:>14}{:>14}{:>16}{:>10}{:>10}{:>10}{:>12}\n", "station", "x_mm",
                      "y_mm", "z_mm", "azimuth_gon", "sx_mm", "sy_mm", "sz_mm", "s_az_\"");
  for (const auto& s : scaled.stations) {
    text += fmt::format(
        "{:<10}{:>14.4f}{:>14.4f}{:>14.4f}{:>16}{:>10.4f}{:>10.4f}{:>10.4f}{:>12.3f}\n", s.pose.id,
        s.pose.position_mm.x(), s.pose.position_mm.y(), s.pose.position_mm.z(),
        s.pose.levelled ? fmt::format("{:.6f}", FromRad(s.pose.azimuth_rad, AngleUnit::kGon))
                        : std::string("(rotation)"),
        s.sigma_position_mm.x(), s.sigma_position_mm.y(), s.sigma_position_mm.z(),
        s.sigma_azimuth_rad / kRadPerArcsec);
  }
  text += "\nvariance components (one step: sigma0 of each group = sqrt(sum v^2 / sum r))\n";
  for (const auto& g : result.groups) {
    // A group without redundancy (a scale bar the network cannot check) has no σ0.
    text += fmt::format("  {:<18} {:>5} observations  redundancy {:>8.2f}  sigma0 {}\n", g.group,
                        g.count, g.redundancy,
                        g.redundancy > 1e-6 ? fmt::format("{:.4f}", g.sigma0)
                                            : std::string("- (no redundancy)"));
  }
  text += "\n" + SnoopingSummary(run) + "\n";
  if (!result.removed.empty()) {
    text += fmt::format("removed as blunders ({}; error = observed - adjusted):\n",
                        result.removed.size());
    for (const auto& m : result.removed) text += "  " + RemovedLine(m, run) + "\n";
  }
  for (const auto& u : result.undecided) {
    if (u.why == reduction::Undecided::kRejectionOff) continue;
    text += "NOT removed: " +
            Named(u.observation.kind, u.observation.label, u.observation.observation, run) +
            fmt::format(" w {:.2f} r {:.2f}: {}", u.observation.w, u.observation.redundancy,
                        reduction::Explain(u.why));
    std::string twins;
    for (const auto& t : u.twins)
      twins += (twins.empty() ? "" : ", ") + Named(t.kind, t.label, t.observation, run);
    text += twins.empty() ? "\n" : " (cannot be told from " + twins + ")\n";
  }
  if (result.removal_limit_reached)
    text += "snooping stopped at its limit on removals (5 % of the observations)\n";
  std::vector<reduction::ResidualReport> worst = result.residuals;
  std::sort(worst.begin(), worst.end(),
            [](const auto& a, const auto& b) { return std::abs(a.w) > std::abs(b.w); });
  const double critical = result.levels.critical_w;
  text += fmt::format("\nlargest standardised residuals (|w| > {:.2f} is a suspected blunder):\n",
                      critical);
  for (size_t k = 0; k < std::min<size_t>(8, worst.size()); ++k) {
    text +=
        "  " + Describe(worst[k]) + (std::abs(worst[k].w) > critical ? "  BLUNDER?" : "") + "\n";
  }
  for (const auto& [id, why] : result.excluded_points)
    text += "point " + id + " not adjusted: " + why + "\n";
  return text;
}

std::string FormatOrientJson(const OrientRun& run) {
  using nlohmann::json;
  const reduction::OrientationResult& r = run.result;
  const reduction::OrientationResult scaled = Scaled(r, run.sigma_scale);
  auto vec = [](const Eigen::Vector3d& v) { return json::array({v.x(), v.y(), v.z()}); };
  auto finite = [](double x) { return std::isfinite(x) ? json(x) : json(nullptr); };
  json stations = json::array();
  for (const auto& s : scaled.stations) {
    json j = {{"id", s.pose.id}, {"position_mm", vec(s.pose.position_mm)},
              {"sigma_position_mm", vec(s.sigma_position_mm)}};
    if (s.pose.levelled) {
      j["azimuth_rad"] = s.pose.azimuth_rad;
      j["sigma_azimuth_rad"] = s.sigma_azimuth_rad;
    } else {
      json rows = json::array();
      for (int i = 0; i < 3; ++i) rows.push_back(vec(s.pose.world_from_station.row(i).transpose()));
      j["rotation"] = rows;
      j["sigma_rotation_rad"] = vec(s.sigma_rotation_rad);
    }
    stations.push_back(j);
  }
  auto line_of = [&](Kind kind, int observation) -> json {
    if (kind == Kind::kScaleBar || kind == Kind::kControl || observation < 0 ||
        observation >= static_cast<int>(run.lines.size()) || run.lines[observation] <= 0)
      return nullptr;
    return run.lines[observation];
  };
  json removed = json::array();
  for (const auto& m : r.removed) {
    json j = {{"station", m.station.empty() ? json(nullptr) : json(m.station)},
              {"point", m.point},
              {"kind", io::KindKey(m.kind)},
              {"line", line_of(m.kind, m.observation)},
              {"w", finite(m.w)},
              {"redundancy", finite(m.redundancy)},
              {"adjustment", m.round},
              {"twins", m.twins}};
    if (IsAngle(m.kind))
      j["error_rad"] = finite(m.error * kRadPerArcsec);
    else
      j["error_mm"] = finite(m.error);
    removed.push_back(j);
  }
  json undecided = json::array();
  for (const auto& u : r.undecided) {
    json twins = json::array();
    for (const auto& t : u.twins) twins.push_back(std::string(reduction::KindName(t.kind)) + " " + t.label);
    undecided.push_back({{"kind", io::KindKey(u.observation.kind)},
                         {"label", u.observation.label},
                         {"line", line_of(u.observation.kind, u.observation.observation)},
                         {"w", finite(u.observation.w)},
                         {"redundancy", finite(u.observation.redundancy)},
                         {"why", reduction::Explain(u.why)},
                         {"twins", twins}});
  }
  const json doc = {
      {"sigma0", r.sigma0},
      {"dof", r.dof},
      {"observations", r.observations},
      {"unknowns", r.unknowns},
      {"global_test_p", run.global_test_p},
      {"sigma_scale", run.sigma_scale},
      {"datum", r.datum},
      {"stations", stations},
      {"snooping",
       {{"reject", run.reject},
        {"alpha", run.alpha},
        {"beta0", reduction::DataSnooping{}.beta0},
        {"tests", r.levels.tests},
        {"alpha0", r.levels.alpha0},
        {"critical_w", r.levels.critical_w},
        {"delta0", r.levels.delta0},
        {"adjustments", r.adjustments},
        {"removed", removed},
        {"undecided", undecided},
        {"removal_limit_reached", r.removal_limit_reached}}},
      {"gate_failure", run.gate_failure.empty() ? json(nullptr) : json(run.gate_failure)}};
  return JsonText(doc, 2) + "\n";
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
      throw InputError({options.observations, o.source_line, o.source_station_column, "station"},
                       "station " + Quoted(o.station) + " is not in " + options.stations +
                           " (expected one of its stations)");
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
  point_options.intersection.snooping.reject = options.reject_blunders;
  point_options.intersection.snooping.critical_w = options.critical_w;
  reduction::ReducedPoint reduced;
  for (size_t p = 0; p < run.points.size(); ++p) {
    reduction::IntersectPoint(groups[p], point_options, reduced);
    run.points[p].result = std::move(reduced.result);
    if (run.points[p].result.status.ok()) {
      ++run.intersected;
      run.rejected_rays += run.points[p].result.rejected;
    }
  }
  for (const auto& point : run.points) {
    const auto& r = point.result;
    spdlog::trace("triangulate: point {}: {} rays, {} ({})", point.id, r.rays.size(),
                  r.status.ok() ? "intersected" : "not intersected", reduction::ToString(r.flags));
    if (!r.status.ok()) {
      spdlog::warn("triangulate: point {} not intersected: {} ({})", point.id, r.status.message,
                   reduction::ToString(r.flags));
      continue;
    }
    for (size_t k = 0; k < r.rays.size(); ++k) {
      if (!r.rays[k].rejected) continue;
      const auto& o = run.observations[point.observations[k]];
      spdlog::warn(
          "triangulate: point {}: ray from station {} ({}:{}) is a blunder (w = {:.1f}), rejected",
          point.id, o.station, options.observations, o.source_line,
          std::max(std::abs(r.rays[k].w_hz), std::abs(r.rays[k].w_v)));
    }
    if (r.flags.Has(reduction::PointFlag::kBlunderSuspected)) {
      spdlog::warn(
          "triangulate: point {}: a ray fails the blunder test but too few rays remain to reject "
          "it ({})",
          point.id, reduction::ToString(reduction::PointFlag::kBlunderSuspected));
    }
  }
  if (!options.out.empty()) io::WriteFileAtomically(options.out, io::FormatPointsCsv(run.points));
  return run;
}

std::string FormatTriangulateSummary(const TriangulateRun& run, const std::string& out) {
  return FormatInstrumentErrors(run.instrument_errors) +
         fmt::format("{} intersected, {} not, {} rejected as blunders -> {}\n",
                     Count(run.intersected, "point"), run.points.size() - run.intersected,
                     Count(run.rejected_rays, "ray"), Printable(out));
}

}  // namespace armsig::workflows
