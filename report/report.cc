#include "report/report.h"

#include <spdlog/spdlog.h>

#include <chrono>
#include <filesystem>
#include <stdexcept>

#include "io/atomic_file.h"
#include "report/html.h"
#include "report/report_figures.h"
#include "report/report_page.h"

namespace armsig::report {

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
  // A figure that would be empty (no temperatures, no residual map, nothing to compare)
  // is not drawn: its section says why instead. The old file of an earlier report in the
  // same folder goes with it.
  auto drop = [&](const char* file) {
    std::error_code ignored;
    std::filesystem::remove(std::filesystem::path(dir) / file, ignored);
  };
  const ReportData data(in);
  const workflows::CalibrationRun& run = data.run;
  const figures::Figure errors = ErrorsFigure(dir, run);
  const figures::Figure histogram = HistogramFigure(dir, data.distances, data.stats[3]);
  const figures::Figure vectors = VectorsFigure(dir, run.validation_residuals, data.poses);
  const auto drift = DriftFigure(dir, in.drift_history, in.history);
  if (!drift) drop("drift.png");
  const auto joints = JointFigures(dir, data.model.num_joints(), data.distances, data.poses);
  // The map's cross-validation curve only when the map is used: a map left out is one
  // sentence (its decision), not a chart a reader must work out is not in effect.
  std::optional<figures::Figure> map;
  if (run.map_used()) map = ResidualMapFigure(dir, *run.residual_map);
  if (!map) drop("residual_map.png");
  const auto temperature = TemperatureFigure(dir, data.temperatures, data.temperature_errors,
                                             static_cast<int>(data.distances.size()), data.trend);
  if (!temperature) drop("temperature.png");

  Html html = PageStart(in) + HeaderSection(data) + ErrorSection(data, map);
  html += Html("<h2>Error per validation configuration</h2>\n") + FigureHtml(errors) +
          FigureHtml(histogram);
  html += WorstPosesSection(data);
  html += Html("<h2>Residual vectors</h2>\n") + FigureHtml(vectors);
  html += TemperatureSection(data, temperature);
  html += Html("<h2>Error against each joint angle</h2>\n<div class=\"joints\">\n");
  for (const auto& f : joints) html += FigureHtml(f);
  html += Html("</div>\n");
  html +=
      ParameterSection(data) + ChangeSection(data) + WindowSection(in) + HistorySection(in, drift);
  html += Html("</body></html>\n");
  const std::string path = dir + "/index.html";
  io::WriteFileAtomically(path, html.str());
  return path;
}

std::string WriteDecisionReport(const std::string& dir, const ReportInput& in) {
  namespace fs = std::filesystem;
  fs::create_directories(dir);
  RemoveReportDebris(dir, 60.0);
  // Every figure of an earlier report (the folder's PNGs are the report's, as for
  // RemoveReportDebris); the drift chart is drawn again below.
  std::error_code error;
  for (const auto& entry : fs::directory_iterator(dir, error)) {
    std::error_code ignored;
    if (entry.path().extension() == ".png") fs::remove(entry.path(), ignored);
  }
  const auto drift = DriftFigure(dir, in.drift_history, in.history);
  Html html = PageStart(in);
  html += Html(
      "<p id=\"no-fit\">No set was fitted this night: the configurations measured since the "
      "change are too few for a fit of their own, and a fit reaching back before it would blend "
      "two robots. The active set stays as it was.</p>\n");
  html += WindowSection(in) + HistorySection(in, drift);
  html += Html("</body></html>\n");
  const std::string path = dir + "/index.html";
  io::WriteFileAtomically(path, html.str());
  return path;
}

}  // namespace armsig::report
