#include "workflows/report.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "io/atomic_file.h"

namespace armsig::workflows {

namespace {

const cv::Scalar kInk(40, 40, 40), kGrid(225, 225, 225), kRed(60, 60, 220), kGreen(80, 160, 40),
    kBlue(200, 120, 30), kGrey(170, 170, 170);

std::string Base64(const std::vector<uchar>& data) {
  static const char* table = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  out.reserve((data.size() + 2) / 3 * 4);
  for (size_t i = 0; i < data.size(); i += 3) {
    const uint32_t b = (data[i] << 16) | ((i + 1 < data.size() ? data[i + 1] : 0) << 8) |
                       (i + 2 < data.size() ? data[i + 2] : 0);
    out += table[(b >> 18) & 63];
    out += table[(b >> 12) & 63];
    out += i + 1 < data.size() ? table[(b >> 6) & 63] : '=';
    out += i + 2 < data.size() ? table[b & 63] : '=';
  }
  return out;
}

std::string Html(const std::string& text) {
  std::string out;
  for (char c : text) {
    if (c == '<')
      out += "&lt;";
    else if (c == '>')
      out += "&gt;";
    else if (c == '&')
      out += "&amp;";
    else if (c == '"')
      out += "&quot;";
    else if (c == '\'')
      out += "&#39;";
    else
      out += c;
  }
  return out;
}

// A plotting area with axes; maps data to pixels.
struct Plot {
  cv::Mat image;
  cv::Rect area;
  double x0, x1, y0, y1;
  bool log_y = false;

  Plot(int w, int h, double xa, double xb, double ya, double yb, bool log, const std::string& title,
       const std::string& xlabel, const std::string& ylabel)
      : image(h, w, CV_8UC3, cv::Scalar(255, 255, 255)),
        area(80, 40, w - 110, h - 100),
        x0(xa),
        x1(xb),
        log_y(log) {
    y0 = log ? std::log10(ya) : ya;
    y1 = log ? std::log10(yb) : yb;
    if (x1 <= x0) x1 = x0 + 1;
    if (y1 <= y0) y1 = y0 + 1;
    cv::putText(image, title, {area.x, 25}, cv::FONT_HERSHEY_SIMPLEX, 0.6, kInk, 1, cv::LINE_AA);
    cv::putText(image, xlabel, {area.x + area.width / 2 - 60, h - 15}, cv::FONT_HERSHEY_SIMPLEX,
                0.45, kInk, 1, cv::LINE_AA);
    cv::putText(image, ylabel, {5, area.y - 10}, cv::FONT_HERSHEY_SIMPLEX, 0.45, kInk, 1,
                cv::LINE_AA);
    // Y ticks: decades on a log axis, 5 steps otherwise.
    if (log) {
      for (int d = static_cast<int>(std::floor(y0)); d <= static_cast<int>(std::ceil(y1)); ++d) {
        if (d < y0 - 1e-9 || d > y1 + 1e-9) continue;
        const int py = Y(std::pow(10.0, d));
        cv::line(image, {area.x, py}, {area.x + area.width, py}, kGrid);
        cv::putText(image, fmt::format("{:g}", std::pow(10.0, d)), {10, py + 4},
                    cv::FONT_HERSHEY_SIMPLEX, 0.4, kInk, 1, cv::LINE_AA);
      }
    } else {
      for (int k = 0; k <= 5; ++k) {
        const double v = y0 + (y1 - y0) * k / 5;
        const int py = Y(v);
        cv::line(image, {area.x, py}, {area.x + area.width, py}, kGrid);
        cv::putText(image, fmt::format("{:.3g}", v), {10, py + 4}, cv::FONT_HERSHEY_SIMPLEX, 0.4,
                    kInk, 1, cv::LINE_AA);
      }
    }
    for (int k = 0; k <= 5; ++k) {
      const double v = x0 + (x1 - x0) * k / 5;
      const int px = X(v);
      cv::putText(image, fmt::format("{:.3g}", v), {px - 15, area.y + area.height + 18},
                  cv::FONT_HERSHEY_SIMPLEX, 0.4, kInk, 1, cv::LINE_AA);
    }
    cv::rectangle(image, area, kInk);
  }
  int X(double x) const { return area.x + static_cast<int>((x - x0) / (x1 - x0) * area.width); }
  int Y(double y) const {
    const double v = log_y ? std::log10(std::max(y, 1e-12)) : y;
    return area.y + area.height - static_cast<int>((v - y0) / (y1 - y0) * area.height);
  }
  void Legend(int row, const cv::Scalar& color, const std::string& text) {
    const cv::Point at(area.x + 15, area.y + area.height - 50 + 20 * row);
    cv::rectangle(image, at + cv::Point(-8, -12), at + cv::Point(215, 8), cv::Scalar(255, 255, 255),
                  cv::FILLED);
    cv::circle(image, at, 5, color, cv::FILLED, cv::LINE_AA);
    cv::putText(image, text, at + cv::Point(12, 5), cv::FONT_HERSHEY_SIMPLEX, 0.45, kInk, 1,
                cv::LINE_AA);
  }
};

struct Figure {
  std::string file, title, png_base64;
};

Figure Save(const std::string& dir, const std::string& file, const std::string& title,
            const cv::Mat& image) {
  std::vector<uchar> png;
  cv::imencode(".png", image, png);
  io::WriteFileAtomically(dir + "/" + file, std::string(png.begin(), png.end()));
  return {file, title, Base64(png)};
}

}  // namespace

std::string WriteReport(const std::string& dir, const ReportInput& in) {
  std::filesystem::create_directories(dir);
  const auto& run = *in.run;
  const auto& model = *in.model;
  std::vector<Figure> figures;

  // 1. Error distance per validation configuration, nominal and calibrated (log scale).
  {
    const size_t n = run.validation_residuals.size();
    double lo = 1e9, hi = 1e-9;
    for (size_t i = 0; i < n; ++i) {
      lo = std::min(
          {lo, run.validation_residuals[i].norm(), run.validation_nominal_residuals[i].norm()});
      hi = std::max(
          {hi, run.validation_residuals[i].norm(), run.validation_nominal_residuals[i].norm()});
    }
    lo = std::pow(10.0, std::floor(std::log10(std::max(lo, 1e-4))));
    hi = std::pow(10.0, std::ceil(std::log10(std::max(hi, 1e-3))));
    Plot p(900, 420, 0, static_cast<double>(std::max<size_t>(n, 1)), lo, hi, true,
           "Error distance per validation configuration", "configuration", "mm");
    for (size_t i = 0; i < n; ++i) {
      cv::circle(p.image, {p.X(i + 0.5), p.Y(run.validation_nominal_residuals[i].norm())}, 3, kRed,
                 cv::FILLED, cv::LINE_AA);
      cv::circle(p.image, {p.X(i + 0.5), p.Y(run.validation_residuals[i].norm())}, 3, kGreen,
                 cv::FILLED, cv::LINE_AA);
    }
    p.Legend(0, kRed, "nominal model");
    p.Legend(1, kGreen, "calibrated (this fit)");
    figures.push_back(
        Save(dir, "errors.png", "Error distance before and after calibration", p.image));
  }
  // 2. Histogram of the calibrated validation errors.
  {
    std::vector<double> d;
    for (const auto& r : run.validation_residuals) d.push_back(r.norm());
    const double top = d.empty() ? 1.0 : *std::max_element(d.begin(), d.end()) * 1.05;
    const int bins = 20;
    std::vector<int> count(bins, 0);
    for (double v : d) count[std::min(bins - 1, static_cast<int>(v / top * bins))]++;
    const int most = std::max(1, *std::max_element(count.begin(), count.end()));
    Plot p(900, 380, 0, top, 0, most * 1.1, false, "Calibrated error distances (validation)", "mm",
           "count");
    for (int b = 0; b < bins; ++b) {
      cv::rectangle(p.image, cv::Point(p.X(top * b / bins) + 1, p.Y(count[b])),
                    cv::Point(p.X(top * (b + 1) / bins) - 1, p.Y(0)), kBlue, cv::FILLED);
    }
    figures.push_back(Save(dir, "histogram.png", "Residual histogram", p.image));
  }
  // 3. Residual vectors in the work volume: top view (x, y) and side view (x, z).
  {
    cv::Mat image(460, 900, CV_8UC3, cv::Scalar(255, 255, 255));
    double largest = 1e-9;
    for (const auto& r : run.validation_residuals) largest = std::max(largest, r.norm());
    for (int panel = 0; panel < 2; ++panel) {
      const int axis = panel == 0 ? 1 : 2;
      double xa = 1e18, xb = -1e18, ya = 1e18, yb = -1e18;
      for (const auto& pose : in.validation) {
        xa = std::min(xa, pose.target_in_world.x());
        xb = std::max(xb, pose.target_in_world.x());
        ya = std::min(ya, pose.target_in_world(axis));
        yb = std::max(yb, pose.target_in_world(axis));
      }
      const double span = std::max({xb - xa, yb - ya, 1.0});
      const cv::Rect box(30 + panel * 440, 50, 400, 380);
      cv::rectangle(image, box, kInk);
      cv::putText(image, panel == 0 ? "top view (x, y)" : "side view (x, z)", {box.x, 40},
                  cv::FONT_HERSHEY_SIMPLEX, 0.5, kInk, 1, cv::LINE_AA);
      const double scale = 0.08 * span / largest;  // the largest residual draws as 8 % of the view
      auto px = [&](double x, double y) {
        return cv::Point(
            box.x + 10 + static_cast<int>((x - xa) / span * (box.width - 20)),
            box.y + box.height - 10 - static_cast<int>((y - ya) / span * (box.height - 20)));
      };
      for (size_t i = 0; i < in.validation.size() && i < run.validation_residuals.size(); ++i) {
        const Eigen::Vector3d& x = in.validation[i].target_in_world;
        const Eigen::Vector3d tip = x + scale * run.validation_residuals[i];
        cv::circle(image, px(x.x(), x(axis)), 2, kGrey, cv::FILLED, cv::LINE_AA);
        cv::arrowedLine(image, px(x.x(), x(axis)), px(tip.x(), tip(axis)), kRed, 1, cv::LINE_AA, 0,
                        0.25);
      }
    }
    cv::putText(image,
                fmt::format("Residual vectors (calibrated model - measured), arrows x{:.0f}: the "
                            "largest is {:.3f} mm",
                            0.08 * 1000 / largest, largest),
                {30, 20}, cv::FONT_HERSHEY_SIMPLEX, 0.5, kInk, 1, cv::LINE_AA);
    figures.push_back(Save(dir, "vectors.png", "Residual vectors in the work volume", image));
  }
  // 4. Drift: validation error of every stored version.
  {
    std::vector<ReportHistoryPoint> h = in.history;
    double top = 1e-6;
    for (const auto& p : h) top = std::max(top, p.validation_mean_mm);
    Plot p(900, 360, 0.5, h.size() + 0.5, 0, top * 1.2, false,
           "Validation mean error of every version", "version", "mm");
    cv::Point last(-1, -1);
    for (size_t i = 0; i < h.size(); ++i) {
      const cv::Point at(p.X(i + 1.0), p.Y(h[i].validation_mean_mm));
      if (last.x >= 0) cv::line(p.image, last, at, kBlue, 2, cv::LINE_AA);
      cv::circle(p.image, at, 5, h[i].version == in.version ? kGreen : kBlue, cv::FILLED,
                 cv::LINE_AA);
      cv::putText(p.image, "v" + std::to_string(h[i].version), at + cv::Point(-8, -10),
                  cv::FONT_HERSHEY_SIMPLEX, 0.4, kInk, 1, cv::LINE_AA);
      last = at;
    }
    figures.push_back(Save(dir, "drift.png", "Drift against earlier versions", p.image));
  }

  // The page.
  const auto names = model.ParameterNames();
  std::string html =
      "<!doctype html>\n<html><head><meta charset=\"utf-8\"><title>armsig report: " +
      Html(in.robot) +
      "</title>\n<style>body{font-family:sans-serif;margin:2em;max-width:960px;color:#222}"
      "table{border-collapse:collapse;margin:1em 0}td,th{border:1px solid #ccc;padding:3px "
      "8px;text-align:right}"
      "th{background:#f4f4f4}.bad{color:#b00}.good{color:#070}img{max-width:100%;border:1px solid "
      "#eee}</style>\n"
      "</head><body>\n";
  html += "<h1>Arm signature of " + Html(in.robot) + "</h1>\n";
  html += "<p class=\"" + std::string(in.version > 0 ? "good" : "bad") + "\"><b>" +
          Html(in.decision) + "</b></p>\n<ul>\n";
  for (const auto& g : in.gates) html += "<li>" + Html(g) + "</li>\n";
  html += "</ul>\n";
  const auto v = calibration::Summarise(calibration::Distances(run.validation_residuals));
  const auto vn = calibration::Summarise(calibration::Distances(run.validation_nominal_residuals));
  html += fmt::format(
      "<table><tr><th>error distance "
      "(mm)</th><th>poses</th><th>mean</th><th>max</th><th>rms</th></tr>"
      "<tr><td>nominal, fit</td><td>{}</td><td>{:.3f}</td><td>{:.3f}</td><td>{:.3f}</td></tr>"
      "<tr><td>calibrated, fit</td><td>{}</td><td>{:.3f}</td><td>{:.3f}</td><td>{:.3f}</td></tr>"
      "<tr><td>nominal, "
      "validation</td><td>{}</td><td>{:.3f}</td><td>{:.3f}</td><td>{:.3f}</td></tr>"
      "<tr><td>calibrated, "
      "validation</td><td>{}</td><td>{:.3f}</td><td>{:.3f}</td><td>{:.3f}</td></tr></table>\n",
      run.estimate.nominal.poses, run.estimate.nominal.mean_mm, run.estimate.nominal.max_mm,
      run.estimate.nominal.rms_mm, run.estimate.fit.poses, run.estimate.fit.mean_mm,
      run.estimate.fit.max_mm, run.estimate.fit.rms_mm, vn.poses, vn.mean_mm, vn.max_mm, vn.rms_mm,
      v.poses, v.mean_mm, v.max_mm, v.rms_mm);
  for (const auto& f : figures) {
    html += "<h2>" + Html(f.title) + "</h2>\n<img class=\"figure\" alt=\"" + Html(f.title) +
            "\" src=\"data:image/png;base64," + f.png_base64 + "\">\n";
  }
  // Parameter table in the paper's layout, with sigmas.
  const int n = model.num_joints();
  std::vector<char> identified(model.num_parameters(), 0);
  for (int k : run.estimate.identifiability.identified) identified[k] = 1;
  html += "<h2>Parameters (paper's Table 1-3 layout; value ± sigma)</h2>\n<table><tr><th>i =</th>";
  for (int i = 1; i <= n + 1; ++i) html += "<th>" + std::to_string(i) + "</th>";
  html += "</tr>\n";
  const char* rows[6] = {"a (mm)",
                         "b (mm)",
                         "c (mm)",
                         "&alpha; (1e-3 rad)",
                         "&beta; (1e-3 rad)",
                         "&gamma; (1e-3 rad)"};
  for (int r = 0; r < 6; ++r) {
    html += std::string("<tr><th>") + rows[r] + "</th>";
    for (int i = 0; i <= n; ++i) {
      const int k = i < n ? 6 * i + r : (r < 3 ? 6 * n + r : -1);
      if (k < 0) {
        html += "<td></td>";
        continue;
      }
      const double scale = r < 3 ? 1.0 : 1e3;
      html += identified[k]
                  ? fmt::format("<td>{:.3f} ± {:.3f}</td>", run.estimate.params(k) * scale,
                                run.estimate.sigmas(k) * scale)
                  : "<td>&mdash;</td>";
    }
    html += "</tr>\n";
  }
  html += "</table>\n";
  for (int k = model.num_geometric(); k < model.num_parameters(); ++k) {
    html += identified[k]
                ? fmt::format("<p>{} = {:.3f} ± {:.3f} × 10<sup>-3</sup> rad</p>\n", Html(names[k]),
                              run.estimate.params(k) * 1e3, run.estimate.sigmas(k) * 1e3)
                : "<p>" + Html(names[k]) + ": not identified</p>\n";
  }
  if (!in.changes.empty()) {
    html += std::string("<h2>Change against the previous version") +
            (in.drift ? " <span class=\"bad\">(drift)</span>" : "") +
            "</h2>\n<table><tr><th>parameter</th><th>change</th><th>in sigmas</th></tr>\n";
    for (const auto& c : in.changes) {
      if (c.z == 0.0) continue;
      const bool mm = model.UnitOf(c.parameter) == calibration::ParameterUnit::kMm;
      html += fmt::format("<tr><td>{}</td><td>{:.4f} {}</td><td class=\"{}\">{:.1f}</td></tr>\n",
                          Html(names[c.parameter]), mm ? c.change : c.change * 1e3, mm ? "mm" : "mrad",
                          std::abs(c.z) > 5 ? "bad" : "", c.z);
    }
    html += "</table>\n";
  }
  html += "</body></html>\n";
  const std::string path = dir + "/index.html";
  io::WriteFileAtomically(path, html);
  return path;
}

}  // namespace armsig::workflows
