#include "iso9283/iso9283_path_report.h"

#include <fmt/format.h>

#include <algorithm>
#include <charconv>
#include <cmath>
#include <filesystem>
#include <map>
#include <opencv2/imgproc.hpp>

#include "acquisition/on_the_move.h"
#include "calibration/iso9283_figures.h"
#include "core/error.h"
#include "core/units.h"
#include "db/observations.h"
#include "db/report_queries.h"
#include "db/sessions.h"
#include "db/streams.h"
#include "instruments/emscon_codec.h"
#include "io/atomic_file.h"
#include "iso9283/iso9283_report.h"
#include "report/figures.h"
#include "report/html.h"

namespace armsig::iso9283 {

namespace iso = calibration::iso9283;

std::optional<Iso9283PathLabel> ParseIso9283PathLabel(const std::string& label) {
  // <path>-<cycle>-v<vertex>
  const size_t v = label.rfind("-v");
  if (v == std::string::npos || v == 0) return std::nullopt;
  const size_t dash = label.rfind('-', v - 1);
  if (dash == std::string::npos || dash == 0) return std::nullopt;
  Iso9283PathLabel out;
  out.path = label.substr(0, dash);
  const auto number = [](std::string_view text, int& value) {
    const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), value);
    return ec == std::errc() && end == text.data() + text.size() && value >= 1;
  };
  if (!number(std::string_view(label).substr(dash + 1, v - dash - 1), out.cycle) ||
      !number(std::string_view(label).substr(v + 2), out.vertex))
    return std::nullopt;
  return out;
}

bool IsIso9283PathSession(db::Database& db, int64_t session) {
  const auto row = db::LoadSession(db, session);
  if (!row || row->plan_json.empty()) return false;
  return acquisition::HasLinearMoves(
      acquisition::PlanFromJson(row->plan_json, {db.path(), "sessions", session, "plan_json"}));
}

iso::PathOptions DefaultIso9283PathOptions() {
  iso::PathOptions o;
  o.speed_stride = 25;
  return o;
}

namespace {

// A path of the plan: its commanded vertices (the first cycle's targets), speed, and the
// stored segments of each cycle.
struct PlannedPath {
  std::string name;
  std::vector<Eigen::Vector3d> vertices;
  double speed_mm_s = 0.0;
  std::map<int, std::vector<int>> segments;  // cycle → its segments
};

std::vector<PlannedPath> PathsOfPlan(const acquisition::Plan& plan, int64_t session,
                                     const std::string& db_path) {
  std::vector<PlannedPath> out;
  for (const acquisition::SweepSpan& span : acquisition::PathSegments(plan)) {
    const auto label = ParseIso9283PathLabel(plan[span.first].label);
    if (!label) continue;  // a segment of something else
    auto it = std::find_if(out.begin(), out.end(),
                           [&](const PlannedPath& p) { return p.name == label->path; });
    if (it == out.end()) {
      out.push_back({label->path, {}, 0.0, {}});
      it = out.end() - 1;
    }
    std::vector<Eigen::Vector3d> vertices;
    for (size_t k = span.first; k <= span.last; ++k) {
      if (!plan[k].target_mm) {
        throw InputError({db_path, 0, 0, "--session"},
                         fmt::format("session {}: path configuration {} keeps no target (a path "
                                     "plan from `iso9283 plan --path` has x_mm, y_mm, z_mm)",
                                     session, plan[k].label));
      }
      if (!plan[k].via || k == span.first || k + 1 > span.last || !plan[k + 1].target_mm) {
        vertices.push_back(*plan[k].target_mm);
        continue;
      }
      // A circular move: the commanded arc as chords of 1° (inside the arc by r (1 − cos
      // 0.5°), 0.005 mm for the large circle of a 300 mm cube).
      const auto arc = iso::ArcThrough(vertices.back(), *plan[k].target_mm, *plan[k + 1].target_mm);
      if (!arc) {
        throw InputError({db_path, 0, 0, "--session"},
                         fmt::format("session {}: the circular move through {} lies on one line",
                                     session, plan[k].label));
      }
      for (const auto& v : iso::ArcPolyline(*arc, kRadPerDeg)) vertices.push_back(v);
      ++k;  // the target: the arc's last chord ends there
    }
    std::vector<int>& segments = it->segments[label->cycle];
    if (segments.empty() && it->segments.size() == 1) {  // the path's first cycle
      it->vertices = vertices;
      it->speed_mm_s = plan[span.last].linear_speed_mm_s.value_or(0.0);
    } else if (segments.empty()) {
      const bool same = vertices.size() == it->vertices.size() &&
                        std::equal(vertices.begin(), vertices.end(), it->vertices.begin(),
                                   [](const auto& a, const auto& b) { return (a - b).norm() < 1e-6; });
      if (!same) {
        throw InputError({db_path, 0, 0, "--session"},
                         fmt::format("session {}: cycle {} of path {} commands other vertices "
                                     "than its first cycle",
                                     session, label->cycle, label->path));
      }
    }
    segments.push_back(span.index);
  }
  return out;
}

// The robot's frame: the active signature located on the session's paired configurations
// (at most 2,000 of them, evenly), else the lab file's base.
Iso9283Frame PathFrameOf(db::Database& db, const db::SessionRow& row, int64_t session,
                         const calibration::RobotModel& model,
                         const workflows::ActiveSignature* signature) {
  const std::vector<MeasuredPose> poses = db::LoadSessionPoses(db, session);
  if (signature && poses.size() < 3) {
    // Its records are paired with the joints once the last segment is stored: a stopped test
    // has none yet, and the lab file's base is no stand-in for the signature's.
    throw InputError({db.path(), 0, 0, "--session"},
                     fmt::format("session {} has no paired configurations yet to locate the robot "
                                 "with arm signature version {} (it stopped before its last "
                                 "segment): resume it with capture --resume {}",
                                 session, signature->signature.version, session));
  }
  if (signature) {
    size_t used = 0;
    if (auto frame = SignatureFrame(model, *signature, poses, 2000, &used)) {
      frame->detail = fmt::format(
          "the robot's base located by arm signature version {} on {} of the session's {} "
          "paired configurations (rms {:.4f} mm of its positions against them)",
          signature->signature.version, used, poses.size(), frame->fit->rms_mm);
      return *frame;
    }
  }
  if (auto frame = LabBaseFrame(row.lab_yaml, session, db.path())) return *frame;
  throw InputError(
      {db.path(), 0, 0, "--session"},
      fmt::format("session {}: the robot's frame is not known (no arm signature located on paired "
                  "configurations, and the lab file gives no robot: base:): calibrate the robot "
                  "or measure its base",
                  session));
}

}  // namespace

Iso9283PathEvaluation EvaluateIso9283PathSession(db::Database& db, int64_t session,
                                                 const calibration::RobotModel& model,
                                                 const workflows::ActiveSignature* signature,
                                                 const iso::PathOptions& options) {
  const auto row = db::LoadSession(db, session);
  if (!row) throw InputError({db.path(), 0, 0, "--session"}, fmt::format("no session {}", session));
  Iso9283PathEvaluation e;
  e.session = session;
  for (const auto& s : db::LoadReportSessions(db, {session})) e.started_at = s.started_at;
  const acquisition::Plan plan =
      acquisition::PlanFromJson(row->plan_json, {db.path(), "sessions", session, "plan_json"});
  std::vector<PlannedPath> planned = PathsOfPlan(plan, session, db.path());
  if (planned.empty()) {
    throw InputError({db.path(), 0, 0, "--session"},
                     fmt::format("session {} holds no ISO 9283 path (labels line-01-v1 … as "
                                 "`iso9283 plan --path` writes them)",
                                 session));
  }
  e.frame = PathFrameOf(db, *row, session, model, signature);
  const auto stations = db::LatestStationSetups(db, session);
  const db::SessionStreams streams = db::LoadSessionStreams(db, session);
  std::map<int, std::vector<const db::StreamPointRow*>> by_segment;
  for (const auto& p : streams.points) by_segment[p.segment].push_back(&p);
  for (const PlannedPath& p : planned) {
    Iso9283PathTest test;
    test.name = p.name;
    test.command = {p.vertices, p.speed_mm_s};
    int missing = 0;
    for (const auto& [cycle, segments] : p.segments) {
      iso::AttainedCycle attained;
      for (int segment : segments) {
        const auto it = by_segment.find(segment);
        if (it == by_segment.end()) continue;
        for (const db::StreamPointRow* r : it->second) {
          const auto station = stations.find(r->station);
          if (station == stations.end()) continue;
          const Eigen::Vector3d world =
              station->second.pose.position_mm +
              station->second.pose.world_from_station *
                  instruments::emscon::PointFromSpherical({r->hz_rad, r->v_rad, r->distance_mm});
          attained.samples.push_back({r->t_s, e.frame.commanded_from_attained * world});
        }
      }
      std::stable_sort(attained.samples.begin(), attained.samples.end(),
                       [](const auto& a, const auto& b) { return a.t_s < b.t_s; });
      // Equal stamps (a record stored twice by a resumed segment) would stop the speed.
      attained.samples.erase(std::unique(attained.samples.begin(), attained.samples.end(),
                                         [](const auto& a, const auto& b) { return a.t_s == b.t_s; }),
                             attained.samples.end());
      if (attained.samples.size() < 2) {
        ++missing;
        continue;
      }
      e.records += static_cast<int>(attained.samples.size());
      test.cycles.push_back(std::move(attained));
    }
    if (missing > 0) {
      e.notes.push_back(fmt::format("path {}: {} of {} cycles have no stored records (the session "
                                    "was stopped before them; resume it)",
                                    p.name, missing, p.segments.size()));
    }
    if (test.cycles.empty()) {
      throw InputError({db.path(), 0, 0, "--session"},
                       fmt::format("session {}: path {} has no measured cycle", session, p.name));
    }
    test.figures = iso::EvaluatePath(test.command, test.cycles, options);
    e.paths.push_back(std::move(test));
  }
  return e;
}

namespace {

nlohmann::json PathNumber(double v) { return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(); }

}  // namespace

nlohmann::json Iso9283PathJson(const Iso9283PathEvaluation& e) {
  nlohmann::json paths = nlohmann::json::array();
  for (const auto& p : e.paths) {
    const iso::PathFigures& f = p.figures;
    nlohmann::json corners = nlohmann::json::array();
    for (const auto& c : f.corners) {
      corners.push_back({{"vertex", c.vertex + 1},
                         {"corner_mm", {c.corner_mm.x(), c.corner_mm.y(), c.corner_mm.z()}},
                         {"turn_deg", c.turn_rad / kRadPerDeg},
                         {"CR_mm", PathNumber(c.cr_max_mm)},
                         {"CO_mm", PathNumber(c.co_max_mm)}});
    }
    paths.push_back({{"path", p.name},
                     {"cycles", f.n},
                     {"speed_mm_s", p.command.speed_mm_s},
                     {"length_mm", f.length_mm},
                     {"AT_mm", PathNumber(f.at_mm)},
                     {"ATx_mm", PathNumber(f.at_xyz_mm.x())},
                     {"ATy_mm", PathNumber(f.at_xyz_mm.y())},
                     {"ATz_mm", PathNumber(f.at_xyz_mm.z())},
                     {"mean_AT_mm", PathNumber(f.mean_at_mm)},
                     {"RT_mm", PathNumber(f.rt_mm)},
                     {"planes", f.planes_used},
                     {"planes_skipped", f.planes_skipped},
                     {"missed_crossings", f.missed_crossings},
                     {"mean_speed_mm_s", PathNumber(f.mean_speed_mm_s)},
                     {"AV_percent", PathNumber(f.av_percent)},
                     {"RV_percent", PathNumber(f.rv_percent)},
                     {"FV_mm_s", PathNumber(f.fv_mm_s)},
                     {"corners", corners}});
  }
  nlohmann::json alignment = {{"method", e.frame.method}, {"detail", e.frame.detail}};
  if (e.frame.fit) alignment["rms_mm"] = e.frame.fit->rms_mm;
  return {{"session", e.session}, {"paths", paths},  {"records", e.records},
          {"alignment", alignment}, {"notes", e.notes}};
}

std::string FormatIso9283PathFigures(const Iso9283PathEvaluation& e) {
  std::string out = fmt::format("{:<12} {:>6} {:>8} {:>8} {:>9} {:>8} {:>8} {:>8} {:>8} {:>8}\n",
                                "path", "cycles", "v mm/s", "AT mm", "mean AT", "RT mm", "AV %",
                                "RV %", "FV mm/s", "planes");
  for (const auto& p : e.paths) {
    const iso::PathFigures& f = p.figures;
    out += fmt::format("{:<12} {:>6} {:>8.1f} {:>8.4f} {:>9.4f} {:>8.4f} {:>8.3f} {:>8.3f} {:>8.2f} {:>8}\n",
                       p.name, f.n, p.command.speed_mm_s, f.at_mm, f.mean_at_mm, f.rt_mm,
                       f.av_percent, f.rv_percent, f.fv_mm_s, f.planes_used);
    for (const auto& c : f.corners) {
      out += fmt::format("  corner {} ({:.0f} deg): CR {:.4f} mm, CO {:.4f} mm\n", c.vertex + 1,
                         c.turn_rad / kRadPerDeg, c.cr_max_mm, c.co_max_mm);
    }
  }
  out += "frame: " + e.frame.detail + "\n";
  for (const auto& n : e.notes) out += "note: " + n + "\n";
  return out;
}

namespace {

using report::Html;
using report::HtmlFormat;

// AT_pj along the path (every normal plane's barycentre from its commanded point), the test
// and, when there is one, the compensated test: where along the path the robot misses.
report::figures::Figure DeviationFigure(const std::string& dir, const std::string& path,
                                        const Iso9283PathTest& test,
                                        const Iso9283PathTest* compensated) {
  namespace fig = report::figures;
  double largest = 0.0;
  for (const auto* t : {&test, compensated}) {
    if (!t) continue;
    for (const auto& plane : t->figures.planes)
      if (std::isfinite(plane.at_mm)) largest = std::max(largest, plane.at_mm);
  }
  fig::Plot plot(720, 300, "|barycentre - commanded| per normal plane along the " + path + " path",
                 fig::LinearAxis(0.0, std::max(test.figures.length_mm, 1.0), 8),
                 fig::LinearAxis(0.0, std::max(largest * 1.1, 1e-3), 6), "path position s (mm)",
                 "mm");
  std::vector<fig::LegendEntry> legend = {{fig::Marker::kLine, fig::kRed, "nominal program"}};
  if (compensated) legend.push_back({fig::Marker::kLine, fig::kBlue, "compensated"});
  plot.Legend(legend);
  for (const auto* t : {&test, compensated}) {
    if (!t) continue;
    const cv::Scalar colour = t == &test ? fig::kRed : fig::kBlue;
    // Consecutive planes joined; none across a margin (planes farther apart than the spacing).
    std::optional<cv::Point> before;
    double before_s = 0.0;
    for (const auto& plane : t->figures.planes) {
      if (!std::isfinite(plane.at_mm)) {
        before.reset();
        continue;
      }
      const cv::Point at = plot.At(plane.s_mm, plane.at_mm);
      if (before && plane.s_mm - before_s <= 1.5 * t->figures.plane_spacing_mm)
        cv::line(plot.image, *before, at, colour, 1, cv::LINE_AA);
      before = at;
      before_s = plane.s_mm;
    }
  }
  plot.Note("Each plane: the barycentre of the cycles' crossings; gaps are the corners' and the "
            "ends' margins, where the standard's normal planes are not taken.");
  return fig::Save(dir, "deviation-" + path + ".png", "Path accuracy along the " + path + " path",
                   plot.image);
}

Html PathTable(const char* id, const Iso9283PathEvaluation& e) {
  using report::figures::Num;
  Html h = HtmlFormat(
      "<table id=\"{}\"><tr><th>path</th><th class=\"num\">cycles</th><th class=\"num\">v<sub>c</sub> "
      "mm/s</th><th class=\"num\">AT mm</th><th class=\"num\">mean AT mm</th><th "
      "class=\"num\">RT mm</th><th class=\"num\">AV %</th><th class=\"num\">RV %</th><th "
      "class=\"num\">FV mm/s</th><th>corners: CR / CO mm</th></tr>\n",
      report::Html::Text(id));
  for (const auto& p : e.paths) {
    const auto& f = p.figures;
    Html corners;
    for (const auto& c : f.corners)
      corners += HtmlFormat("{}: {} / {}<br>", c.vertex + 1, Num(c.cr_max_mm), Num(c.co_max_mm));
    h += HtmlFormat(
        "<tr><td>{}</td><td class=\"num\">{}</td><td class=\"num\">{}</td><td "
        "class=\"num\">{}</td><td class=\"num\">{}</td><td class=\"num\">{}</td><td "
        "class=\"num\">{}</td><td class=\"num\">{}</td><td class=\"num\">{}</td><td>{}</td></tr>\n",
        p.name, f.n, Num(p.command.speed_mm_s, 1), Num(f.at_mm), Num(f.mean_at_mm), Num(f.rt_mm),
        Num(f.av_percent, 3), Num(f.rv_percent, 3), Num(f.fv_mm_s, 2),
        corners.empty() ? Html("&mdash;") : corners);
  }
  return h + Html("</table>\n");
}

}  // namespace

std::string WriteIso9283PathPage(const std::string& dir, const Iso9283PathPageInput& in) {
  if (!in.test) throw std::logic_error("WriteIso9283PathPage: no test");
  std::filesystem::create_directories(dir);
  Html body = HtmlFormat(
      "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\"><title>ISO 9283 path "
      "test: {}</title><style>{}</style></head><body>\n<h1>ISO 9283 path test: robot {}</h1>\n",
      in.robot, Html::Trusted(report::figures::kPageStyle), in.robot);
  auto row = [](const char* name, Html value) {
    return HtmlFormat("<tr><th>{}</th><td>{}</td></tr>\n", name, value);
  };
  body += "<table class=\"header\">\n";
  body += row("Robot", HtmlFormat("{} (model {})", in.robot, in.model));
  body += row("Test", HtmlFormat("nominal program: session {}, started {}", in.test->session,
                                 in.test->started_at));
  if (in.compensated) {
    body += row("Compensated", HtmlFormat("session {}, started {}", in.compensated->session,
                                          in.compensated->started_at));
  }
  body += row("Frame", Html::Text(in.test->frame.detail));
  Html instruments;
  for (const auto& i : in.instruments) instruments += HtmlFormat("{}<br>", i);
  body += row("Instruments", instruments.empty() ? Html("&mdash;") : instruments);
  body += row("Date", Html::Text(in.generated_at.empty() ? report::figures::Now() : in.generated_at));
  body += row("Program", HtmlFormat("armsig {}", in.armsig_version));
  body += "</table>\n<h2>Figures: nominal program</h2>\n";
  body += PathTable("paths", *in.test);
  if (in.compensated) {
    body += "<h2>Figures: compensated program</h2>\n";
    body += PathTable("compensated", *in.compensated);
  }
  for (const auto& p : in.test->paths) {
    const Iso9283PathTest* after = nullptr;
    if (in.compensated) {
      for (const auto& q : in.compensated->paths)
        if (q.name == p.name) after = &q;
    }
    body += report::figures::FigureHtml(DeviationFigure(dir, p.name, p, after));
  }
  for (const auto& n : in.test->notes) body += HtmlFormat("<p class=\"note\">{}</p>\n", n);
  body +=
      "<h2>How the figures are computed</h2>\n<p>ISO 9283:1998 clause 8, from the tracker's "
      "continuous records of each cycle in the robot's frame. Normal planes to the commanded "
      "path every millimetre or less over its steady part (the ends and each corner's "
      "neighbourhood left out); in plane j the cycles' crossings, their barycentre x&#772;<sub>j"
      "</sub>; AT = max<sub>j</sub> |x&#772;<sub>j</sub> &minus; x<sub>cj</sub>|, RT = "
      "max<sub>j</sub> (l&#772;<sub>j</sub> + 3 S<sub>lj</sub>). CR: the corner's distance from "
      "the attained path; CO: the largest deviation from the outgoing leg after it. AV = (v&#772; "
      "&minus; v<sub>c</sub>) / v<sub>c</sub>, RV = &plusmn;3 S<sub>v</sub> / v<sub>c</sub> over "
      "the cycles' mean speeds, FV the largest speed fluctuation within a cycle; speeds are chords "
      "over 25 records (100 ms).</p>\n</body></html>\n";
  const std::string path = dir + "/index.html";
  io::WriteFileAtomically(path, body.str());
  return path;
}

}  // namespace armsig::iso9283
