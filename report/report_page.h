// The report's HTML page, one function per section, in the order the page shows them.
// Every text goes through Html (report/html.h): escaped unless it is a literal here.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "report/figures.h"
#include "report/html.h"
#include "report/report_input.h"
#include "report/report_statistics.h"

namespace armsig::report {

// What several sections and figures read, computed once from the input.
struct ReportData {
  explicit ReportData(const ReportInput& input);
  const ReportInput& in;
  const calibration::RobotModel& model;
  const workflows::CalibrationRun& run;
  std::vector<double> distances;           // of the validation residuals
  std::vector<const MeasuredPose*> poses;  // of each validation residual (null: not known)
  std::vector<AxisStatistics> stats;       // dX, dY, dZ, distance
  // The validation poses with an air temperature, their error distances, and the trend
  // when their span allows it (else `trend_refusal` says why).
  std::vector<double> temperatures, temperature_errors;
  std::optional<LinearTrend> trend;
  std::string trend_refusal;
};

// The report's first line: PASS (a set stored), DRIFT (stored after the robot changed),
// DRIFT SUSPECTED (nothing fitted) or REJECTED, with the one figure that matters for it: the
// validation error, how far the robot moved, or the gate that failed.
struct ReportBanner {
  std::string word;       // PASS, DRIFT, DRIFT SUSPECTED, REJECTED
  std::string css_class;  // good, warn, bad
  std::string figure;
};
ReportBanner BannerOf(const ReportInput& in);
// <head> (with the set marker and the print stylesheet), the title, the banner and the
// decision.
// The text index.html carries to say which robot's which version it reports (a <meta>
// element of its head); "" for a run that stored nothing.
std::string ReportSetMarker(const std::string& robot, int version);

Html PageStart(const ReportInput& in);
// Where the numbers come from: date, version, robot, parameter set, sessions,
// instruments, the orientations' σ0 (equal ones said once), rank, condition number,
// what is not identifiable; then the gates.
Html HeaderSection(const ReportData& data);
// Error distances (nominal and calibrated, fit and validation), the residual map's
// decision with its figure, the per-axis statistics.
Html ErrorSection(const ReportData& data, const std::optional<figures::Figure>& map_figure);
// The ten worst validation poses with their joints, and with the residual map whether each
// lay inside its support and the map's predictive σ there.
Html WorstPosesSection(const ReportData& data);
// Error against the air temperature: the figure and the slope with its uncertainty when
// the span allows it, else why there is none.
Html TemperatureSection(const ReportData& data, const std::optional<figures::Figure>& figure);
// The parameters in the paper's layout, value ± sigma (sigma to two significant digits,
// the value to the same decimal).
Html ParameterSection(const ReportData& data);
// The change of every parameter against the previous version, or why there is none.
Html ChangeSection(const ReportData& data);
// The nightly window's sessions against the active set (when there is a window).
Html WindowSection(const ReportInput& in);
// How far each version moved the arm (figure and its numbers), then the versions table.
Html HistorySection(const ReportInput& in, const std::optional<figures::Figure>& drift_figure);

// A parameter's change as the change table shows it: three significant digits, in mm or
// mrad from 0.01 up, else in µm or µrad ("-0.0420 µrad", never "-0.0000 mrad").
std::string FormatChange(double value, bool millimetres);

// "all", "geometric", "auto" or "list" (a comma list of names and groups).
std::string ParamsKind(const std::string& params_spec);
// What a --params value fitted, in words: "every term of the model", "the geometric
// parameters", "the geometric parameters and the terms that held on data the fit did not
// see", "the parameters geometric, h3, h4"; "not known" for none.
std::string ParamsInWords(const std::string& params_spec);

// The stations' set-ups with equal figures said once: in a session, the stations with the
// same σ0, dof and method (one network adjustment gives all its stations one σ0); then
// the sessions whose groups are all equal. "sessions 3, 4, 5, stations T1, T2, T3: σ0 =
// 0.942 (25 dof, mutual+scale_bar)" instead of twelve equal lines. In the order first met.
struct Sigma0Group {
  std::vector<int64_t> sessions;
  std::vector<std::string> stations;
  std::optional<double> sigma0;
  int dof = 0;
  std::string method;
};
std::vector<Sigma0Group> Sigma0Groups(const std::vector<ReportStationSetup>& setups);

}  // namespace armsig::report
