// The pieces the HTML pages draw with (the recalibration report, the ISO 9283 report):
// axes with round ticks, a plotting area, markers and legends drawn with OpenCV, PNG
// figures saved beside the page and embedded in it as data URIs, numbers for tables, and
// the pages' one A4 print stylesheet.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <opencv2/core.hpp>
#include <string>
#include <utility>
#include <vector>

#include "report/html.h"

namespace armsig::report {

// Axis ticks: steps of 1, 2 or 5 × 10^k covering [lo, hi] with about `max_ticks` steps.
std::vector<double> NiceTicks(double lo, double hi, int max_ticks);
// Count ticks 0, s, 2s, … (s = 1, 2, 5, 10, …) up to the first ≥ `largest`.
std::vector<int> IntegerTicks(int largest, int max_ticks = 6);
// 1, 2 or 5 × 10^k: the smallest not below `raw`, and the largest not above `value`.
double NiceStep(double raw);
double NiceBelow(double value);

namespace figures {

inline const cv::Scalar kInk(40, 40, 40), kGrid(228, 228, 228), kRed(60, 60, 220),
    kGreen(70, 150, 40), kBlue(190, 110, 30), kGrey(160, 160, 160), kOrange(0, 140, 240),
    kPurple(150, 60, 140), kTeal(140, 140, 0);
inline constexpr double kDegPerRad = 180.0 / 3.14159265358979323846;

enum class Align { kLeft, kCenter, kRight };
void Text(cv::Mat& image, const std::string& text, cv::Point at, double scale = 0.4,
          Align align = Align::kLeft, const cv::Scalar& color = kInk);
int TextWidth(const std::string& text, double scale = 0.4);

enum class Marker { kCircle, kSquare, kTriangle, kDiamond, kLine };
void DrawMarker(cv::Mat& image, cv::Point c, Marker marker, const cv::Scalar& color, int r = 4);

struct LegendEntry {
  Marker marker;
  cv::Scalar color;
  std::string text;
};

struct Axis {
  double lo = 0.0, hi = 1.0;
  bool log = false;
  std::vector<double> ticks;
  std::vector<std::string> labels;
};

// A tick label with as many decimals as the step needs (never "-0.00").
std::string TickLabel(double value, double step);
Axis LinearAxis(double lo, double hi, int max_ticks);
Axis IntegerAxis(int largest, int max_ticks);
Axis LogAxis(double lo, double hi);

// A plotting area with ticked axes. The title (and a caption at its right) and the
// legend sit above the area, the axis titles beside and below it, notes below those: the
// image grows to give each its own room, so no text covers data or another text.
class Plot {
 public:
  Plot(int width, int height, const std::string& title, Axis x, Axis y, const std::string& xlabel,
       const std::string& ylabel);

  int X(double x) const {
    return area.x + static_cast<int>(std::lround(Fraction(x_, x) * area.width));
  }
  int Y(double y) const {
    return area.y + area.height - static_cast<int>(std::lround(Fraction(y_, y) * area.height));
  }
  cv::Point At(double x, double y) const { return {X(x), Y(y)}; }

  // Rows above the plotting area, as many as the entries need within the image's width
  // (the image grows at the top for each row after the first; everything drawn so far
  // moves down with the area).
  void Legend(const std::vector<LegendEntry>& entries);
  // A short text at the right of the title row ("ring: the chosen one").
  void Caption(const std::string& text);
  // A row of its own below the axis title, `height` pixels tall (the image grows at the
  // bottom); returns the y of its top. Note: a text in such rows, wrapped at words to the
  // image's width.
  int RowBelow(int height);
  void Note(const std::string& text);

  cv::Mat image;
  cv::Rect area;

 private:
  void DrawTitleRow();
  std::string title_, ylabel_, caption_;
  static double Fraction(const Axis& a, double v) {
    if (a.log) {
      return (std::log10(std::max(v, 1e-12)) - std::log10(a.lo)) /
             (std::log10(a.hi) - std::log10(a.lo));
    }
    return (v - a.lo) / (a.hi - a.lo);
  }
  Axis x_, y_;
};

// A PNG figure: saved as DIR/file and kept as base64 for the page.
struct Figure {
  std::string file, title, png_base64;
};
std::string Base64(const std::vector<uchar>& data);
// Writes DIR/file (atomically); throws when the image cannot be encoded or written.
Figure Save(const std::string& dir, const std::string& file, const std::string& title,
            const cv::Mat& image);
// <figure> with the PNG embedded as a data URI and the title as caption.
Html FigureHtml(const Figure& f);

// A number for a table cell ("—" when not finite, never "-0.0000").
Html Num(double v, int decimals = 4);
// Now, ISO-8601 UTC to the second.
std::string Now();

inline constexpr const char* kPageStyle = R"css(
body{font-family:sans-serif;margin:2em;max-width:960px;color:#222}
h1{font-size:1.5em}h2{font-size:1.2em;margin-top:1.6em;break-after:avoid;page-break-after:avoid}
table{border-collapse:collapse;margin:0.8em 0}
td,th{border:1px solid #ccc;padding:3px 8px;text-align:left;vertical-align:top}
th{background:#f4f4f4}
td.num,th.num{text-align:right;white-space:nowrap;font-variant-numeric:tabular-nums}
th.num.wrap{white-space:normal;max-width:7em}
.nowrap{white-space:nowrap}
table.header th{white-space:nowrap}
.bad{color:#b00}.good{color:#070}.note{font-style:italic}
.banner{font-size:1.25em;padding:0.5em 0.8em;border:2px solid;margin:0.6em 0}
.banner.good{background:#eef8ee}.banner.bad{background:#fbecec}
.banner.warn{color:#8a5300;background:#fff4e0}
figure{margin:1em 0;break-inside:avoid;page-break-inside:avoid}
figure img{max-width:100%;border:1px solid #eee;display:block}
figcaption{font-size:0.85em;color:#555}
.joints{display:flex;flex-wrap:wrap;gap:8px}.joints figure{margin:0.3em 0}
@page{size:A4;margin:14mm}
@media print{
  body{margin:0;max-width:none;font-size:9pt}
  figure img{max-width:100%;height:auto}
  table{break-inside:avoid;page-break-inside:avoid}
  .joints figure{width:48%}
}
)css";

}  // namespace figures
}  // namespace armsig::report
