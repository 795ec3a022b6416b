#include "iso9283/iso9283_page.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <map>
#include <opencv2/imgproc.hpp>

#include "core/units.h"
#include "io/atomic_file.h"
#include "report/figures.h"
#include "report/html.h"

namespace armsig::iso9283 {

using namespace report::figures;  // the drawing pieces (report/figures.h)
using report::Html;
using report::HtmlFormat;
namespace iso = calibration::iso9283;

std::optional<iso::TestCube> CubeOfTestPoints(const Iso9283Evaluation& e) {
  std::map<std::string, Eigen::Vector3d> c;
  for (const auto& p : e.points) c[p.name] = p.commanded_mm;
  for (const char* name : {"P1", "P2", "P3", "P4", "P5"})
    if (!c.count(name)) return std::nullopt;
  iso::TestCube cube{c["P1"], (c["P2"] - c["P4"]).norm() / (0.8 * std::sqrt(3.0))};
  if (!(cube.edge_mm > 0)) return std::nullopt;
  for (const auto& p : iso::TestPoints(cube))
    if ((p.position_mm - c[p.name]).norm() > 1e-6 * cube.edge_mm + 1e-6) return std::nullopt;
  return cube;
}

namespace {

// ---- The cube: an oblique view (x right, y receding at 30°, z up) ----

Figure CubeFigure(const std::string& dir, const iso::TestCube& cube, const Iso9283Evaluation& e) {
  cv::Mat image(440, 960, CV_8UC3, cv::Scalar(255, 255, 255));
  Text(image,
       fmt::format("Test cube: edge {:.1f} mm, centre ({:.1f}, {:.1f}, {:.1f}) mm, robot frame",
                   cube.edge_mm, cube.centre_mm.x(), cube.centre_mm.y(), cube.centre_mm.z()),
       {20, 24}, 0.55);
  const double scale = 250.0 / cube.edge_mm;  // px per mm
  const cv::Point origin(310, 250);
  auto project = [&](const Eigen::Vector3d& x) {
    const Eigen::Vector3d d = x - cube.centre_mm;
    return cv::Point(
        origin.x + static_cast<int>(std::lround(scale * (d.x() + 0.45 * d.y() * 0.866))),
        origin.y - static_cast<int>(std::lround(scale * (d.z() + 0.45 * d.y() * 0.5))));
  };
  const auto c = iso::CubeCorners(cube);
  // The measuring plane C1–C2–C7–C8, shaded.
  cv::Mat overlay = image.clone();
  const std::vector<cv::Point> plane = {project(c[0]), project(c[1]), project(c[6]), project(c[7])};
  cv::fillConvexPoly(overlay, plane, cv::Scalar(235, 215, 170), cv::LINE_AA);
  cv::addWeighted(overlay, 0.6, image, 0.4, 0.0, image);
  const int edges[12][2] = {{0, 1}, {1, 2}, {2, 3}, {3, 0}, {4, 5}, {5, 6},
                            {6, 7}, {7, 4}, {0, 4}, {1, 5}, {2, 6}, {3, 7}};
  for (const auto& edge : edges)
    cv::line(image, project(c[edge[0]]), project(c[edge[1]]), kInk, 1, cv::LINE_AA);
  cv::line(image, project(c[0]), project(c[6]), kGrey, 1, cv::LINE_AA);  // the diagonals
  cv::line(image, project(c[1]), project(c[7]), kGrey, 1, cv::LINE_AA);
  for (int k = 0; k < 8; ++k) {
    Text(image, fmt::format("C{}", k + 1),
         project(c[k]) + cv::Point(k % 4 < 2 ? -24 : 6, k < 4 ? -6 : 16), 0.4, Align::kLeft, kGrey);
  }
  for (const auto& p : e.points) {
    const cv::Point at = project(p.commanded_mm);
    DrawMarker(image, at, Marker::kCircle, kRed, 4);
    Text(image, p.name, at + cv::Point(7, -5), 0.45, Align::kLeft, kRed);
  }
  // Axes of the robot frame, and the legend.
  const cv::Point axes(80, 390);
  const double len = 50.0 / scale;
  const Eigen::Vector3d centre = cube.centre_mm;
  auto axis = [&](const Eigen::Vector3d& d) { return project(centre + d * len) - project(centre); };
  const char* names[3] = {"x", "y", "z"};
  for (int k = 0; k < 3; ++k) {
    cv::arrowedLine(image, axes, axes + axis(Eigen::Vector3d::Unit(k)), kInk, 1, cv::LINE_AA, 0,
                    0.15);
    Text(image, names[k], axes + axis(Eigen::Vector3d::Unit(k)) * 1.25, 0.45);
  }
  int y = 80;
  for (const auto& p : e.points) {
    Text(image,
         fmt::format("{}  ({:.1f}, {:.1f}, {:.1f}) mm", p.name, p.commanded_mm.x(),
                     p.commanded_mm.y(), p.commanded_mm.z()),
         {610, y});
    y += 22;
  }
  y += 10;
  for (const std::string line :
       {"shaded: measuring plane C1-C2-C7-C8", "P2...P5 at 10 % of the diagonal",
        "from C1, C2, C7, C8", "a cycle: P1 P5 P4 P3 P2"}) {
    Text(image, line, {610, y}, 0.4, Align::kLeft, kGrey);
    y += 20;
  }
  return Save(dir, "cube.png", "The test cube and its measuring plane", image);
}

// ---- The five points: attained positions around their barycentre ----

// One panel: deviations from the barycentre on two axes, equal scale, the RP circle, the
// commanded position marked (or an arrow towards it when it lies outside the panel).
void ScatterPanel(cv::Mat& image, const cv::Rect& box, const iso::PointData& data,
                  const iso::PointFigures& f, int h, int v) {
  const char* names = "xyz";
  std::vector<Eigen::Vector2d> d;
  for (const auto& s : data.samples) {
    const Eigen::Vector3d r = s.position_mm - f.barycentre_mm;
    d.emplace_back(r(h), r(v));
  }
  double extent = std::isfinite(f.rp_mm) ? 1.15 * f.rp_mm : 0.0;
  for (const auto& p : d) extent = std::max({extent, 1.1 * std::abs(p.x()), 1.1 * std::abs(p.y())});
  if (!(extent > 0)) extent = 0.01;
  const auto ticks = report::NiceTicks(-extent, extent, 4);
  extent = std::max(std::abs(ticks.front()), std::abs(ticks.back()));
  const double px = box.width / (2.0 * extent);
  const cv::Point centre(box.x + box.width / 2, box.y + box.height / 2);
  auto at = [&](double a, double b) {
    return cv::Point(centre.x + static_cast<int>(std::lround(a * px)),
                     centre.y - static_cast<int>(std::lround(b * px)));
  };
  const double step = ticks.size() > 1 ? ticks[1] - ticks[0] : extent;
  for (double t : ticks) {
    if (std::abs(t) > extent + 1e-12) continue;
    cv::line(image, at(t, -extent), at(t, extent), kGrid);
    cv::line(image, at(-extent, t), at(extent, t), kGrid);
    Text(image, TickLabel(t, step), at(t, -extent) + cv::Point(0, 14), 0.33, Align::kCenter);
    Text(image, TickLabel(t, step), at(-extent, t) + cv::Point(-4, 4), 0.33, Align::kRight);
  }
  cv::rectangle(image, box, kInk);
  Text(image, fmt::format("d{} mm", names[h]), {box.x + box.width - 34, box.y + box.height + 30},
       0.36);
  Text(image, fmt::format("d{}", names[v]), {box.x - 40, box.y + 10}, 0.36);
  if (std::isfinite(f.rp_mm))
    cv::circle(image, centre, static_cast<int>(std::lround(f.rp_mm * px)), kOrange, 1, cv::LINE_AA);
  for (const auto& p : d) DrawMarker(image, at(p.x(), p.y()), Marker::kCircle, kBlue, 2);
  cv::drawMarker(image, centre, kInk, cv::MARKER_CROSS, 10, 1, cv::LINE_AA);
  // The commanded position relative to the barycentre: −AP.
  const Eigen::Vector2d c(-f.ap_xyz_mm(h), -f.ap_xyz_mm(v));
  if (std::abs(c.x()) <= extent && std::abs(c.y()) <= extent) {
    DrawMarker(image, at(c.x(), c.y()), Marker::kDiamond, kRed, 4);
  } else {
    const Eigen::Vector2d u = c.normalized();
    const double reach = 0.92 * extent / std::max(std::abs(u.x()), std::abs(u.y()));
    const cv::Point tip = at(u.x() * reach, u.y() * reach);
    cv::arrowedLine(image, at(u.x() * reach * 0.55, u.y() * reach * 0.55), tip, kRed, 2,
                    cv::LINE_AA, 0, 0.25);
    Text(image, fmt::format("commanded {:.3f} mm off", c.norm()), {box.x + 5, box.y + 14}, 0.36,
         Align::kLeft, kRed);
  }
}

Figure ScatterFigure(const std::string& dir, const std::string& file, const std::string& title,
                     const Iso9283Evaluation& e) {
  const int columns = static_cast<int>(std::min<size_t>(e.points.size(), 5));
  const int panel = 190, gap = 70;
  const int width = std::max(900, 60 + columns * (panel + gap));
  cv::Mat image(2 * (panel + 80) + 70, width, CV_8UC3, cv::Scalar(255, 255, 255));
  Text(image, title, {20, 24}, 0.55);
  int x = 70;
  for (int k = 0; k < columns; ++k) {
    const auto& f = e.points[k];
    Text(image,
         fmt::format("{}: AP {:.3f}, RP {}", f.name, f.ap_mm,
                     std::isfinite(f.rp_mm) ? fmt::format("{:.3f}", f.rp_mm) : std::string("-")),
         {x - 20, 62}, 0.42);
    ScatterPanel(image, cv::Rect(x, 80, panel, panel), e.data[k], f, 0, 1);
    ScatterPanel(image, cv::Rect(x, 80 + panel + 80, panel, panel), e.data[k], f, 0, 2);
    x += panel + gap;
  }
  const int legend_y = image.rows - 16;
  DrawMarker(image, {30, legend_y - 4}, Marker::kCircle, kBlue, 3);
  Text(image, "attained (mm from the barycentre +)", {40, legend_y});
  DrawMarker(image, {330, legend_y - 4}, Marker::kDiamond, kRed, 4);
  Text(image, "commanded (an arrow towards it when outside the view)", {342, legend_y});
  cv::circle(image, {770, legend_y - 4}, 6, kOrange, 1, cv::LINE_AA);
  Text(image, "RP", {782, legend_y});
  Text(image, "top row: x-y (from above); bottom row: x-z (from the side)", {20, 42}, 0.4,
       Align::kLeft, kGrey);
  return Save(dir, file, title, image);
}

report::Html Deg(double rad) { return Num(rad / kRadPerDeg, 4); }

// The figures table of one test.
report::Html FiguresTable(const std::string& id, const Iso9283Evaluation& e) {
  const bool oriented = std::any_of(e.points.begin(), e.points.end(),
                                    [](const auto& f) { return f.rp_abc_rad.has_value(); });
  const bool vap = std::any_of(e.points.begin(), e.points.end(),
                               [](const auto& f) { return f.vap_mm.has_value(); });
  report::Html h = HtmlFormat(
      "<table id=\"{}\"><tr><th>point</th><th class=\"num\">n</th><th class=\"num\">AP mm</th>"
      "<th class=\"num\">APx</th><th class=\"num\">APy</th><th class=\"num\">APz</th>"
      "<th class=\"num\">l&#772; mm</th><th class=\"num\">S<sub>l</sub> mm</th>"
      "<th class=\"num\">RP mm</th><th class=\"num wrap\">RP, 95 % bootstrap</th>{}{}</tr>\n",
      id,
      oriented ? report::Html("<th class=\"num wrap\">APa, b, c deg</th><th class=\"num wrap\">RPa, b, c "
                      "deg (&plusmn;)</th>")
               : report::Html(),
      vap ? report::Html("<th class=\"num\">vAP mm</th>") : report::Html());
  for (size_t i = 0; i < e.points.size(); ++i) {
    const auto& f = e.points[i];
    const auto& iv = e.rp_intervals[i];
    report::Html orientation;
    if (oriented) {
      // a, b and c one above the other: three numbers side by side made the table wider
      // than a laptop's window (its last column cut at 1,400 px).
      auto triple = [](const std::optional<Eigen::Vector3d>& v) {
        return v ? Deg(v->x()) + report::Html("<br>") + Deg(v->y()) + report::Html("<br>") + Deg(v->z())
                 : report::Html("&mdash;");
      };
      orientation = HtmlFormat("<td class=\"num\">{}</td><td class=\"num\">{}</td>",
                               triple(f.ap_abc_rad), triple(f.rp_abc_rad));
    }
    h += HtmlFormat(
        "<tr id=\"{}-{}\"><td>{}</td><td class=\"num\">{}</td><td class=\"num\">{}</td>"
        "<td class=\"num\">{}</td><td class=\"num\">{}</td><td class=\"num\">{}</td>"
        "<td class=\"num\">{}</td><td class=\"num\">{}</td><td class=\"num\"><b>{}</b></td>"
        "<td class=\"num\">{}</td>{}{}</tr>\n",
        id, f.name, f.name, f.n, Num(f.ap_mm), Num(f.ap_xyz_mm.x()), Num(f.ap_xyz_mm.y()),
        Num(f.ap_xyz_mm.z()), Num(f.mean_l_mm), Num(f.s_l_mm), Num(f.rp_mm),
        iv ? Num(iv->lo) + report::Html(" &ndash; ") + Num(iv->hi) : report::Html("&mdash;"), orientation,
        vap ? HtmlFormat("<td class=\"num\">{}</td>", f.vap_mm ? Num(*f.vap_mm) : report::Html("&mdash;"))
            : report::Html());
  }
  h += "</table>\n";
  if (!e.distances.empty()) {
    h += report::HtmlFormat(
        "<table id=\"{}-distance\"><tr><th>distance</th><th class=\"num\">n</th><th "
        "class=\"num\">commanded mm</th><th class=\"num\">mean attained mm</th><th "
        "class=\"num\">AD mm</th><th class=\"num\">RD mm (&plusmn;)</th></tr>\n",
        id);
    for (const auto& d : e.distances) {
      h += HtmlFormat(
          "<tr><td>{}&ndash;{}</td><td class=\"num\">{}</td><td class=\"num\">{}</td><td "
          "class=\"num\">{}</td><td class=\"num\"><b>{}</b></td><td "
          "class=\"num\"><b>{}</b></td></tr>\n",
          d.from, d.to, d.n, Num(d.commanded_mm, 3), Num(d.mean_mm, 4), Num(d.ad_mm), Num(d.rd_mm));
    }
    h += "</table>\n";
  }
  h += report::HtmlFormat("<p>Frame: {}</p>\n", e.frame.detail.empty() ? e.frame.method : e.frame.detail);
  for (const auto& n : e.notes) h += report::HtmlFormat("<p class=\"note\">{}</p>\n", n);
  return h;
}

// Before and after: the measured AP, the signature's prediction and the compensated test.
report::Html ComparisonTable(const Iso9283PageInput& in) {
  const auto& before = *in.test.figures;
  const Iso9283Evaluation* after = in.compensated ? in.compensated->figures : nullptr;
  report::Html h(
      "<table id=\"comparison\"><tr><th>point</th><th class=\"num\">AP measured, nominal "
      "program</th><th class=\"num\">AP predicted by the signature</th><th class=\"num\">AP "
      "attained with compensation</th><th class=\"num\">RP nominal program</th><th "
      "class=\"num\">RP with compensation</th></tr>\n");
  for (size_t i = 0; i < before.points.size(); ++i) {
    const auto& f = before.points[i];
    const iso::PointFigures* g = nullptr;
    if (after) {
      for (const auto& p : after->points)
        if (p.name == f.name) g = &p;
    }
    const report::Html predicted = i < in.test.predicted_ap_mm.size()
                               ? Num(in.test.predicted_ap_mm[i].norm())
                               : report::Html("&mdash;");
    h += HtmlFormat(
        "<tr><td>{}</td><td class=\"num\">{}</td><td class=\"num\">{}</td><td "
        "class=\"num\"><b>{}</b></td><td class=\"num\">{}</td><td class=\"num\">{}</td></tr>\n",
        f.name, Num(f.ap_mm), predicted, g ? Num(g->ap_mm) : report::Html("not measured"), Num(f.rp_mm),
        g ? Num(g->rp_mm) : report::Html("&mdash;"));
  }
  h += "</table>\n";
  if (before.frame.method == "rigid best fit") {
    h += report::Html(
        "<p class=\"note\">The measured AP is taken after a rigid best fit, which removes the "
        "rigid part of the error; the signature's prediction keeps it. Without --align both are in "
        "the robot's frame.</p>\n");
  }
  if (in.signature) {
    const auto& s = *in.signature;
    h += HtmlFormat(
        "<p>Held-out validation of arm signature version {} ({}): mean {} mm, max {} mm over {} "
        "configurations spread over the work volume, never used in its fit. The AP attained with "
        "compensation is expected near this figure (the signature's own prediction error) plus the "
        "barycentre's uncertainty; RP is the robot's own and does not change with a "
        "calibration.</p>\n",
        s.version, s.params_spec, Num(s.validation_mean_mm), Num(s.validation_max_mm),
        s.validation_poses);
  }
  return h;
}

}  // namespace

std::string WriteIso9283Page(const std::string& dir, const Iso9283PageInput& in) {
  if (!in.test.figures) throw std::logic_error("WriteIso9283Page: no figures");
  std::filesystem::create_directories(dir);
  const Iso9283Evaluation& e = *in.test.figures;
  report::Html body = HtmlFormat(
      "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\"><title>ISO 9283 test: "
      "{}</title><style>{}</style></head><body>\n<h1>ISO 9283 pose test: robot {}</h1>\n",
      in.robot, report::Html::Trusted(kPageStyle), in.robot);
  auto row = [](const char* name, report::Html value) {
    return HtmlFormat("<tr><th>{}</th><td>{}</td></tr>\n", name, value);
  };
  body += "<table class=\"header\">\n";
  body += row("Robot", HtmlFormat("{} (model {})", in.robot, in.model));
  body += row("Test", HtmlFormat("{}: session {}, started {}", in.test.title, in.test.session,
                                 in.test.started_at));
  if (in.compensated) {
    body += row("Compensated", HtmlFormat("{}: session {}, started {}", in.compensated->title,
                                          in.compensated->session, in.compensated->started_at));
  }
  body += row("Date", report::Html::Text(in.generated_at.empty() ? Now() : in.generated_at));
  body += row("Program", report::HtmlFormat("armsig {}", in.armsig_version));
  body += "</table>\n";
  // Against stated limits: the verdict first, then every check.
  const Iso9283Verdict* decisive =
      in.compensated_verdict ? &*in.compensated_verdict : (in.verdict ? &*in.verdict : nullptr);
  if (decisive) {
    body += HtmlFormat("<p class=\"banner {}\" id=\"verdict\"><b>{}</b> &mdash; {}{}</p>\n",
                       report::Html::Text(decisive->pass ? "good" : "bad"),
                       decisive->pass ? "PASS" : "FAIL", decisive->summary.substr(6),
                       in.compensated_verdict ? report::Html(" (the compensated program)") : report::Html());
    body += "<h2>Against the stated limits</h2>\n<table id=\"limits\"><tr><th>test</th>"
            "<th>figure</th><th>at</th><th class=\"num\">mm</th><th class=\"num\">limit mm"
            "</th><th></th></tr>\n";
    auto checks = [&](const char* test, const Iso9283Verdict& v) {
      for (const auto& c : v.checks) {
        body += HtmlFormat(
            "<tr><td>{}</td><td>{}</td><td>{}</td><td class=\"num\">{}</td><td "
            "class=\"num\">{}</td><td class=\"{}\">{}</td></tr>\n",
            test, c.figure, c.where, Num(c.value_mm), Num(c.limit_mm),
            report::Html::Text(c.pass ? "good" : "bad"), c.pass ? "pass" : "FAIL");
      }
    };
    if (in.verdict) checks("nominal program", *in.verdict);
    if (in.compensated_verdict) checks("compensated program", *in.compensated_verdict);
    body += "</table>\n";
  }

  body += "<h2>Conditions</h2>\n<table id=\"conditions\">\n";
  body += row("Load", in.load_kg ? report::HtmlFormat("{} kg", fmt::format("{:g}", *in.load_kg))
                                 : report::Html("not stated (--load-kg)"));
  body += row("Speed", in.speed_percent ? report::HtmlFormat("{} % of rated speed",
                                                     fmt::format("{:g}", *in.speed_percent))
                                        : report::Html("not stated (--speed-percent)"));
  body += row("Temperature",
              in.temperature.empty() ? report::Html("not measured") : report::Html::Text(in.temperature));
  report::Html instruments;
  for (const auto& i : in.instruments) instruments += report::HtmlFormat("{}<br>", i);
  body += row("Instruments", instruments.empty() ? report::Html("&mdash;") : instruments);
  if (!in.point_precision.empty()) body += row("Point precision", report::Html::Text(in.point_precision));
  body += "</table>\n";

  if (in.cube) body += FigureHtml(CubeFigure(dir, *in.cube, e));
  body += "<h2>Figures: " + report::Html::Text(in.test.title) + "</h2>\n";
  body += FiguresTable("figures", e);
  body += FigureHtml(ScatterFigure(
      dir, "scatter.png",
      "The five points: attained positions around their barycentre (" + in.test.title + ")", e));
  if (in.compensated && in.compensated->figures) {
    body += "<h2>Figures: " + report::Html::Text(in.compensated->title) + "</h2>\n";
    body += FiguresTable("compensated", *in.compensated->figures);
    body += FigureHtml(
        ScatterFigure(dir, "scatter-compensated.png",
                      "The five points with compensation (" + in.compensated->title + ")",
                      *in.compensated->figures));
  }
  if (in.signature) {
    body += "<h2>Calibration: predicted and attained</h2>\n";
    body += ComparisonTable(in);
  }
  body +=
      "<h2>How the figures are computed</h2>\n<p>Per test point, from its n attained positions "
      "x<sub>j</sub>: the barycentre x&#772;; pose accuracy AP = |x&#772; &minus; x<sub>c</sub>| "
      "(APx, APy, APz its components); pose repeatability RP = l&#772; + 3 S<sub>l</sub> with "
      "l<sub>j</sub> = |x<sub>j</sub> &minus; x&#772;| and S<sub>l</sub> the standard deviation "
      "of the l<sub>j</sub> on n &minus; 1; orientation APa = a&#772; &minus; a<sub>c</sub> and "
      "RPa "
      "= &plusmn;3 S<sub>a</sub>. Distance accuracy AD = D&#772; &minus; D<sub>c</sub> over the "
      "cycles' distances D<sub>j</sub> = |x<sub>Aj</sub> &minus; x<sub>Bj</sub>|, RD = &plusmn;3 "
      "S<sub>D</sub>. vAP: the largest distance between the barycentres of the approach "
      "directions. The RP interval is a percentile bootstrap (2,000 resamples of the cycles); the "
      "standard gives none.</p>\n";
  body += "</body></html>\n";
  const std::string path = dir + "/index.html";
  io::WriteFileAtomically(path, body.str());
  return path;
}

}  // namespace armsig::iso9283
