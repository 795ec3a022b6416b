#include "report/report_figures.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>
#include <set>

#include "calibration/statistics.h"
#include "core/text.h"
#include "core/wording.h"

namespace armsig::report {

using namespace figures;  // the drawing pieces (report/figures.h)

namespace {

const MeasuredPose* PoseAt(const std::vector<const MeasuredPose*>& poses, size_t i) {
  return i < poses.size() ? poses[i] : nullptr;
}

// A horizontal dashed line across the plotting area at `y` (mm).
void DashedLevel(Plot& p, double y, const cv::Scalar& color) {
  const int py = p.Y(y);
  for (int x = p.area.x; x < p.area.x + p.area.width; x += 12)
    cv::line(p.image, {x, py}, {std::min(x + 7, p.area.x + p.area.width), py}, color, 2,
             cv::LINE_AA);
}

}  // namespace

Figure ErrorsFigure(const std::string& dir, const workflows::CalibrationRun& run) {
  const auto& residuals = run.validation_residuals;
  const size_t n = residuals.size();
  double lo = 1e9, hi = 1e-9;
  for (size_t i = 0; i < n; ++i) {
    lo = std::min({lo, residuals[i].norm(), run.validation_nominal_residuals[i].norm()});
    hi = std::max({hi, residuals[i].norm(), run.validation_nominal_residuals[i].norm()});
  }
  Plot p(900, 420, "Error distance per validation configuration",
         IntegerAxis(static_cast<int>(std::max<size_t>(n, 1)), 10), LogAxis(lo, hi),
         "validation configuration (number)", "mm");
  for (size_t i = 0; i < n; ++i) {
    DrawMarker(p.image, p.At(i + 1.0, run.validation_nominal_residuals[i].norm()), Marker::kCircle,
               kRed, 3);
    DrawMarker(p.image, p.At(i + 1.0, residuals[i].norm()), Marker::kSquare, kGreen, 3);
  }
  p.Legend({{Marker::kCircle, kRed, "nominal model"},
            {Marker::kSquare, kGreen, "calibrated (this fit)"}});
  return Save(dir, "errors.png", "Error distance before and after calibration", p.image);
}

Figure HistogramFigure(const std::string& dir, const std::vector<double>& distances_mm,
                       const AxisStatistics& distance) {
  const Histogram h = HistogramOf(distances_mm);
  const double top = h.bin_width_mm * h.counts.size();
  Plot p(900, 380, "Calibrated error distances (validation)", LinearAxis(0, top, 8),
         IntegerAxis(h.count_ticks.back(), 6), "error distance (mm)", "poses");
  for (size_t b = 0; b < h.counts.size(); ++b) {
    if (h.counts[b] == 0) continue;
    cv::rectangle(p.image, p.At(h.bin_width_mm * b, h.counts[b]) + cv::Point(1, 0),
                  p.At(h.bin_width_mm * (b + 1), 0) - cv::Point(1, 0), kBlue, cv::FILLED);
  }
  const auto& d = distance;
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
  return Save(dir, "histogram.png", "Residual histogram", p.image);
}

Figure VectorsFigure(const std::string& dir, const std::vector<Eigen::Vector3d>& residuals,
                     const std::vector<const MeasuredPose*>& poses) {
  const size_t n = residuals.size();
  cv::Mat image(520, 900, CV_8UC3, cv::Scalar(255, 255, 255));
  double largest = 1e-9;
  for (const auto& r : residuals) largest = std::max(largest, r.norm());
  double span = 1.0;
  for (int axis = 0; axis < 3; ++axis) {
    double a = 1e18, b = -1e18;
    for (size_t i = 0; i < n; ++i) {
      if (const auto* pose = PoseAt(poses, i)) {
        a = std::min(a, pose->target_in_world(axis));
        b = std::max(b, pose->target_in_world(axis));
      }
    }
    if (b >= a) span = std::max(span, (b - a) * 1.15);
  }
  const double magnify = 0.08 * span / largest;  // the largest residual: 8 % of the view
  Text(image, "Residual vectors (calibrated model - measured) at the validation targets", {70, 20},
       0.55);
  double px_per_mm = 1.0;
  for (int panel = 0; panel < 2; ++panel) {
    const int axis = panel == 0 ? 1 : 2;
    const char* vertical = panel == 0 ? "y" : "z";
    const cv::Rect box(70 + panel * 440, 50, 370, 370);
    double xa = 1e18, xb = -1e18, ya = 1e18, yb = -1e18;
    for (size_t i = 0; i < n; ++i) {
      if (const auto* pose = PoseAt(poses, i)) {
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
    Text(image,
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
      const auto* pose = PoseAt(poses, i);
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
  return Save(dir, "vectors.png", "Residual vectors in the work volume", image);
}

std::vector<Figure> JointFigures(const std::string& dir, int joints,
                                 const std::vector<double>& distances_mm,
                                 const std::vector<const MeasuredPose*>& poses) {
  std::vector<Figure> out;
  const size_t n = distances_mm.size();
  double top = 1e-6;
  for (double d : distances_mm) top = std::max(top, d);
  for (int j = 0; j < joints; ++j) {
    double lo = 1e18, hi = -1e18;
    for (size_t i = 0; i < n; ++i) {
      if (const auto* pose = PoseAt(poses, i); pose && j < pose->joints_rad.size()) {
        lo = std::min(lo, pose->joints_rad(j) * kDegPerRad);
        hi = std::max(hi, pose->joints_rad(j) * kDegPerRad);
      }
    }
    if (hi < lo) lo = hi = 0.0;
    Plot p(440, 260, fmt::format("Joint {}: error against angle", j + 1), LinearAxis(lo, hi, 5),
           LinearAxis(0, top, 4), fmt::format("joint {} (deg)", j + 1), "mm");
    for (size_t i = 0; i < n; ++i) {
      if (const auto* pose = PoseAt(poses, i); pose && j < pose->joints_rad.size()) {
        DrawMarker(p.image, p.At(pose->joints_rad(j) * kDegPerRad, distances_mm[i]),
                   Marker::kCircle, kBlue, 3);
      }
    }
    out.push_back(Save(dir, fmt::format("joint_{}.png", j + 1),
                       fmt::format("Error against joint {}", j + 1), p.image));
  }
  return out;
}

std::optional<Figure> ResidualMapFigure(const std::string& dir,
                                        const calibration::ResidualMapFit& map) {
  if (map.grid.empty()) return std::nullopt;
  const auto& m = map;
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
  const Marker markers[] = {Marker::kCircle, Marker::kSquare, Marker::kTriangle, Marker::kDiamond};
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
    cv::circle(p.image, p.At(m.map.length_scale, m.cv_mean_mm_with_map), 10, kInk, 1, cv::LINE_AA);
    Text(p.image, "ring: chosen", {p.area.x + p.area.width, 20}, 0.4, Align::kRight);
  }
  p.Legend(legend);
  return Save(dir, "residual_map.png", "Residual map: cross-validation curve", p.image);
}

std::optional<Figure> TemperatureFigure(const std::string& dir,
                                        const std::vector<double>& temperatures_c,
                                        const std::vector<double>& errors_mm, int validation_poses,
                                        const std::optional<LinearTrend>& trend) {
  if (temperatures_c.empty()) return std::nullopt;
  double lo = *std::min_element(temperatures_c.begin(), temperatures_c.end());
  double hi = *std::max_element(temperatures_c.begin(), temperatures_c.end());
  if (hi - lo < 0.01) {  // a steady room: a 0.1 °C wide axis around it
    lo -= 0.05;
    hi += 0.05;
  }
  double top = 1e-6;
  for (double d : errors_mm) top = std::max(top, d);
  const Axis axis = LinearAxis(lo, hi, 8);  // lo and hi rounded out to ticks
  Plot p(900, 360, "Calibrated error against the air temperature at the instrument", axis,
         LinearAxis(0, top, 5), "air temperature at the instrument (deg C)", "mm");
  for (size_t k = 0; k < temperatures_c.size(); ++k) {
    DrawMarker(p.image, p.At(temperatures_c[k], errors_mm[k]), Marker::kCircle, kBlue, 3);
  }
  std::vector<LegendEntry> legend = {{Marker::kCircle, kBlue,
                                      fmt::format("validation poses with a temperature: {} of {}",
                                                  temperatures_c.size(), validation_poses)}};
  if (trend) {
    cv::line(p.image, p.At(axis.lo, trend->intercept + trend->slope * axis.lo),
             p.At(axis.hi, trend->intercept + trend->slope * axis.hi), kRed, 2, cv::LINE_AA);
    const int decimals = std::max(DecimalsForSigma(trend->sigma_slope), 4);
    legend.push_back(
        {Marker::kLine, kRed,
         std::isfinite(trend->sigma_slope)
             ? fmt::format("least-squares trend: {:+.{}f} +/- {:.{}f} mm per deg C", trend->slope,
                           decimals, trend->sigma_slope, decimals)
             : fmt::format("least-squares trend: {:+.4f} mm per deg C", trend->slope)});
  }
  p.Legend(legend);
  return Save(dir, "temperature.png", "Error against the air temperature", p.image);
}

double DriftAxisTop(const ReportDrift& drift) {
  // Each point's reach: its difference and two of its σ.
  std::vector<double> reach;
  for (const auto& d : drift.points) {
    if (std::isfinite(d.max_mm))
      reach.push_back(d.max_mm + 2.0 * (std::isfinite(d.sigma_max_mm) ? d.sigma_max_mm : 0.0));
  }
  const double floor = std::isfinite(drift.tolerance_mm) ? 1.25 * drift.tolerance_mm : 1e-3;
  if (reach.empty()) return floor;
  std::sort(reach.begin(), reach.end());
  // One version far off (a set of another robot, a roll-back to a bad set) would press every
  // other point onto the axis: the axis stops at three times what the rest and the tolerance
  // reach, and what lies beyond is marked with its value.
  const double rest = std::max(floor, reach.size() > 1 ? reach[reach.size() - 2] : 0.0);
  return reach.back() > 5.0 * rest ? 3.0 * rest : std::max(floor, reach.back());
}

std::optional<Figure> DriftFigure(const std::string& dir, const ReportDrift& drift,
                                  const std::vector<ReportHistoryPoint>& history) {
  if (drift.points.empty()) return std::nullopt;
  // The version axis: every stored version, and this run (not stored) after the newest.
  int newest = 0;
  for (const auto& h : history) newest = std::max(newest, h.version);
  for (const auto& d : drift.points) newest = std::max(newest, d.version);
  auto x_of = [&](int version) { return version > 0 ? version : newest + 1; };
  std::set<int> xs;
  for (const auto& h : history) xs.insert(x_of(h.version));
  for (const auto& d : drift.points) xs.insert(x_of(d.version));
  Axis x;
  const int every = static_cast<int>(std::ceil(xs.size() / 15.0));  // at most ~15 labels
  int k = 0;
  for (int v : xs) {
    if (k++ % every != 0 && v != *xs.rbegin()) continue;
    x.ticks.push_back(v);
    x.labels.push_back(v == newest + 1 && newest > 0 &&
                               std::any_of(drift.points.begin(), drift.points.end(),
                                           [](const auto& d) { return d.version == 0; })
                           ? "this run"
                           : std::to_string(v));
  }
  x.lo = *xs.begin() - 0.5;
  x.hi = *xs.rbegin() + 0.5;
  const double top = DriftAxisTop(drift);
  Plot p(900, 360, "How far each version moved the arm", x, LinearAxis(0, top * 1.1, 5),
         "parameter set version", "mm");
  if (std::isfinite(drift.tolerance_mm)) DashedLevel(p, drift.tolerance_mm, kRed);
  bool any_drift = false, any_unsaved = false, any_clipped = false;
  for (const auto& d : drift.points) {
    if (!std::isfinite(d.max_mm)) continue;
    const int px = p.X(x_of(d.version));
    if (d.max_mm > top) {
      // Beyond the axis: a triangle at its top, pointing up, with the value written beside.
      const cv::Point at = p.At(x_of(d.version), top);
      DrawMarker(p.image, at, Marker::kTriangle, d.drift ? kRed : kBlue, 6);
      Text(p.image, fmt::format("{:.3g} mm", d.max_mm), {at.x + 9, at.y + 4}, 0.4);
      any_clipped = true;
      any_drift |= d.drift;
      continue;
    }
    if (std::isfinite(d.sigma_max_mm) && d.sigma_max_mm > 0.0) {
      // ±2σ of the plotted difference: a bar with caps (cut at the axis's top).
      const int y0 = p.Y(std::max(0.0, d.max_mm - 2.0 * d.sigma_max_mm));
      const int y1 = p.Y(std::min(top, d.max_mm + 2.0 * d.sigma_max_mm));
      cv::line(p.image, {px, y0}, {px, y1}, kGrey, 2, cv::LINE_AA);
      cv::line(p.image, {px - 5, y0}, {px + 5, y0}, kGrey, 2, cv::LINE_AA);
      cv::line(p.image, {px - 5, y1}, {px + 5, y1}, kGrey, 2, cv::LINE_AA);
    }
    const cv::Point at = p.At(x_of(d.version), d.max_mm);
    DrawMarker(p.image, at, d.drift ? Marker::kDiamond : Marker::kCircle, d.drift ? kRed : kBlue,
               5);
    if (d.version == 0) {
      cv::circle(p.image, at, 10, kRed, 2, cv::LINE_AA);
      any_unsaved = true;
    }
    any_drift |= d.drift;
  }
  std::vector<LegendEntry> legend = {
      {Marker::kCircle, kBlue, "largest difference against the version before, +/- 2 sigma"}};
  if (any_drift) legend.push_back({Marker::kDiamond, kRed, "drift flagged"});
  if (std::isfinite(drift.tolerance_mm))
    legend.push_back({Marker::kLine, kRed, fmt::format("tolerance {:g} mm", drift.tolerance_mm)});
  if (any_clipped) legend.push_back({Marker::kTriangle, kBlue, "beyond the axis: its value written"});
  p.Legend(legend);
  if (any_unsaved) p.Caption("red ring: this run (not stored)");
  // Made active: a row of its own under the axis title, never read as data.
  bool any = false;
  for (const auto& h : history) any |= !h.activations.empty();
  if (any) {
    const int top_y = p.RowBelow(24);
    Text(p.image, "made active:", {8, top_y + 16}, 0.4);
    bool any_by_hand = false;
    for (const auto& h : history) {
      if (h.activations.empty() || !xs.count(x_of(h.version))) continue;
      const bool by_hand = std::any_of(h.activations.begin(), h.activations.end(),
                                       [](const auto& a) { return a.by == "activate"; });
      any_by_hand |= by_hand;
      const cv::Point tip(p.X(x_of(h.version)), top_y + 5);
      const std::vector<cv::Point> triangle = {tip, tip + cv::Point(-6, 11),
                                               tip + cv::Point(6, 11)};
      cv::fillConvexPoly(p.image, triangle, by_hand ? kPurple : kGreen, cv::LINE_AA);
      if (h.active) cv::circle(p.image, tip + cv::Point(0, 7), 10, kInk, 1, cv::LINE_AA);
    }
    p.Note(std::string("triangle: the version was made active (ringed: active now)") +
           (any_by_hand ? "; purple: by armsig activate" : ""));
  }
  p.Note(
      fmt::format("each point: the largest |dx| over {} configurations spread over the work "
                  "volume, the two sets' positions rigidly aligned",
                  drift.configurations));
  return Save(dir, "drift.png", "Drift: how far each version moved the arm", p.image);
}

}  // namespace armsig::report
