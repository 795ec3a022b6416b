#include "report/report_page.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <set>
#include <tuple>

#include "calibration/statistics.h"
#include "core/wording.h"

namespace armsig::report {

using namespace figures;  // Num, Now, FigureHtml, kPageStyle (report/figures.h)

ReportData::ReportData(const ReportInput& input) : in(input), model(*input.model), run(*input.run) {
  const auto& residuals = run.validation_residuals;
  distances = calibration::Distances(residuals);
  std::map<std::string, const MeasuredPose*> by_id;
  for (const auto& p : in.validation) by_id[p.id] = &p;
  for (size_t i = 0; i < residuals.size(); ++i) {
    const MeasuredPose* pose = nullptr;
    if (i < run.validation_pose_ids.size()) {
      const auto it = by_id.find(run.validation_pose_ids[i]);
      if (it != by_id.end()) pose = it->second;
    }
    poses.push_back(pose);
  }
  stats = ResidualStatistics(residuals);
  for (size_t i = 0; i < residuals.size() && i < run.validation_pose_ids.size(); ++i) {
    const auto it = in.temperature_c.find(run.validation_pose_ids[i]);
    if (it == in.temperature_c.end() || !std::isfinite(it->second)) continue;
    temperatures.push_back(it->second);
    temperature_errors.push_back(distances[i]);
  }
  trend_refusal = TemperatureTrendRefusal(temperatures);
  if (trend_refusal.empty()) trend = LinearTrendOf(temperatures, temperature_errors);
}

std::string ReportSetMarker(const std::string& robot, int version) {
  if (version <= 0) return "";
  return HtmlFormat("<meta name=\"armsig-set\" content=\"{} {}\">\n", robot, version).str();
}

ReportBanner BannerOf(const ReportInput& in) {
  double moved_mm = 0.0;  // the largest effect at the tool of a session that disagreed
  for (const auto& w : in.window)
    if (w.disagrees) moved_mm = std::max(moved_mm, w.effect_max_mm);
  const std::string moved =
      moved_mm > 0.0 ? fmt::format("the robot moved by up to {:.3f} mm at the tool", moved_mm)
                     : std::string("the robot changed");
  std::string validated;
  if (in.run && !in.run->validation_residuals.empty()) {
    const auto v = workflows::StatsOf(in.run->validation_residuals);
    validated = fmt::format("validation mean {:.3f} mm, max {:.3f} mm on {} configurations",
                            v.mean_mm, v.max_mm, in.run->validation_residuals.size());
  }
  if (in.version > 0 && in.drift)
    return {"DRIFT", "warn", fmt::format("{}; version {} follows it ({})", moved, in.version,
                                         validated.empty() ? "stored" : validated)};
  if (in.version > 0)
    return {"PASS", "good", fmt::format("version {}: {}", in.version,
                                        validated.empty() ? "stored" : validated)};
  if (!in.run)
    return {"DRIFT SUSPECTED", "bad",
            fmt::format("{}; nothing stored, version {} stays active", moved,
                        in.previous_version ? std::to_string(*in.previous_version) : "none")};
  for (const auto& g : in.gates)
    if (g.ends_with("FAILED")) return {"REJECTED", "bad", g + "; nothing stored"};
  return {"REJECTED", "bad", in.decision};
}

Html PageStart(const ReportInput& in) {
  Html html = HtmlFormat(
      "<!doctype html>\n<html><head><meta charset=\"utf-8\"><title>armsig report: {}</title>\n"
      "{}<style>{}</style>\n</head><body>\n",
      in.robot, Html::Trusted(ReportSetMarker(in.robot, in.version)), Html::Trusted(kPageStyle));
  html += HtmlFormat("<h1>Recalibration of {}</h1>\n", in.robot);
  // One glance first: the word and the figure that matter, never green on a drift night.
  const ReportBanner banner = BannerOf(in);
  html += HtmlFormat("<p class=\"banner {}\" id=\"banner\"><b>{}</b> &mdash; {}</p>\n",
                     Html::Text(banner.css_class), banner.word, banner.figure);
  html += HtmlFormat("<p class=\"{}\"><b>{}</b></p>\n", Html::Text(banner.css_class), in.decision);

  return html;
}

Html HeaderSection(const ReportData& data) {
  const ReportInput& in = data.in;
  const auto& run = data.run;
  const auto& model = data.model;
  const auto names = model.ParameterNames();
  Html html;
  const auto& id = run.estimate.identifiability;
  auto row = [&](const Html& label, const Html& id_name, const Html& value, bool nowrap = false) {
    html += HtmlFormat("<tr><th>{}</th><td id=\"{}\"{}>{}</td></tr>\n", label, id_name,
                       nowrap ? Html(" class=\"nowrap\"") : Html(), value);
  };
  html += "<table class=\"header\">\n";
  row("Date", "generated-at", Html::Text(in.generated_at.empty() ? Now() : in.generated_at), true);
  row("armsig version", "armsig-version",
      in.armsig_version.empty() ? Html("not known") : Html::Text(in.armsig_version), true);
  row("Robot", "robot",
      HtmlFormat("{} (model {}, {} joints)", in.robot, model.name, model.num_joints()));
  row("Parameter set", "params",
      HtmlFormat("{}; {} poses fitted, {} validated", ParamsInWords(run.params_spec),
                 run.fit_pose_ids.size(), run.validation_pose_ids.size()));
  Html sessions;
  for (const auto& s : in.sources.sessions) {
    sessions += HtmlFormat(
        "<div>session {}: {} &ndash; {} ({}), {} fitted + {} validation poses{}</div>", s.id,
        s.started_at, s.finished_at.empty() ? std::string("not finished") : s.finished_at, s.state,
        s.poses_fit, s.poses_validation, s.note.empty() ? Html() : Html(", ") + Html::Text(s.note));
  }
  row("Sessions used", "sessions", sessions.empty() ? Html("not known") : sessions);
  Html instruments;
  for (const auto& i : in.sources.instruments) {
    std::string used;
    for (int64_t s : i.sessions) used += (used.empty() ? "" : ", ") + std::to_string(s);
    instruments += HtmlFormat("<div>{}: {}{}</div>", i.name, i.description,
                              used.empty() ? std::string() : " (session " + used + ")");
  }
  row("Instruments", "instruments",
      instruments.empty() ? Html("none recorded with these sessions") : instruments);
  Html sigma0;
  for (const auto& g : Sigma0Groups(in.sources.setups)) {
    std::string sessions, stations;
    for (int64_t s : g.sessions) sessions += (sessions.empty() ? "" : ", ") + std::to_string(s);
    for (const auto& s : g.stations) stations += (stations.empty() ? "" : ", ") + s;
    sigma0 +=
        HtmlFormat("<div>{} {}, {} {}: {}</div>", g.sessions.size() == 1 ? "session" : "sessions",
                   sessions, g.stations.size() == 1 ? "station" : "stations", stations,
                   g.sigma0 ? HtmlFormat("&sigma;<sub>0</sub> = {:.3f} ({} dof{})", *g.sigma0,
                                         g.dof, g.method.empty() ? std::string() : ", " + g.method)
                            : Html("&sigma;<sub>0</sub> not stored"));
  }
  row("Orientation &sigma;<sub>0</sub>", "sigma0",
      sigma0.empty() ? Html("not stored (no station set-ups with these sessions)") : sigma0);
  row("Rank", "rank",
      HtmlFormat("{} of {} candidate parameters{}", id.rank, id.candidates.size(),
                 id.structural_rank >= 0 ? fmt::format(" (structural rank {})", id.structural_rank)
                                         : std::string()),
      true);
  row("Condition number", "condition-number", HtmlFormat("{:.4g}", id.condition_number), true);
  std::string unidentified;
  for (int k : id.unidentified) unidentified += (unidentified.empty() ? "" : ", ") + names[k];
  row("Not identifiable (kept nominal)", "not-identifiable",
      unidentified.empty() ? Html("none") : Html::Text(unidentified));
  html += "</table>\n<ul>\n";
  for (const auto& g : in.gates) html += HtmlFormat("<li>{}</li>\n", g);
  html += "</ul>\n";
  return html;
}

namespace {

// Where the set holds: the joint arcs its terms were fitted on (outside, each term keeps its
// value at the edge), and the σ a prediction carries there and beside, with the coverage
// measured on held-out data.
Html ValiditySection(const calibration::SetValidity& v) {
  const auto Percent = [](double share) {
    return std::isfinite(share) ? fmt::format("{:.0f} %", 100.0 * share) : std::string("n/a");
  };
  constexpr double kDeg = 180.0 / 3.14159265358979323846;
  Html html = HtmlFormat(
      "<h2>Where the set holds</h2>\n<p id=\"validity\">Its non-geometric terms are used only "
      "inside the joint ranges of its fit poses; beyond them each keeps its value at the range's "
      "edge (predict and compensate name such configurations). A prediction's σ per coordinate "
      "is the parameters' own and what held-out data show the model leaves: {} mm among the fit "
      "poses ({} of held-out poses within {} σ), {} mm beside them ({}; {} within).</p>\n",
      Num(v.sigma_inside_mm), Percent(v.coverage_inside), fmt::format("{:.2f}", calibration::kCoverageRadius),
      Num(v.sigma_outside_mm), v.outside_folds.empty() ? std::string("not measured") : v.outside_folds,
      Percent(v.coverage_outside));
  html += "<table id=\"term-arcs\"><tr><th>joint</th><th class=\"num\">from, deg</th><th "
          "class=\"num\">to, deg</th></tr>\n";
  for (size_t j = 0; j < v.term_arcs.size(); ++j) {
    const auto& a = v.term_arcs[j];
    if (a.whole_turn()) {
      html += HtmlFormat("<tr><td>{}</td><td colspan=\"2\">the whole turn</td></tr>\n", j + 1);
    } else {
      html += HtmlFormat("<tr><td>{}</td><td class=\"num\">{}</td><td class=\"num\">{}</td></tr>\n",
                         j + 1, fmt::format("{:.1f}", a.start_rad * kDeg),
                         fmt::format("{:.1f}", (a.start_rad + a.length_rad) * kDeg));
    }
  }
  html += "</table>\n";
  return html;
}

}  // namespace

Html ErrorSection(const ReportData& data, const std::optional<Figure>& map_figure) {
  const auto& run = data.run;
  const auto& residuals = run.validation_residuals;
  const size_t n = residuals.size();
  const auto& stats = data.stats;
  Html html;
  const auto v = workflows::StatsOf(residuals);
  const auto vn = workflows::StatsOf(run.validation_nominal_residuals);
  html +=
      "<h2>Error distances</h2>\n<table><tr><th>error distance (mm)</th><th "
      "class=\"num\">poses</th><th class=\"num\">mean</th><th class=\"num\">max</th><th "
      "class=\"num\">rms</th></tr>\n";
  auto line = [&](const char* label, const calibration::ErrorStats& s) {
    html += HtmlFormat(
        "<tr><td>{}</td><td class=\"num\">{}</td><td class=\"num\">{}</td><td "
        "class=\"num\">{}</td><td class=\"num\">{}</td></tr>\n",
        label, s.poses, Num(s.mean_mm), Num(s.max_mm), Num(s.rms_mm));
  };
  line("nominal, fit", run.estimate.nominal);
  line("calibrated, fit", run.estimate.fit);
  line("nominal, validation", vn);
  if (run.map_used() && !run.validation_parametric_residuals.empty()) {
    line("parametric, validation (before the map)", workflows::StatsOf(run.validation_parametric_residuals));
    line("with the residual map, validation", v);
  } else {
    line("calibrated, validation", v);
  }
  html += "</table>\n";
  if (run.residual_map) {
    const auto& m = *run.residual_map;
    // The decision says the cross-validation's figures itself.
    html += HtmlFormat("<h2>Residual map</h2>\n<p id=\"residual-map\">{}: {}.",
                       m.used ? "Used" : "Not used", m.decision);
    if (m.used && !m.map.curves.empty()) {
      html += HtmlFormat(" Joint curves: {} knots per turn, smoothing {}.", m.map.curves.knots,
                         fmt::format("{:g}", m.map.curves.smoothing));
    }
    if (m.used && !m.map.centres_rad.empty()) {
      html += HtmlFormat(" Kernel: length scale {}, regularisation {}, {} centres, noise σ {} mm.",
                         fmt::format("{:g}", m.map.length_scale),
                         fmt::format("{:g}", m.map.regularisation), m.map.centres_rad.size(),
                         Num(m.map.noise_sigma_mm));
    }
    if (const auto v = run.map_validation(); run.map_used() && v.poses > 0) {
      html += HtmlFormat(
          " On the validation poses: predictive σ {} mm per coordinate on average; {} of {} "
          "outside the map's support (far from the fit poses, or a joint at an angle its curve had "
          "no data for: only what has data there applies).",
          Num(v.mean_sigma_mm), v.outside, v.poses);
    }
    html += "</p>\n";
    if (map_figure) html += FigureHtml(*map_figure);
  }
  if (run.validity && !run.validity->empty()) html += ValiditySection(*run.validity);
  html += HtmlFormat(
      "<h2>Validation error per axis</h2>\n<p>Calibrated model &minus; measured on the {} "
      "validation poses, mm. Percentiles (nearest rank) of the absolute values.</p>\n"
      "<table id=\"axis-statistics\"><tr><th></th><th class=\"num\">mean</th><th "
      "class=\"num\">std dev</th><th class=\"num\">rms</th><th class=\"num\">max "
      "|&middot;|</th><th class=\"num\">50 %</th><th class=\"num\">95 %</th><th "
      "class=\"num\">99 %</th></tr>\n",
      n);
  for (const auto& s : stats) {
    auto cell = [&](const char* field, double value) {
      return HtmlFormat("<td class=\"num\" id=\"stat-{}-{}\">{}</td>", s.name, field, Num(value));
    };
    html += HtmlFormat("<tr><th>{}</th>", s.name) + cell("mean", s.mean_mm) +
            cell("std", s.std_mm) + cell("rms", s.rms_mm) + cell("max", s.max_abs_mm) +
            cell("p50", s.p50_mm) + cell("p95", s.p95_mm) + cell("p99", s.p99_mm) + "</tr>\n";
  }
  html += "</table>\n";
  return html;
}

Html WorstPosesSection(const ReportData& data) {
  const auto& run = data.run;
  const auto& residuals = run.validation_residuals;
  // With the residual map: whether each pose lay inside its support (the map applied) or
  // outside (the parametric prediction), and the map's predictive σ there.
  const bool map = run.validation_map_extrapolated.size() == residuals.size() &&
                   run.validation_map_sigma_mm.size() == residuals.size() && !residuals.empty();
  Html html;
  html +=
      "<h2>The ten worst validation poses</h2>\n<table id=\"worst\"><tr><th "
      "class=\"num\">#</th><th>pose</th><th class=\"num\">distance</th><th "
      "class=\"num\">dX</th><th class=\"num\">dY</th><th class=\"num\">dZ</th><th "
      "class=\"num\">joints (deg)</th>";
  if (map) html += "<th>residual map</th><th class=\"num\">map σ</th>";
  html += "</tr>\n";
  int rank = 0;
  for (int i : WorstResiduals(residuals, 10)) {
    const auto* pose = (static_cast<size_t>(i) < data.poses.size() ? data.poses[i] : nullptr);
    std::string joints;
    if (pose) {
      for (int j = 0; j < pose->joints_rad.size(); ++j)
        joints += fmt::format("{}{:.1f}", j ? ", " : "", pose->joints_rad(j) * kDegPerRad);
    }
    html += HtmlFormat(
        "<tr><td class=\"num\">{}</td><td class=\"pose\">{}</td><td class=\"num\">{}</td><td "
        "class=\"num\">{}</td><td class=\"num\">{}</td><td class=\"num\">{}</td><td "
        "class=\"num\">{}</td>",
        ++rank,
        static_cast<size_t>(i) < run.validation_pose_ids.size() ? run.validation_pose_ids[i]
                                                                : std::to_string(i + 1),
        Num(residuals[i].norm()), Num(residuals[i].x()), Num(residuals[i].y()),
        Num(residuals[i].z()), joints.empty() ? Html("&mdash;") : Html::Text(joints));
    if (map) {
      const bool outside = run.validation_map_extrapolated[i] != 0;
      html += HtmlFormat("<td class=\"map\">{}</td><td class=\"num\">{}</td>",
                         outside ? "outside its support" : "applied",
                         outside ? Html("&mdash;") : Num(run.validation_map_sigma_mm[i]));
    }
    html += "</tr>\n";
  }
  html += "</table>\n";
  return html;
}

Html TemperatureSection(const ReportData& data, const std::optional<Figure>& figure) {
  Html html("<h2>Error against temperature</h2>\n");
  const auto& t = data.temperatures;
  if (t.empty()) {
    return html + Html(
                      "<p id=\"temperature-trend\">No validation pose has an air temperature "
                      "(laser trackers store it with every reading; theodolites and imported "
                      "poses do not).</p>\n");
  }
  const auto [lo, hi] = std::minmax_element(t.begin(), t.end());
  Html slope;
  if (!data.trend) {
    slope = HtmlFormat("no slope of the error against it: {}.", data.trend_refusal);
  } else {
    const LinearTrend& trend = *data.trend;
    // The slope to the decimal its sigma's two significant digits reach.
    const int decimals = DecimalsForSigma(trend.sigma_slope, 4);
    slope = HtmlFormat(
        "least-squares slope of the error distance: <span id=\"temperature-slope\">{:+.{}f}</span> "
        "&plusmn; <span id=\"temperature-slope-sigma\">{}</span> mm per &deg;C (<span "
        "id=\"temperature-slope-p\">{}</span>: {}).",
        trend.slope, decimals, Significant(trend.sigma_slope, 2), PValueText(trend.p_value),
        trend.p_value < 0.01 ? Html("<b>significant</b>: the error changes with the temperature")
                             : Html("not significant at 1 %"));
  }
  html += HtmlFormat(
      "<p id=\"temperature-trend\">{} of {} validation poses have an air temperature, {:.3f} "
      "to {:.3f} &deg;C; {}</p>\n",
      t.size(), data.distances.size(), *lo, *hi, slope);
  if (figure) html += FigureHtml(*figure);
  return html;
}

std::vector<Sigma0Group> Sigma0Groups(const std::vector<ReportStationSetup>& setups) {
  // Per session, its stations grouped by equal figures (σ0 to the digits shown).
  auto key_of = [](const ReportStationSetup& s) {
    return std::make_tuple(s.sigma0 ? fmt::format("{:.3f}", *s.sigma0) : std::string("-"), s.dof,
                           s.method);
  };
  using Key = decltype(key_of(setups.front()));
  std::vector<int64_t> session_order;
  std::map<int64_t, std::vector<std::pair<Key, Sigma0Group>>> per_session;
  for (const auto& s : setups) {
    auto& groups = per_session[s.session_id];
    if (groups.empty()) session_order.push_back(s.session_id);
    const Key key = key_of(s);
    auto it =
        std::find_if(groups.begin(), groups.end(), [&](const auto& g) { return g.first == key; });
    if (it == groups.end()) {
      groups.push_back({key, Sigma0Group{{s.session_id}, {}, s.sigma0, s.dof, s.method}});
      it = std::prev(groups.end());
    }
    it->second.stations.push_back(s.station);
  }
  // Sessions whose groups are all alike (the same stations with the same figures): one line.
  std::vector<Sigma0Group> out;
  std::vector<std::vector<std::pair<Key, std::vector<std::string>>>> signatures;
  std::vector<std::vector<size_t>> members;  // indices into `out` of each signature's groups
  for (int64_t session : session_order) {
    std::vector<std::pair<Key, std::vector<std::string>>> signature;
    for (const auto& [key, group] : per_session[session])
      signature.push_back({key, group.stations});
    const auto same = std::find(signatures.begin(), signatures.end(), signature);
    if (same != signatures.end()) {
      for (size_t index : members[same - signatures.begin()])
        out[index].sessions.push_back(session);
      continue;
    }
    signatures.push_back(signature);
    members.emplace_back();
    for (const auto& [key, group] : per_session[session]) {
      members.back().push_back(out.size());
      out.push_back(group);
    }
  }
  return out;
}

namespace {

// "0.14130 &plusmn; 0.00042": the sigma to two significant digits, the value to the same
// decimal (at least three).
Html ValueAndSigma(double value, double sigma) {
  const int decimals = DecimalsForSigma(sigma, 3);
  return HtmlFormat("{:.{}f} &plusmn; {}",
                    std::abs(value) < 0.5 * std::pow(10.0, -decimals) ? 0.0 : value, decimals,
                    Significant(sigma, 2));
}

}  // namespace

Html ParameterSection(const ReportData& data) {
  const auto& run = data.run;
  const auto& model = data.model;
  const auto names = model.ParameterNames();
  const int joints = model.num_joints();
  std::vector<char> identified(model.num_parameters(), 0);
  for (int k : run.estimate.identifiability.identified) identified[k] = 1;
  Html html =
      "<h2>Parameters (paper's Table 1-3 layout; value &plusmn; sigma)</h2>\n"
      "<table id=\"parameters\"><tr><th>i =</th>";
  for (int i = 1; i <= joints + 1; ++i) html += HtmlFormat("<th class=\"num\">{}</th>", i);
  html += "</tr>\n";
  const Html rows[6] = {"a (mm)",
                        "b (mm)",
                        "c (mm)",
                        "&alpha; (1e-3 rad)",
                        "&beta; (1e-3 rad)",
                        "&gamma; (1e-3 rad)"};
  for (int r = 0; r < 6; ++r) {
    html += HtmlFormat("<tr><th>{}</th>", rows[r]);
    for (int i = 0; i <= joints; ++i) {
      // Links 1…n carry six parameters each; the tool (the last column) its three lengths
      // and, with a known mounting, the flange's turn α β.
      const int k = model.GeometricIndex(i, r);
      if (k < 0) {
        html += "<td></td>";
        continue;
      }
      const double scale = r < 3 ? 1.0 : 1e3;
      html += identified[k] ? HtmlFormat("<td class=\"num\" id=\"param-{}\">{}</td>", names[k],
                                         ValueAndSigma(run.estimate.params(k) * scale,
                                                       run.estimate.sigmas(k) * scale))
                            : Html("<td class=\"num\">&mdash;</td>");
    }
    html += "</tr>\n";
  }
  html += HtmlFormat(
      "</table>\n<p class=\"note\">&mdash;: not identifiable from these data (kept nominal); "
      "i = {}: the tool, lengths only{}.</p>\n",
      joints + 1,
      model.known_mounting()
          ? Html(" (held at zero: the mounting is known), and the flange's turn &alpha; &beta;")
          : Html(""));
  for (int k = model.num_geometric(); k < model.num_parameters(); ++k) {
    html +=
        identified[k]
            ? HtmlFormat("<p id=\"param-{}\">{} = {} &times; 10<sup>-3</sup> rad</p>\n", names[k],
                         names[k],
                         ValueAndSigma(run.estimate.params(k) * 1e3, run.estimate.sigmas(k) * 1e3))
            : HtmlFormat("<p>{}: not identified</p>\n", names[k]);
  }
  return html;
}

Html ChangeSection(const ReportData& data) {
  const ReportInput& in = data.in;
  const auto& run = data.run;
  const auto& model = data.model;
  const auto names = model.ParameterNames();
  Html html;
  html += HtmlFormat("<h2>Change against the previous version{}</h2>\n",
                     in.drift ? Html(" <span class=\"bad\">(drift)</span>") : Html());
  std::vector<calibration::ParameterChange> rows;
  for (const auto& c : in.changes) {
    if (c.z != 0.0 && std::isfinite(c.z)) rows.push_back(c);
  }
  Html why;
  if (!in.previous_version) {
    why = HtmlFormat(
        "No previous version: this is the first parameter set of {}, so there is nothing to "
        "compare against.",
        in.robot);
  } else if (!in.previous_params_spec.empty() && in.previous_params_spec != run.params_spec) {
    why = HtmlFormat(
        "Version {} was fitted with --params {}, this run with --params {}: the two sets "
        "estimate different parameter subsets, {}.",
        *in.previous_version, in.previous_params_spec, run.params_spec,
        rows.empty() ? "so their parameters are not compared"
                     : "so only the parameters identified in both are compared");
  } else if (rows.empty()) {
    why = HtmlFormat(
        "Version {} and this run share no parameter identified with a sigma in both, so no "
        "parameter is compared.",
        *in.previous_version);
  }
  if (!in.changes_note.empty()) {
    why += (why.empty() ? Html() : Html(" ")) + Html::Text(in.changes_note);
  }
  if (!why.empty()) html += HtmlFormat("<p class=\"note\" id=\"change-note\">{}</p>\n", why);
  if (!rows.empty()) {
    html += HtmlFormat(
        "<table id=\"changes\"><tr><th>parameter</th><th class=\"num\">change since version "
        "{}</th><th class=\"num\">in sigmas</th></tr>\n",
        *in.previous_version);
    for (const auto& c : rows) {
      const bool mm = model.UnitOf(c.parameter) == calibration::ParameterUnit::kMm;
      html += HtmlFormat(
          "<tr><td>{}</td><td class=\"num\">{}</td><td class=\"num{}\">{:.1f}</td></tr>\n",
          names[c.parameter], FormatChange(c.change, mm), std::abs(c.z) > 5 ? Html(" bad") : Html(),
          c.z);
    }
    html += "</table>\n";
  }
  return html;
}

Html WindowSection(const ReportInput& in) {
  if (in.window.empty() && in.drift_line.empty()) return Html();
  Html html("<h2>The sessions against the active set</h2>\n");
  if (!in.drift_line.empty())
    html += HtmlFormat("<p class=\"bad\" id=\"drift-line\">{}</p>\n", in.drift_line);
  if (!in.causes.empty()) {
    html +=
        Html("<p>Physical causes, each fitted alone against the change:</p>\n<ol id=\"causes\">\n");
    for (const auto& c : in.causes) html += HtmlFormat("<li>{}</li>\n", c);
    html += Html("</ol>\n");
  }
  if (in.window.empty()) return html;
  html += HtmlFormat(
      "<table id=\"window\"><tr><th class=\"num\">session</th><th>started</th><th "
      "class=\"num\">configurations</th><th class=\"num\">mean error under version {} "
      "(mm)</th><th class=\"num\">change up to (mm)</th><th class=\"num\">p</th><th>verdict</th>"
      "</tr>\n",
      in.previous_version.value_or(0));
  for (const auto& w : in.window) {
    // "p < 0.001", "p > 0.99", "0.034": the p-value as a reader acts on it.
    std::string p = PValueText(w.p_value);
    if (p.rfind("p = ", 0) == 0) p = p.substr(4);
    html += HtmlFormat(
        "<tr><td class=\"num\">{}</td><td>{}</td><td class=\"num\">{}</td><td "
        "class=\"num\">{:.4f}</td><td class=\"num\">{:.3f}</td><td class=\"num\">{}</td>"
        "<td{}>{}</td></tr>\n",
        w.session, w.started_at, w.poses, w.mean_mm, w.effect_max_mm, p,
        w.disagrees ? Html(" class=\"bad\"") : Html(),
        w.outlier     ? "disagrees (an outlier: left out)"
        : w.disagrees ? "disagrees"
                      : "agrees");
  }
  return html + Html("</table>\n");
}

namespace {

// The numbers the drift figure is drawn from, a row per version compared.
Html DriftTable(const ReportDrift& drift) {
  Html html = HtmlFormat(
      "<table id=\"drift-points\"><tr><th class=\"num\">version</th><th class=\"num\">against "
      "version</th><th class=\"num\">largest difference (mm)</th><th class=\"num\">its sigma "
      "(mm)</th><th class=\"num\">mean difference (mm)</th><th>drift</th></tr>\n");
  for (const auto& d : drift.points) {
    const std::string v = d.version > 0 ? std::to_string(d.version) : "this-run";
    html += HtmlFormat(
        "<tr><td class=\"num\">{}</td><td class=\"num\">{}</td><td class=\"num\" "
        "id=\"drift-{}-max\">{}</td><td class=\"num\" id=\"drift-{}-sigma\">{}</td><td "
        "class=\"num\" id=\"drift-{}-mean\">{}</td><td>{}</td></tr>\n",
        d.version > 0 ? std::to_string(d.version) : std::string("this run"), d.against, v,
        Num(d.max_mm), v, Html::Text(Significant(d.sigma_max_mm, 2)), v, Num(d.mean_mm),
        d.drift ? Html("<span class=\"bad\">DRIFT</span>") : Html());
  }
  return html + Html("</table>\n");
}

}  // namespace

Html HistorySection(const ReportInput& in, const std::optional<Figure>& drift_figure) {
  Html html("<h2>Drift against earlier versions</h2>\n");
  const ReportDrift& drift = in.drift_history;
  if (drift_figure) {
    html += HtmlFormat(
        "<p id=\"drift-explained\">Drift is how far a new parameter set moves the arm: the "
        "positions it predicts against those of the set before it, over {} configurations "
        "spread over the work volume, the two rigidly aligned (the measuring frame is not the "
        "robot's). Each point is the largest difference, its bar &plusmn;2&sigma; from both "
        "fits' uncertainty; drift is flagged only beyond that uncertainty and the tolerance "
        "of <span id=\"drift-tolerance\">{}</span> mm.</p>\n",
        drift.configurations, Num(drift.tolerance_mm, 3));
    html += FigureHtml(*drift_figure) + DriftTable(drift);
  } else {
    html += Html(
        "<p id=\"drift-explained\">No earlier parameter set to compare with: drift needs two "
        "versions.</p>\n");
  }
  if (in.history.empty()) return html;
  html +=
      "<table id=\"versions\"><tr><th class=\"num\">version</th><th>stored</th><th>params</th>"
      "<th class=\"num\">validation mean (mm)</th><th>drift</th><th>made active</th>"
      "<th>active</th></tr>\n";
  for (const auto& h : in.history) {
    Html activations;
    for (const auto& a : h.activations) {
      activations += HtmlFormat("{}<span class=\"nowrap\">{} by {}</span>",
                                activations.empty() ? Html() : Html("<br>"), a.at, a.by);
    }
    html += HtmlFormat(
        "<tr><td class=\"num\">{}</td><td class=\"num\">{}</td><td>{}</td><td "
        "class=\"num\">{}</td><td class=\"drift\">{}</td><td class=\"activated\">{}</td>"
        "<td>{}</td></tr>\n",
        h.version > 0 ? std::to_string(h.version) : std::string("this run"), h.created_at,
        h.params_spec.empty() ? std::string("not known") : h.params_spec, Num(h.validation_mean_mm),
        h.drift ? Html("<span class=\"bad\">DRIFT</span>") : Html(), activations,
        h.active ? "active" : "");
  }
  return html + Html("</table>\n");
}

std::string FormatChange(double value, bool millimetres) {
  // Three significant digits in mm / mrad from 0.01 up, else in µm / µrad (never "-0.0000").
  const double magnitude = std::abs(value) * (millimetres ? 1.0 : 1e3);  // mm or mrad
  const bool small = magnitude < 0.01;
  const double shown = (millimetres ? value : value * 1e3) * (small ? 1e3 : 1.0);
  const char* unit = millimetres ? (small ? "µm" : "mm") : (small ? "µrad" : "mrad");
  const double a = std::abs(shown);
  if (!(a > 0.0)) return fmt::format("0 {}", unit);
  if (!std::isfinite(a)) return fmt::format("{} {}", shown, unit);
  const int decimals = std::clamp(2 - static_cast<int>(std::floor(std::log10(a))), 0, 6);
  const std::string text = fmt::format("{:.{}f}", shown, decimals);
  // A value that rounds to zero at six decimals is shown as zero, without a sign.
  return (text.find_first_not_of("-0.") == std::string::npos ? fmt::format("{:.{}f}", 0.0, decimals)
                                                             : text) +
         " " + unit;
}

std::string ParamsKind(const std::string& spec) {
  if (spec == "all" || spec == "geometric" || spec == "auto") return spec;
  return spec.empty() ? "unknown" : "list";
}

std::string ParamsInWords(const std::string& spec) {
  const std::string kind = ParamsKind(spec);
  if (kind == "all") return "every term of the model";
  if (kind == "geometric") return "the geometric parameters";
  if (kind == "auto") {
    return "the geometric parameters and the terms that held on data the fit did not see";
  }
  if (kind == "unknown") return "not known";
  std::string words;
  for (size_t at = 0; at <= spec.size();) {
    const size_t comma = std::min(spec.find(',', at), spec.size());
    words += (words.empty() ? "" : ", ") + spec.substr(at, comma - at);
    at = comma + 1;
  }
  return "the parameters " + words;
}

}  // namespace armsig::report
