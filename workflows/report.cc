#include "workflows/report.h"

#include <fmt/chrono.h>
#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <map>
#include <nlohmann/json.hpp>
#include <numbers>
#include <numeric>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <set>

#include "acquisition/lab.h"
#include "calibration/statistics.h"
#include "core/error.h"
#include "db/calibrations.h"
#include "db/observations.h"
#include "db/report_queries.h"
#include "io/atomic_file.h"
#include "workflows/figures.h"
#include "workflows/html.h"

namespace armsig::workflows {

using namespace figures;  // the drawing pieces (workflows/figures.h)

// ---- Numbers ----

double PercentileNearestRank(std::vector<double> values, int percent) {
  if (values.empty()) return NAN;
  const int64_t n = static_cast<int64_t>(values.size());
  // ceil(percent·n/100) in integers: 0.95·60 must be 57, not 57.000000000000007 → 58.
  const int64_t rank = std::clamp<int64_t>((percent * n + 99) / 100, 1, n);
  std::nth_element(values.begin(), values.begin() + (rank - 1), values.end());
  return values[rank - 1];
}

std::vector<AxisStatistics> ResidualStatistics(const std::vector<Eigen::Vector3d>& residuals) {
  std::vector<AxisStatistics> out;
  const size_t n = residuals.size();
  for (int c = 0; c < 4; ++c) {
    AxisStatistics s;
    s.name = c < 3 ? std::string("d") + "XYZ"[c] : "distance";
    std::vector<double> v, magnitude;
    for (const auto& r : residuals) {
      v.push_back(c < 3 ? r(c) : r.norm());
      magnitude.push_back(std::abs(v.back()));
    }
    if (n > 0) {
      s.mean_mm = std::accumulate(v.begin(), v.end(), 0.0) / n;
      double squares = 0.0, deviations = 0.0;
      for (double x : v) {
        squares += x * x;
        deviations += (x - s.mean_mm) * (x - s.mean_mm);
      }
      s.rms_mm = std::sqrt(squares / n);
      s.std_mm = n > 1 ? std::sqrt(deviations / (n - 1)) : NAN;  // sample standard deviation
      s.max_abs_mm = *std::max_element(magnitude.begin(), magnitude.end());
      s.p50_mm = PercentileNearestRank(magnitude, 50);
      s.p95_mm = PercentileNearestRank(magnitude, 95);
      s.p99_mm = PercentileNearestRank(magnitude, 99);
    }
    out.push_back(s);
  }
  return out;
}

std::vector<int> WorstResiduals(const std::vector<Eigen::Vector3d>& residuals, int count) {
  std::vector<int> order(residuals.size());
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(),
                   [&](int a, int b) { return residuals[a].norm() > residuals[b].norm(); });
  order.resize(std::min<size_t>(order.size(), std::max(count, 0)));
  return order;
}

std::optional<LinearTrend> LinearTrendOf(const std::vector<double>& x,
                                         const std::vector<double>& y) {
  const size_t n = std::min(x.size(), y.size());
  if (n < 2) return std::nullopt;
  double mx = 0.0, my = 0.0;
  for (size_t i = 0; i < n; ++i) {
    mx += x[i] / n;
    my += y[i] / n;
  }
  double sxx = 0.0, sxy = 0.0;
  for (size_t i = 0; i < n; ++i) {
    sxx += (x[i] - mx) * (x[i] - mx);
    sxy += (x[i] - mx) * (y[i] - my);
  }
  if (!(sxx > 0.0)) return std::nullopt;  // one temperature: no slope
  LinearTrend t;
  t.slope = sxy / sxx;
  t.intercept = my - t.slope * mx;
  t.points = static_cast<int>(n);
  if (n >= 3) {
    double ss = 0.0;
    for (size_t i = 0; i < n; ++i) {
      const double r = y[i] - t.intercept - t.slope * x[i];
      ss += r * r;
    }
    const double dof = static_cast<double>(n - 2);
    t.sigma_slope = std::sqrt(ss / dof / sxx);
    // t² ~ F(1, n − 2): the two-sided t test of a zero slope.
    const double z = t.sigma_slope > 0.0 ? t.slope / t.sigma_slope
                                         : std::numeric_limits<double>::infinity();
    t.p_value = t.slope == 0.0 ? 1.0 : calibration::FisherFSurvival(z * z, 1.0, dof);
  }
  return t;
}

Histogram HistogramOf(const std::vector<double>& distances_mm, int bins) {
  Histogram h;
  const double top =
      distances_mm.empty()
          ? 1.0
          : std::max(*std::max_element(distances_mm.begin(), distances_mm.end()), 1e-6);
  h.bin_width_mm = NiceStep(top / std::max(bins, 1));
  h.counts.assign(static_cast<size_t>(std::floor(top / h.bin_width_mm)) + 1, 0);
  for (double d : distances_mm) {
    const auto b = static_cast<size_t>(std::floor(d / h.bin_width_mm));
    h.counts[std::min(b, h.counts.size() - 1)]++;
  }
  h.count_ticks = IntegerTicks(*std::max_element(h.counts.begin(), h.counts.end()));
  return h;
}

std::string ParamsKind(const std::string& spec) {
  if (spec == "all" || spec == "geometric" || spec == "auto") return spec;
  return spec.empty() ? "unknown" : "list";
}

std::string ReportSetMarker(const std::string& robot, int version) {
  if (version <= 0) return "";
  return HtmlFormat("<meta name=\"armsig-set\" content=\"{} {}\">\n", robot, version).str();
}

int RemoveReportDebris(const std::string& dir, double min_age_s) {
  namespace fs = std::filesystem;
  std::error_code error;
  int removed = 0;
  const auto now = fs::file_time_type::clock::now();
  for (const auto& entry : fs::directory_iterator(dir, error)) {
    const std::string name = entry.path().filename().string();
    const size_t at = name.rfind(".tmp.");
    if (at == std::string::npos || name.size() != at + 11) continue;  // NAME.tmp.XXXXXX
    const std::string base = name.substr(0, at);
    if (base != "index.html" && !base.ends_with(".png")) continue;  // only the report's files
    const auto written = entry.last_write_time(error);
    if (error || std::chrono::duration<double>(now - written).count() < min_age_s) continue;
    if (fs::remove(entry.path(), error)) ++removed;
  }
  return removed;
}

std::string WriteReport(const std::string& dir, const ReportInput& in) {
  if (!in.run || !in.model) throw std::logic_error("WriteReport: no run or model");
  std::filesystem::create_directories(dir);
  if (const int removed = RemoveReportDebris(dir, 60.0))
    spdlog::info("report: removed {} temporary file{} a stopped writer left in {}", removed,
                 removed == 1 ? "" : "s", dir);
  const auto& run = *in.run;
  const auto& model = *in.model;
  const auto names = model.ParameterNames();
  const auto& residuals = run.validation_residuals;
  const std::vector<double> distances = calibration::Distances(residuals);
  const size_t n = residuals.size();
  // Validation poses by id (joints for the per-joint views, targets for the vectors).
  std::map<std::string, const MeasuredPose*> pose_by_id;
  for (const auto& p : in.validation) pose_by_id[p.id] = &p;
  auto pose_of = [&](size_t i) -> const MeasuredPose* {
    if (i >= run.validation_pose_ids.size()) return nullptr;
    const auto it = pose_by_id.find(run.validation_pose_ids[i]);
    return it == pose_by_id.end() ? nullptr : it->second;
  };
  const auto stats = ResidualStatistics(residuals);

  // 1. Error distance per validation configuration, nominal and calibrated (log scale).
  Figure errors_figure;
  {
    double lo = 1e9, hi = 1e-9;
    for (size_t i = 0; i < n; ++i) {
      lo = std::min({lo, residuals[i].norm(), run.validation_nominal_residuals[i].norm()});
      hi = std::max({hi, residuals[i].norm(), run.validation_nominal_residuals[i].norm()});
    }
    Plot p(900, 420, "Error distance per validation configuration",
           IntegerAxis(static_cast<int>(std::max<size_t>(n, 1)), 10), LogAxis(lo, hi),
           "validation configuration (number)", "mm");
    for (size_t i = 0; i < n; ++i) {
      DrawMarker(p.image, p.At(i + 1.0, run.validation_nominal_residuals[i].norm()),
                 Marker::kCircle, kRed, 3);
      DrawMarker(p.image, p.At(i + 1.0, residuals[i].norm()), Marker::kSquare, kGreen, 3);
    }
    p.Legend({{Marker::kCircle, kRed, "nominal model"},
              {Marker::kSquare, kGreen, "calibrated (this fit)"}});
    errors_figure = Save(dir, "errors.png", "Error distance before and after calibration", p.image);
  }
  // 2. Histogram of the calibrated validation errors, with the percentiles.
  Figure histogram_figure;
  {
    const Histogram h = HistogramOf(distances);
    const double top = h.bin_width_mm * h.counts.size();
    Plot p(900, 380, "Calibrated error distances (validation)", LinearAxis(0, top, 8),
           IntegerAxis(h.count_ticks.back(), 6), "error distance (mm)", "poses");
    for (size_t b = 0; b < h.counts.size(); ++b) {
      if (h.counts[b] == 0) continue;
      cv::rectangle(p.image, p.At(h.bin_width_mm * b, h.counts[b]) + cv::Point(1, 0),
                    p.At(h.bin_width_mm * (b + 1), 0) - cv::Point(1, 0), kBlue, cv::FILLED);
    }
    const auto& d = stats[3];
    const std::vector<std::pair<double, cv::Scalar>> lines = {
        {d.p50_mm, kGreen}, {d.p95_mm, kOrange}, {d.p99_mm, kRed}};
    for (const auto& [value, color] : lines) {
      if (!std::isfinite(value)) continue;
      cv::line(p.image, {p.X(value), p.area.y}, {p.X(value), p.area.y + p.area.height}, color, 2,
               cv::LINE_AA);
    }
    p.Legend({{Marker::kSquare, kBlue, fmt::format("poses per {:g} mm", h.bin_width_mm)},
              {Marker::kLine, kGreen, fmt::format("50 %: {:.4f} mm", d.p50_mm)},
              {Marker::kLine, kOrange, fmt::format("95 %: {:.4f} mm", d.p95_mm)},
              {Marker::kLine, kRed, fmt::format("99 %: {:.4f} mm", d.p99_mm)}});
    histogram_figure = Save(dir, "histogram.png", "Residual histogram", p.image);
  }
  // 3. Residual vectors in the work volume: top view (x, y) and side view (x, z), equal
  // scales, positions ticked in mm, arrows magnified with a scale bar in mm.
  Figure vectors_figure;
  {
    cv::Mat image(520, 900, CV_8UC3, cv::Scalar(255, 255, 255));
    double largest = 1e-9;
    for (const auto& r : residuals) largest = std::max(largest, r.norm());
    double span = 1.0;
    for (int axis = 0; axis < 3; ++axis) {
      double a = 1e18, b = -1e18;
      for (size_t i = 0; i < n; ++i) {
        if (const auto* pose = pose_of(i)) {
          a = std::min(a, pose->target_in_world(axis));
          b = std::max(b, pose->target_in_world(axis));
        }
      }
      if (b >= a) span = std::max(span, (b - a) * 1.15);
    }
    const double magnify = 0.08 * span / largest;  // the largest residual: 8 % of the view
    Text(image, "Residual vectors (calibrated model - measured) at the validation targets",
         {70, 20}, 0.55);
    double px_per_mm = 1.0;
    for (int panel = 0; panel < 2; ++panel) {
      const int axis = panel == 0 ? 1 : 2;
      const char* vertical = panel == 0 ? "y" : "z";
      const cv::Rect box(70 + panel * 440, 50, 370, 370);
      double xa = 1e18, xb = -1e18, ya = 1e18, yb = -1e18;
      for (size_t i = 0; i < n; ++i) {
        if (const auto* pose = pose_of(i)) {
          xa = std::min(xa, pose->target_in_world.x());
          xb = std::max(xb, pose->target_in_world.x());
          ya = std::min(ya, pose->target_in_world(axis));
          yb = std::max(yb, pose->target_in_world(axis));
        }
      }
      if (xb < xa) xa = xb = ya = yb = 0.0;
      const double cx = (xa + xb) / 2, cy = (ya + yb) / 2;
      px_per_mm = box.width / span;
      auto px = [&](double x, double y) {
        return cv::Point(
            box.x + box.width / 2 + static_cast<int>(std::lround((x - cx) * px_per_mm)),
            box.y + box.height / 2 - static_cast<int>(std::lround((y - cy) * px_per_mm)));
      };
      const std::vector<double> tx = NiceTicks(cx - span / 2, cx + span / 2, 4);
      const std::vector<double> ty = NiceTicks(cy - span / 2, cy + span / 2, 4);
      const double step = tx.size() > 1 ? tx[1] - tx[0] : 1.0;
      for (double t : tx) {
        const int x = px(t, cy).x;
        if (x < box.x || x > box.x + box.width) continue;
        cv::line(image, {x, box.y}, {x, box.y + box.height}, kGrid);
        Text(image, TickLabel(t, step), {x, box.y + box.height + 16}, 0.38, Align::kCenter);
      }
      for (double t : ty) {
        const int y = px(cx, t).y;
        if (y < box.y || y > box.y + box.height) continue;
        cv::line(image, {box.x, y}, {box.x + box.width, y}, kGrid);
        Text(image, TickLabel(t, step), {box.x - 5, y + 4}, 0.38, Align::kRight);
      }
      cv::rectangle(image, box, kInk);
      Text(
          image,
          panel == 0 ? "top view: x (mm) across, y (mm) up" : "side view: x (mm) across, z (mm) up",
          {box.x, box.y - 8}, 0.45);
      Text(image, "x (mm)", {box.x + box.width / 2, box.y + box.height + 34}, 0.4, Align::kCenter);
      Text(image, std::string(vertical) + " (mm)", {box.x - 60, box.y - 8 + 0}, 0.4);
      // Coordinate axes of the measuring frame (directions), bottom left.
      const cv::Point o(box.x + 16, box.y + box.height - 16);
      cv::arrowedLine(image, o, o + cv::Point(36, 0), kInk, 1, cv::LINE_AA, 0, 0.25);
      cv::arrowedLine(image, o, o + cv::Point(0, -36), kInk, 1, cv::LINE_AA, 0, 0.25);
      Text(image, "x", o + cv::Point(40, 4));
      Text(image, vertical, o + cv::Point(-3, -40));
      for (size_t i = 0; i < n; ++i) {
        const auto* pose = pose_of(i);
        if (!pose) continue;
        const Eigen::Vector3d& x = pose->target_in_world;
        const Eigen::Vector3d tip = x + magnify * residuals[i];
        cv::circle(image, px(x.x(), x(axis)), 2, kGrey, cv::FILLED, cv::LINE_AA);
        cv::arrowedLine(image, px(x.x(), x(axis)), px(tip.x(), tip(axis)), kRed, 1, cv::LINE_AA, 0,
                        0.25);
      }
    }
    // The residual scale bar: a round length in mm, drawn at the arrows' magnification.
    const double bar_mm = NiceBelow(largest);
    const int bar_px = std::max(1, static_cast<int>(std::lround(bar_mm * magnify * px_per_mm)));
    const cv::Point b0(70, 490);
    cv::line(image, b0, b0 + cv::Point(bar_px, 0), kRed, 2, cv::LINE_AA);
    cv::line(image, b0 + cv::Point(0, -5), b0 + cv::Point(0, 5), kRed, 2);
    cv::line(image, b0 + cv::Point(bar_px, -5), b0 + cv::Point(bar_px, 5), kRed, 2);
    Text(image,
         fmt::format("= {:g} mm of residual (arrows magnified x{:.0f}; largest {:.4f} mm)", bar_mm,
                     magnify, largest),
         b0 + cv::Point(bar_px + 10, 5), 0.45);
    vectors_figure = Save(dir, "vectors.png", "Residual vectors in the work volume", image);
  }
  // 4. Drift: the validation mean of every version, on the version axis; the kind of
  // parameter set (--params) as marker and colour.
  Figure drift_figure;
  {
    const auto& h = in.history;
    int newest = 0;
    double top = 1e-6;
    for (const auto& p : h) {
      newest = std::max(newest, p.version);
      if (std::isfinite(p.validation_mean_mm)) top = std::max(top, p.validation_mean_mm);
    }
    auto x_of = [&](const ReportHistoryPoint& p) { return p.version > 0 ? p.version : newest + 1; };
    Axis x;
    std::set<int> xs;
    for (const auto& p : h) xs.insert(x_of(p));
    if (xs.empty()) xs.insert(1);
    const int every = static_cast<int>(std::ceil(xs.size() / 15.0));  // at most ~15 labels
    int k = 0;
    for (int v : xs) {
      if (k++ % every != 0 && v != *xs.rbegin()) continue;
      x.ticks.push_back(v);
      const bool unsaved = std::any_of(
          h.begin(), h.end(), [&](const auto& p) { return p.version == 0 && x_of(p) == v; });
      x.labels.push_back(unsaved ? "this run" : std::to_string(v));
    }
    x.lo = *xs.begin() - 0.5;
    x.hi = *xs.rbegin() + 0.5;
    Plot p(900, 360, "Validation mean error of every version", x, LinearAxis(0, top * 1.25, 5),
           "parameter set version", "mm");
    struct Style {
      Marker marker;
      cv::Scalar color;
    };
    const std::map<std::string, Style> styles = {{"all", {Marker::kCircle, kBlue}},
                                                 {"geometric", {Marker::kSquare, kOrange}},
                                                 {"auto", {Marker::kTriangle, kPurple}},
                                                 {"list", {Marker::kDiamond, kTeal}},
                                                 {"unknown", {Marker::kCircle, kGrey}}};
    std::set<std::string> kinds;
    bool any_active = false, any_unsaved = false, any_drift = false, any_by_hand = false,
         any_activated = false;
    cv::Point last(-1, -1);
    for (const auto& point : h) {
      if (!std::isfinite(point.validation_mean_mm)) continue;
      const cv::Point at = p.At(x_of(point), point.validation_mean_mm);
      if (last.x >= 0) cv::line(p.image, last, at, kGrey, 1, cv::LINE_AA);
      last = at;
    }
    for (const auto& point : h) {
      if (!std::isfinite(point.validation_mean_mm)) continue;
      const std::string kind = ParamsKind(point.params_spec);
      kinds.insert(kind);
      const Style& s = styles.at(kind);
      const cv::Point at = p.At(x_of(point), point.validation_mean_mm);
      DrawMarker(p.image, at, s.marker, s.color, 5);
      if (point.active) {
        cv::circle(p.image, at, 10, kInk, 1, cv::LINE_AA);
        any_active = true;
      }
      if (point.version == 0) {
        cv::circle(p.image, at, 10, kRed, 2, cv::LINE_AA);
        any_unsaved = true;
      }
      if (point.drift) {
        // Drift flagged against the set before it: a red bar with a cap above the point.
        cv::line(p.image, at + cv::Point(0, -14), at + cv::Point(0, -30), kRed, 3, cv::LINE_AA);
        cv::line(p.image, at + cv::Point(-6, -30), at + cv::Point(6, -30), kRed, 3, cv::LINE_AA);
        any_drift = true;
      }
      if (!point.activations.empty()) {
        // Made active: a triangle below the point, purple when `activate` chose it (a roll
        // back or forward), green when the nightly job or the demo did.
        const bool by_hand = std::any_of(point.activations.begin(), point.activations.end(),
                                         [](const auto& a) { return a.by == "activate"; });
        const cv::Point tip = at + cv::Point(0, 13);
        const std::vector<cv::Point> triangle = {tip, tip + cv::Point(-6, 10),
                                                 tip + cv::Point(6, 10)};
        cv::fillConvexPoly(p.image, triangle, by_hand ? kPurple : kGreen, cv::LINE_AA);
        any_by_hand |= by_hand;
        any_activated |= !by_hand;
      }
    }
    std::vector<LegendEntry> legend;
    for (const char* kind : {"all", "geometric", "auto", "list", "unknown"}) {
      if (!kinds.count(kind)) continue;
      legend.push_back({styles.at(kind).marker, styles.at(kind).color,
                        std::string("params ") + (std::string(kind) == "list" ? "list" : kind)});
    }
    p.Legend(legend);
    // Rings are explained in the caption row below the title's legend, inside the figure.
    std::string rings;
    if (any_active) rings += "black ring: the active set";
    if (any_unsaved)
      rings += std::string(rings.empty() ? "" : "; ") + "red ring: this run (not stored)";
    if (!rings.empty()) Text(p.image, rings, {p.area.x + p.area.width, 20}, 0.4, Align::kRight);
    // The marks of the life cycle, explained under the plot (outside the data).
    std::string marks;
    if (any_drift) marks += "red bar above: drift flagged against the set before";
    if (any_activated)
      marks += std::string(marks.empty() ? "" : "; ") + "green triangle below: made active";
    if (any_by_hand)
      marks += std::string(marks.empty() ? "" : "; ") + "purple triangle: made active by activate";
    if (!marks.empty()) Text(p.image, marks, {p.area.x, p.image.rows - 8}, 0.4);
    if (h.empty()) {
      Text(p.image, "no parameter set stored yet",
           {p.area.x + p.area.width / 2, p.area.y + p.area.height / 2}, 0.5, Align::kCenter);
    }
    drift_figure = Save(dir, "drift.png", "Drift against earlier versions", p.image);
  }
  // 5. Error against each joint angle, one small figure per joint.
  std::vector<Figure> joint_figures;
  {
    double top = 1e-6;
    for (double d : distances) top = std::max(top, d);
    for (int j = 0; j < model.num_joints(); ++j) {
      double lo = 1e18, hi = -1e18;
      for (size_t i = 0; i < n; ++i) {
        if (const auto* pose = pose_of(i); pose && j < pose->joints_rad.size()) {
          lo = std::min(lo, pose->joints_rad(j) * kDegPerRad);
          hi = std::max(hi, pose->joints_rad(j) * kDegPerRad);
        }
      }
      if (hi < lo) lo = hi = 0.0;
      Plot p(440, 260, fmt::format("Joint {}: error against angle", j + 1), LinearAxis(lo, hi, 5),
             LinearAxis(0, top, 4), fmt::format("joint {} (deg)", j + 1), "mm");
      for (size_t i = 0; i < n; ++i) {
        if (const auto* pose = pose_of(i); pose && j < pose->joints_rad.size()) {
          DrawMarker(p.image, p.At(pose->joints_rad(j) * kDegPerRad, distances[i]), Marker::kCircle,
                     kBlue, 3);
        }
      }
      joint_figures.push_back(Save(dir, fmt::format("joint_{}.png", j + 1),
                                   fmt::format("Error against joint {}", j + 1), p.image));
    }
  }

  // 6. The residual map's cross-validation curve: CV mean against the length scale, one
  // line per regularisation, the parametric model's CV mean as a level.
  std::optional<Figure> map_figure;
  if (run.residual_map && !run.residual_map->grid.empty()) {
    const auto& m = *run.residual_map;
    double lo = 1e300, hi = 0.0, top = 0.0, bottom = 1e300;
    std::set<double> lambdas;
    for (const auto& g : m.grid) {
      lo = std::min(lo, g.length_scale);
      hi = std::max(hi, g.length_scale);
      if (std::isfinite(g.cv_mean_mm)) {
        top = std::max(top, g.cv_mean_mm);
        bottom = std::min(bottom, g.cv_mean_mm);
      }
      lambdas.insert(g.regularisation);
    }
    if (std::isfinite(m.cv_mean_mm_parametric)) {
      top = std::max(top, m.cv_mean_mm_parametric);
      bottom = std::min(bottom, m.cv_mean_mm_parametric);
    }
    if (!(top > 0)) top = 1.0;
    if (!(bottom < top)) bottom = 0.0;
    Plot p(900, 360, "Residual map: cross-validated mean error on the fit poses",
           LinearAxis(lo * 0.9, hi * 1.1, 6), LinearAxis(std::max(0.0, bottom * 0.9), top * 1.05, 5),
           "length scale (scaled joint features)", "mm");
    const Marker markers[] = {Marker::kCircle, Marker::kSquare, Marker::kTriangle,
                              Marker::kDiamond};
    const cv::Scalar colors[] = {kBlue, kOrange, kPurple, kTeal, kGrey};
    std::vector<LegendEntry> legend;
    int k = 0;
    for (double lambda : lambdas) {
      std::vector<calibration::CrossValidationPoint> line;
      for (const auto& g : m.grid) {
        if (g.regularisation == lambda && std::isfinite(g.cv_mean_mm)) line.push_back(g);
      }
      std::sort(line.begin(), line.end(),
                [](const auto& a, const auto& b) { return a.length_scale < b.length_scale; });
      const Marker marker = markers[k % 4];
      const cv::Scalar color = colors[k % 5];
      for (size_t i = 0; i < line.size(); ++i) {
        const cv::Point at = p.At(line[i].length_scale, line[i].cv_mean_mm);
        if (i > 0) {
          cv::line(p.image, p.At(line[i - 1].length_scale, line[i - 1].cv_mean_mm), at, color, 1,
                   cv::LINE_AA);
        }
        DrawMarker(p.image, at, marker, color, 4);
      }
      legend.push_back({marker, color, fmt::format("lambda {:g}", lambda)});
      ++k;
    }
    if (std::isfinite(m.cv_mean_mm_parametric)) {
      const int y = p.Y(m.cv_mean_mm_parametric);
      cv::line(p.image, {p.area.x, y}, {p.area.x + p.area.width, y}, kRed, 1, cv::LINE_AA);
      legend.push_back({Marker::kLine, kRed, "parametric model"});
    }
    if (!m.map.centres_rad.empty()) {
      // The chosen (length scale, regularisation): a ring around its point.
      cv::circle(p.image, p.At(m.map.length_scale, m.cv_mean_mm_with_map), 10, kInk, 1,
                 cv::LINE_AA);
      Text(p.image, "ring: chosen", {p.area.x + p.area.width, 20}, 0.4, Align::kRight);
    }
    p.Legend(legend);
    map_figure = Save(dir, "residual_map.png", "Residual map: cross-validation curve", p.image);
  }

  // 7. Error against the air temperature at the instrument (laser trackers report it with
  // every reading): a thermal drift of the robot or the set-up shows as a slope.
  Figure temperature_figure;
  std::vector<double> temperatures, temperature_errors;
  for (size_t i = 0; i < n && i < run.validation_pose_ids.size(); ++i) {
    const auto it = in.temperature_c.find(run.validation_pose_ids[i]);
    if (it == in.temperature_c.end() || !std::isfinite(it->second)) continue;
    temperatures.push_back(it->second);
    temperature_errors.push_back(distances[i]);
  }
  const std::optional<LinearTrend> trend = LinearTrendOf(temperatures, temperature_errors);
  {
    double lo = 20.0, hi = 21.0, top = 1e-6;
    if (!temperatures.empty()) {
      lo = *std::min_element(temperatures.begin(), temperatures.end());
      hi = *std::max_element(temperatures.begin(), temperatures.end());
      if (hi - lo < 0.01) {  // a steady room: a 0.1 °C wide axis around it
        lo -= 0.05;
        hi += 0.05;
      }
    }
    for (double d : distances) top = std::max(top, d);
    Plot p(900, 360, "Calibrated error against the air temperature at the instrument",
           LinearAxis(lo, hi, 8), LinearAxis(0, top, 5), "air temperature at the instrument (deg C)",
           "mm");
    for (size_t k = 0; k < temperatures.size(); ++k) {
      DrawMarker(p.image, p.At(temperatures[k], temperature_errors[k]), Marker::kCircle, kBlue, 3);
    }
    std::vector<LegendEntry> legend = {
        {Marker::kCircle, kBlue,
         fmt::format("validation poses with a temperature: {} of {}", temperatures.size(), n)}};
    if (trend) {
      const Axis axis = LinearAxis(lo, hi, 8);  // the drawn axis: lo and hi rounded out
      const double x0 = axis.lo, x1 = axis.hi;
      cv::line(p.image, p.At(x0, trend->intercept + trend->slope * x0),
               p.At(x1, trend->intercept + trend->slope * x1), kRed, 2, cv::LINE_AA);
      legend.push_back({Marker::kLine, kRed,
                        fmt::format("least-squares trend: {:+.4f} mm per deg C", trend->slope)});
    }
    p.Legend(legend);
    if (temperatures.empty()) {
      Text(p.image,
           "no temperature stored with these poses (theodolites, or poses imported from a file)",
           {p.area.x + p.area.width / 2, p.area.y + p.area.height / 2}, 0.5, Align::kCenter);
    }
    temperature_figure =
        Save(dir, "temperature.png", "Error against the air temperature", p.image);
  }

  // ---- The page ---- (every text through Html: escaped unless it is a literal here)
  Html html = HtmlFormat(
      "<!doctype html>\n<html><head><meta charset=\"utf-8\"><title>armsig report: {}</title>\n"
      "{}<style>{}</style>\n</head><body>\n",
      in.robot, Html::Trusted(ReportSetMarker(in.robot, in.version)), Html::Trusted(kPageStyle));
  html += HtmlFormat("<h1>Recalibration of {}</h1>\n", in.robot);
  html += HtmlFormat("<p class=\"{}\"><b>{}</b></p>\n", in.version > 0 ? Html("good") : Html("bad"),
                     in.decision);

  // Header: where the numbers come from.
  {
    const auto& id = run.estimate.identifiability;
    auto row = [&](const Html& label, const Html& id_name, const Html& value, bool nowrap = false) {
      html += HtmlFormat("<tr><th>{}</th><td id=\"{}\"{}>{}</td></tr>\n", label, id_name,
                         nowrap ? Html(" class=\"nowrap\"") : Html(), value);
    };
    html += "<table class=\"header\">\n";
    row("Date", "generated-at", Html::Text(in.generated_at.empty() ? Now() : in.generated_at),
        true);
    row("armsig version", "armsig-version",
        in.armsig_version.empty() ? Html("not known") : Html::Text(in.armsig_version), true);
    row("Robot", "robot",
        HtmlFormat("{} (model {}, {} joints)", in.robot, model.name, model.num_joints()));
    row("Parameter set", "params",
        HtmlFormat("--params {} ({}), {} poses fitted, {} validated", run.params_spec,
                   ParamsKind(run.params_spec), run.fit_pose_ids.size(),
                   run.validation_pose_ids.size()));
    Html sessions;
    for (const auto& s : in.sources.sessions) {
      sessions += HtmlFormat(
          "<div>session {}: {} &ndash; {} ({}), {} fitted + {} validation poses{}</div>", s.id,
          s.started_at, s.finished_at.empty() ? std::string("not finished") : s.finished_at,
          s.state, s.poses_fit, s.poses_validation,
          s.note.empty() ? Html() : Html(", ") + Html::Text(s.note));
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
    for (const auto& s : in.sources.setups) {
      sigma0 += HtmlFormat(
          "<div>session {}, station {}: {}</div>", s.session_id, s.station,
          s.sigma0 ? HtmlFormat("&sigma;<sub>0</sub> = {:.3f} ({} dof{})", *s.sigma0, s.dof,
                                s.method.empty() ? std::string() : ", " + s.method)
                   : Html("&sigma;<sub>0</sub> not stored"));
    }
    row("Orientation &sigma;<sub>0</sub>", "sigma0",
        sigma0.empty() ? Html("not stored (no station set-ups with these sessions)") : sigma0);
    row("Rank", "rank",
        HtmlFormat("{} of {} candidate parameters{}", id.rank, id.candidates.size(),
                   id.structural_rank >= 0
                       ? fmt::format(" (structural rank {})", id.structural_rank)
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
  }

  // Error statistics.
  {
    const auto v = StatsOf(residuals);
    const auto vn = StatsOf(run.validation_nominal_residuals);
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
      line("parametric, validation (before the map)", StatsOf(run.validation_parametric_residuals));
      line("with the residual map, validation", v);
    } else {
      line("calibrated, validation", v);
    }
    html += "</table>\n";
    if (run.residual_map) {
      const auto& m = *run.residual_map;
      html += HtmlFormat(
          "<h2>Residual map</h2>\n<p id=\"residual-map\">{}: {}. Cross-validated mean error on "
          "the fit poses (5 folds): {} mm parametric, {} mm with the map.",
          m.used ? "Used" : "Not used", m.decision, Num(m.cv_mean_mm_parametric),
          Num(m.cv_mean_mm_with_map));
      if (!m.map.centres_rad.empty()) {
        html += HtmlFormat(" Length scale {}, regularisation {}, {} centres, noise σ {} mm.",
                           fmt::format("{:g}", m.map.length_scale),
                           fmt::format("{:g}", m.map.regularisation), m.map.centres_rad.size(),
                           Num(m.map.noise_sigma_mm));
      }
      if (const auto v = run.map_validation(); run.map_used() && v.poses > 0) {
        html += HtmlFormat(
            " On the validation poses: predictive σ {} mm per coordinate on average; {} of {} "
            "outside the map's support (parametric prediction).",
            Num(v.mean_sigma_mm), v.outside, v.poses);
      }
      html += "</p>\n";
      if (map_figure) html += FigureHtml(*map_figure);
    }
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
  }
  html += Html("<h2>Error per validation configuration</h2>\n") + FigureHtml(errors_figure) +
          FigureHtml(histogram_figure);

  // The ten worst validation poses.
  {
    html +=
        "<h2>The ten worst validation poses</h2>\n<table id=\"worst\"><tr><th "
        "class=\"num\">#</th><th>pose</th><th class=\"num\">distance</th><th "
        "class=\"num\">dX</th><th class=\"num\">dY</th><th class=\"num\">dZ</th><th "
        "class=\"num\">joints (deg)</th></tr>\n";
    int rank = 0;
    for (int i : WorstResiduals(residuals, 10)) {
      const auto* pose = pose_of(i);
      std::string joints;
      if (pose) {
        for (int j = 0; j < pose->joints_rad.size(); ++j)
          joints += fmt::format("{}{:.1f}", j ? ", " : "", pose->joints_rad(j) * kDegPerRad);
      }
      html += HtmlFormat(
          "<tr><td class=\"num\">{}</td><td class=\"pose\">{}</td><td class=\"num\">{}</td><td "
          "class=\"num\">{}</td><td class=\"num\">{}</td><td class=\"num\">{}</td><td "
          "class=\"num\">{}</td></tr>\n",
          ++rank,
          static_cast<size_t>(i) < run.validation_pose_ids.size() ? run.validation_pose_ids[i]
                                                                  : std::to_string(i + 1),
          Num(residuals[i].norm()), Num(residuals[i].x()), Num(residuals[i].y()),
          Num(residuals[i].z()), joints.empty() ? Html("&mdash;") : Html::Text(joints));
    }
    html += "</table>\n";
  }
  html += Html("<h2>Residual vectors</h2>\n") + FigureHtml(vectors_figure);
  html += Html("<h2>Error against temperature</h2>\n");
  if (temperatures.empty()) {
    html += Html(
        "<p id=\"temperature-trend\">No validation pose has an air temperature (laser trackers "
        "store it with every reading; theodolites and imported poses do not).</p>\n");
  } else {
    const auto [t_lo, t_hi] = std::minmax_element(temperatures.begin(), temperatures.end());
    html += HtmlFormat(
        "<p id=\"temperature-trend\">{} of {} validation poses have an air temperature, {:.3f} "
        "to {:.3f} &deg;C; {}</p>\n",
        temperatures.size(), n, *t_lo, *t_hi,
        trend ? HtmlFormat("least-squares slope of the error distance: <span "
                           "id=\"temperature-slope\">{:.6f}</span> mm per &deg;C{}",
                           trend->slope,
                           std::isfinite(trend->sigma_slope)
                               ? HtmlFormat(" &plusmn; <span id=\"temperature-slope-sigma\">"
                                            "{:.6f}</span> (p = <span id=\"temperature-slope-p\">"
                                            "{:.3g}</span>: {})",
                                            trend->sigma_slope, trend->p_value,
                                            trend->p_value < 0.01
                                                ? Html("<b>significant</b>: the error changes "
                                                       "with the temperature")
                                                : Html("not significant at 1 %"))
                               : Html(" (two temperatures: no significance)"))
              : Html("all at one temperature: no slope."));
  }
  html += FigureHtml(temperature_figure);
  html += "<h2>Error against each joint angle</h2>\n<div class=\"joints\">\n";
  for (const auto& f : joint_figures) html += FigureHtml(f);
  html += "</div>\n";

  // Parameter table in the paper's layout, with sigmas.
  {
    const int joints = model.num_joints();
    std::vector<char> identified(model.num_parameters(), 0);
    for (int k : run.estimate.identifiability.identified) identified[k] = 1;
    html +=
        "<h2>Parameters (paper's Table 1-3 layout; value &plusmn; sigma)</h2>\n<table><tr><th>i "
        "=</th>";
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
        const int k = i < joints ? 6 * i + r : (r < 3 ? 6 * joints + r : -1);
        if (k < 0) {
          html += "<td></td>";
          continue;
        }
        const double scale = r < 3 ? 1.0 : 1e3;
        html += identified[k]
                    ? HtmlFormat("<td class=\"num\">{:.3f} &plusmn; {:.3f}</td>",
                                 run.estimate.params(k) * scale, run.estimate.sigmas(k) * scale)
                    : Html("<td class=\"num\">&mdash;</td>");
      }
      html += "</tr>\n";
    }
    html += "</table>\n";
    for (int k = model.num_geometric(); k < model.num_parameters(); ++k) {
      html += identified[k]
                  ? HtmlFormat(
                        "<p>{} = {:.3f} &plusmn; {:.3f} &times; 10<sup>-3</sup> "
                        "rad</p>\n",
                        names[k], run.estimate.params(k) * 1e3, run.estimate.sigmas(k) * 1e3)
                  : HtmlFormat("<p>{}: not identified</p>\n", names[k]);
    }
  }

  // Change against the previous version: a table, or a sentence saying why there is none.
  {
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
            names[c.parameter], FormatChange(c.change, mm),
            std::abs(c.z) > 5 ? Html(" bad") : Html(), c.z);
      }
      html += "</table>\n";
    }
  }

  // The window's sessions against the set active before the run.
  if (!in.window.empty() || !in.drift_line.empty()) {
    html += Html("<h2>The sessions against the active set</h2>\n");
    if (!in.drift_line.empty())
      html += HtmlFormat("<p class=\"bad\" id=\"drift-line\">{}</p>\n", in.drift_line);
    if (!in.causes.empty()) {
      html += Html("<p>Physical causes, each fitted alone against the change:</p>\n<ol id=\"causes\">\n");
      for (const auto& c : in.causes) html += HtmlFormat("<li>{}</li>\n", c);
      html += Html("</ol>\n");
    }
    if (!in.window.empty()) {
      html += HtmlFormat(
          "<table id=\"window\"><tr><th class=\"num\">session</th><th>started</th><th "
          "class=\"num\">configurations</th><th class=\"num\">mean error under version {} "
          "(mm)</th><th class=\"num\">change up to (mm)</th><th class=\"num\">p</th><th>verdict</th>"
          "</tr>\n",
          in.previous_version.value_or(0));
      for (const auto& w : in.window) {
        html += HtmlFormat(
            "<tr><td class=\"num\">{}</td><td>{}</td><td class=\"num\">{}</td><td "
            "class=\"num\">{:.4f}</td><td class=\"num\">{:.3f}</td><td class=\"num\">{:.2g}</td><td{}>{}</td></tr>\n",
            w.session, w.started_at, w.poses, w.mean_mm, w.effect_max_mm, w.p_value,
            w.disagrees ? Html(" class=\"bad\"") : Html(),
            w.outlier ? "disagrees (an outlier: left out)"
                      : w.disagrees ? "disagrees" : "agrees");
      }
      html += Html("</table>\n");
    }
  }

  // History of versions.
  html += Html("<h2>Drift against earlier versions</h2>\n") + FigureHtml(drift_figure);
  if (!in.history.empty()) {
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
          h.params_spec.empty() ? std::string("not known") : h.params_spec,
          Num(h.validation_mean_mm), h.drift ? Html("<span class=\"bad\">DRIFT</span>") : Html(),
          activations, h.active ? "active" : "");
    }
    html += "</table>\n";
  }
  html += "</body></html>\n";
  const std::string path = dir + "/index.html";
  io::WriteFileAtomically(path, html.str());
  return path;
}

std::vector<ReportHistoryPoint> ReportHistoryOf(db::Database& db, int64_t robot_id) {
  std::vector<ReportHistoryPoint> out;
  const auto activations = db::ActivationHistory(db, robot_id);
  for (const auto& h : db::CalibrationHistory(db, robot_id)) {
    ReportHistoryPoint point{h.version, h.created_at, h.validation_mean_mm, h.params_spec,
                             h.active};
    const auto drift = nlohmann::json::parse(h.drift_json.empty() ? "null" : h.drift_json,
                                             nullptr, false);
    point.drift = drift.is_object() && drift.contains("flag") && drift["flag"].is_boolean() &&
                  drift["flag"].get<bool>();
    for (const auto& a : activations) {
      if (a.version == h.version) point.activations.push_back({a.activated_at, a.activated_by});
    }
    out.push_back(std::move(point));
  }
  return out;
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

namespace {
// The sessions with their fitted and validated pose counts: dates, the instruments of
// their stored lab files and of the instruments table, their stations' latest set-ups.
ReportSources LoadSessionSources(db::Database& db,
                                 const std::map<int64_t, std::pair<int, int>>& counts);
}  // namespace

ReportSources LoadReportSources(db::Database& db, const CalibrationRun& run) {
  // Pose ids are "<session>:<label>" (db::LoadRobotPoses).
  std::map<int64_t, std::pair<int, int>> counts;  // session → fitted, validated
  auto count = [&](const std::vector<std::string>& ids, bool fit) {
    for (const auto& id : ids) {
      const auto colon = id.find(':');
      if (colon == std::string::npos || colon == 0) continue;
      int64_t session = 0;
      try {
        session = std::stoll(id.substr(0, colon));
      } catch (const std::exception&) {
        continue;  // not a stored pose id
      }
      (fit ? counts[session].first : counts[session].second)++;
    }
  };
  count(run.fit_pose_ids, true);
  count(run.validation_pose_ids, false);
  return LoadSessionSources(db, counts);
}

ReportSources LoadReportSources(db::Database& db, const std::vector<int64_t>& session_ids) {
  std::map<int64_t, std::pair<int, int>> counts;
  for (int64_t id : session_ids) counts[id] = {0, 0};
  return LoadSessionSources(db, counts);
}

namespace {

ReportSources LoadSessionSources(db::Database& db,
                                 const std::map<int64_t, std::pair<int, int>>& counts) {
  ReportSources out;
  std::vector<int64_t> ids;
  for (const auto& [id, c] : counts) ids.push_back(id);

  std::map<std::pair<std::string, std::string>, std::vector<int64_t>> instruments;
  for (const auto& s : db::LoadSessionSummaries(db, ids)) {
    const auto [fitted, validated] = counts.at(s.id);
    out.sessions.push_back({s.id, s.started_at, s.finished_at, s.state, s.note, fitted, validated});
    if (!s.lab_yaml.empty()) {
      try {
        const auto lab = acquisition::ParseLabSettings(
            s.lab_yaml, fmt::format("lab file stored with session {}", s.id));
        for (const auto& i : lab.instruments) {
          std::string d = i.protocol + (i.tcp.empty() ? " on " + i.port : " over " + i.tcp);
          if (i.protocol == "emscon") {
            // A laser tracker's readings carry their own sigmas, which take the place of
            // any a-priori ones.
            d += fmt::format(", laser tracker, stationary mode {} ms; sigmas: each reading's own",
                             i.measurement_time_ms);
          } else {
            d += fmt::format(", sigma hz {:g}\" v {:g}\"", i.sigma_hz_arcsec, i.sigma_v_arcsec);
            if (i.distance) d += fmt::format(", distances (sigma {:g} mm)", i.sigma_distance_mm);
          }
          instruments[{"station " + i.station, d}].push_back(s.id);
        }
      } catch (const InputError& e) {
        spdlog::warn("report: session {}: its stored lab file cannot be read: {}", s.id, e.what());
        instruments[{"session " + std::to_string(s.id), "lab file unreadable"}].push_back(s.id);
      }
    }
    for (const auto& i : db::SessionInstruments(db, s.id)) {
      std::string d = i.kind + ", " + i.protocol;
      if (!i.serial_number.empty()) d += ", serial " + i.serial_number;
      if (!i.firmware.empty()) d += ", firmware " + i.firmware;
      if (i.sigma_hz_arcsec && i.sigma_v_arcsec)
        d += fmt::format(", sigma hz {:g}\" v {:g}\"", *i.sigma_hz_arcsec, *i.sigma_v_arcsec);
      if (i.sigma_distance_mm) d += fmt::format(", sigma distance {:g} mm", *i.sigma_distance_mm);
      instruments[{i.name, d}].push_back(s.id);
    }
    for (const auto& [station, setup] : db::LatestStationSetups(db, s.id)) {
      out.setups.push_back({s.id, station, setup.sigma0, setup.dof, setup.method});
    }
  }
  for (const auto& [key, sessions] : instruments) {
    out.instruments.push_back({key.first, key.second, sessions});
  }
  return out;
}

}  // namespace

}  // namespace armsig::workflows
