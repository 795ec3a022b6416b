#include "report/figures.h"

#include <fmt/chrono.h>
#include <fmt/format.h>
#include <png.h>

#include <algorithm>
#include <chrono>
#include <cstdint>
#include <opencv2/imgproc.hpp>
#include <stdexcept>

#include "io/atomic_file.h"

namespace armsig::report {

// 1, 2 or 5 × 10^k, the smallest not below `raw`.
double NiceStep(double raw) {
  const double magnitude = std::pow(10.0, std::floor(std::log10(raw)));
  for (double m : {1.0, 2.0, 5.0}) {
    if (m * magnitude >= raw * (1 - 1e-9)) return m * magnitude;
  }
  return 10.0 * magnitude;
}

// 1, 2 or 5 × 10^k, the largest not above `value`.
double NiceBelow(double value) {
  const double magnitude = std::pow(10.0, std::floor(std::log10(value)));
  for (double m : {5.0, 2.0}) {
    if (m * magnitude <= value * (1 + 1e-9)) return m * magnitude;
  }
  return magnitude;
}

std::vector<double> NiceTicks(double lo, double hi, int max_ticks) {
  if (!(hi > lo)) hi = lo + 1.0;
  const double step = NiceStep((hi - lo) / std::max(max_ticks, 1));
  const double first = std::floor(lo / step + 1e-9), last = std::ceil(hi / step - 1e-9);
  std::vector<double> ticks;
  for (double k = first; k <= last; k += 1.0) ticks.push_back(k * step);
  return ticks;
}

std::vector<int> IntegerTicks(int largest, int max_ticks) {
  largest = std::max(largest, 1);
  const int step = std::max(1, static_cast<int>(std::lround(NiceStep(static_cast<double>(largest) /
                                                                     std::max(max_ticks, 1)))));
  std::vector<int> ticks;
  for (int t = 0;; t += step) {
    ticks.push_back(t);
    if (t >= largest) break;
  }
  return ticks;
}

namespace figures {

namespace {
constexpr int kFont = cv::FONT_HERSHEY_SIMPLEX;
}  // namespace

void Text(cv::Mat& image, const std::string& text, cv::Point at, double scale, Align align,
          const cv::Scalar& color) {
  int baseline = 0;
  const cv::Size size = cv::getTextSize(text, kFont, scale, 1, &baseline);
  if (align == Align::kCenter) at.x -= size.width / 2;
  if (align == Align::kRight) at.x -= size.width;
  cv::putText(image, text, at, kFont, scale, color, 1, cv::LINE_AA);
}

int TextWidth(const std::string& text, double scale) {
  int baseline = 0;
  return cv::getTextSize(text, kFont, scale, 1, &baseline).width;
}

void DrawMarker(cv::Mat& image, cv::Point c, Marker marker, const cv::Scalar& color, int r) {
  switch (marker) {
    case Marker::kCircle:
      cv::circle(image, c, r, color, cv::FILLED, cv::LINE_AA);
      break;
    case Marker::kSquare:
      cv::rectangle(image, c - cv::Point(r, r), c + cv::Point(r, r), color, cv::FILLED);
      break;
    case Marker::kTriangle: {
      const std::vector<cv::Point> p = {c + cv::Point(0, -r - 1), c + cv::Point(r + 1, r),
                                        c + cv::Point(-r - 1, r)};
      cv::fillConvexPoly(image, p, color, cv::LINE_AA);
      break;
    }
    case Marker::kDiamond: {
      const std::vector<cv::Point> p = {c + cv::Point(0, -r - 1), c + cv::Point(r + 1, 0),
                                        c + cv::Point(0, r + 1), c + cv::Point(-r - 1, 0)};
      cv::fillConvexPoly(image, p, color, cv::LINE_AA);
      break;
    }
    case Marker::kLine:
      cv::line(image, c - cv::Point(2 * r, 0), c + cv::Point(2 * r, 0), color, 2, cv::LINE_AA);
      break;
  }
}

std::string TickLabel(double value, double step) {
  const int decimals = std::max(0, static_cast<int>(-std::floor(std::log10(step) + 1e-9)));
  if (std::abs(value) < step * 1e-6) value = 0.0;  // no "-0.00"
  return fmt::format("{:.{}f}", value, decimals);
}

Axis LinearAxis(double lo, double hi, int max_ticks) {
  Axis a;
  a.ticks = NiceTicks(lo, hi, max_ticks);
  a.lo = a.ticks.front();
  a.hi = a.ticks.back();
  const double step = a.ticks.size() > 1 ? a.ticks[1] - a.ticks[0] : 1.0;
  for (double t : a.ticks) a.labels.push_back(TickLabel(t, step));
  return a;
}

Axis IntegerAxis(int largest, int max_ticks) {
  Axis a;
  for (int t : IntegerTicks(largest, max_ticks)) {
    a.ticks.push_back(t);
    a.labels.push_back(std::to_string(t));
  }
  a.lo = a.ticks.front();
  a.hi = a.ticks.back();
  return a;
}

Axis LogAxis(double lo, double hi) {
  Axis a;
  a.log = true;
  const int first = static_cast<int>(std::floor(std::log10(std::max(lo, 1e-6))));
  const int last = std::max(first + 1, static_cast<int>(std::ceil(std::log10(std::max(hi, 1e-6)))));
  for (int d = first; d <= last; ++d) {
    a.ticks.push_back(std::pow(10.0, d));
    a.labels.push_back(fmt::format("{:g}", std::pow(10.0, d)));
  }
  a.lo = a.ticks.front();
  a.hi = a.ticks.back();
  return a;
}

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

// An 8-bit BGR image as PNG bytes, by libpng (OpenCV's codec library would bring some 120
// shared libraries — GDAL, Poppler, HDF5 — into every armsig process for this one call).
std::vector<uchar> EncodePng(const cv::Mat& image, const std::string& file) {
  if (image.type() != CV_8UC3 || image.empty()) throw std::runtime_error("cannot encode " + file);
  png_image png{};
  png.version = PNG_IMAGE_VERSION;
  png.width = static_cast<png_uint_32>(image.cols);
  png.height = static_cast<png_uint_32>(image.rows);
  png.format = PNG_FORMAT_BGR;
  const auto stride = static_cast<png_int_32>(image.step[0]);
  png_alloc_size_t size = 0;
  if (!png_image_write_to_memory(&png, nullptr, &size, 0, image.data, stride, nullptr))
    throw std::runtime_error("cannot encode " + file + ": " + png.message);
  std::vector<uchar> out(size);
  if (!png_image_write_to_memory(&png, out.data(), &size, 0, image.data, stride, nullptr))
    throw std::runtime_error("cannot encode " + file + ": " + png.message);
  out.resize(size);
  return out;
}

Figure Save(const std::string& dir, const std::string& file, const std::string& title,
            const cv::Mat& image) {
  const std::vector<uchar> png = EncodePng(image, file);
  io::WriteFileAtomically(dir + "/" + file, std::string(png.begin(), png.end()));
  return {file, title, Base64(png)};
}

Html FigureHtml(const Figure& f) {
  // The base64 text is the program's own encoding of its PNG: trusted markup.
  return HtmlFormat(
      "<figure><img alt=\"{}\" src=\"data:image/png;base64,{}\"><figcaption>{}</figcaption>"
      "</figure>\n",
      f.title, Html::Trusted(f.png_base64), f.title);
}

Html Num(double v, int decimals) {
  if (std::abs(v) < 0.5 * std::pow(10.0, -decimals)) v = 0.0;  // no "-0.0000"
  return std::isfinite(v) ? Html::Text(fmt::format("{:.{}f}", v, decimals)) : Html("&mdash;");
}

std::string Now() {
  return fmt::format("{:%Y-%m-%dT%H:%M:%SZ}",
                     std::chrono::floor<std::chrono::seconds>(std::chrono::system_clock::now()));
}

Plot::Plot(int width, int height, const std::string& title, Axis x, Axis y,
           const std::string& xlabel, const std::string& ylabel)
    : image(height, width, CV_8UC3, cv::Scalar(255, 255, 255)),
      area(70, 56, width - 70 - 20, height - 56 - 52),
      title_(title),
      ylabel_(ylabel),
      x_(std::move(x)),
      y_(std::move(y)) {
  DrawTitleRow();
  Text(image, ylabel_, {8, area.y - 10});
  Text(image, xlabel, {area.x + area.width / 2, height - 10}, 0.45, Align::kCenter);
  for (size_t k = 0; k < x_.ticks.size(); ++k) {
    const int px = X(x_.ticks[k]);
    cv::line(image, {px, area.y}, {px, area.y + area.height}, kGrid);
    cv::line(image, {px, area.y + area.height}, {px, area.y + area.height + 4}, kInk);
    Text(image, x_.labels[k], {px, area.y + area.height + 18}, 0.4, Align::kCenter);
  }
  for (size_t k = 0; k < y_.ticks.size(); ++k) {
    const int py = Y(y_.ticks[k]);
    cv::line(image, {area.x, py}, {area.x + area.width, py}, kGrid);
    cv::line(image, {area.x - 4, py}, {area.x, py}, kInk);
    Text(image, y_.labels[k], {area.x - 7, py + 4}, 0.4, Align::kRight);
  }
  cv::rectangle(image, area, kInk);
}

namespace {
constexpr int kTitleBaseline = 20, kLegendRow = 18, kNoteRow = 18;
}  // namespace

void Plot::DrawTitleRow() {
  Text(image, title_, {area.x, kTitleBaseline}, 0.55);
  if (!caption_.empty())
    Text(image, caption_, {area.x + area.width, kTitleBaseline}, 0.4, Align::kRight);
}

void Plot::Caption(const std::string& text) {
  caption_ = text;
  Text(image, caption_, {area.x + area.width, kTitleBaseline}, 0.4, Align::kRight);
}

void Plot::Legend(const std::vector<LegendEntry>& entries) {
  // Rows of entries, each within the image (an entry wider than a row gets one of its own).
  const int left = area.x + 10, right = image.cols - 10;
  std::vector<std::vector<const LegendEntry*>> rows(1);
  int x = left;
  for (const auto& e : entries) {
    const int width = 16 + TextWidth(e.text) + 22;
    if (x > left && x + width - 22 > right) {
      rows.emplace_back();
      x = left;
    }
    rows.back().push_back(&e);
    x += width;
  }
  const int extra = kLegendRow * (static_cast<int>(rows.size()) - 1);
  if (extra > 0) {
    // Room above: everything drawn so far moves down with the area; the title row is
    // drawn again at the top.
    cv::copyMakeBorder(image, image, extra, 0, 0, 0, cv::BORDER_CONSTANT,
                       cv::Scalar(255, 255, 255));
    area.y += extra;
    cv::rectangle(image, cv::Rect(0, 0, image.cols, kTitleBaseline + extra + 6),
                  cv::Scalar(255, 255, 255), cv::FILLED);
    DrawTitleRow();
  }
  for (size_t r = 0; r < rows.size(); ++r) {
    cv::Point at(left, area.y - 14 - kLegendRow * static_cast<int>(rows.size() - 1 - r));
    for (const auto* e : rows[r]) {
      DrawMarker(image, at + cv::Point(5, -4), e->marker, e->color);
      Text(image, e->text, at + cv::Point(16, 0));
      at.x += 16 + TextWidth(e->text) + 22;
    }
  }
}

int Plot::RowBelow(int height) {
  const int top = image.rows;
  cv::copyMakeBorder(image, image, 0, height, 0, 0, cv::BORDER_CONSTANT, cv::Scalar(255, 255, 255));
  return top;
}

void Plot::Note(const std::string& text) {
  // Words to a row while they fit between the area's left edge and the image's right.
  const int width = image.cols - 10 - area.x;
  std::string row;
  auto flush = [&] {
    const int top = RowBelow(kNoteRow);
    Text(image, row, {area.x, top + kNoteRow - 6}, 0.4);
    row.clear();
  };
  size_t at = 0;
  while (at < text.size()) {
    size_t end = text.find(' ', at);
    if (end == std::string::npos) end = text.size();
    const std::string word = text.substr(at, end - at);
    if (!row.empty() && TextWidth(row + " " + word) > width) flush();
    row += (row.empty() ? "" : " ") + word;
    at = end + 1;
  }
  if (!row.empty()) flush();
}

}  // namespace figures
}  // namespace armsig::report
