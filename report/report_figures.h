// The report's figures, one function each: drawn with OpenCV (report/figures.h), saved
// as DIR/<name>.png and kept for embedding in the page.
#pragma once

#include <Eigen/Core>
#include <optional>
#include <string>
#include <vector>

#include "calibration/model.h"
#include "calibration/residual_map.h"
#include "workflows/calibration_run.h"
#include "report/figures.h"
#include "report/report_input.h"
#include "report/report_statistics.h"

namespace armsig::report {

// Error distance per validation configuration, nominal and calibrated, on a log scale.
figures::Figure ErrorsFigure(const std::string& dir, const workflows::CalibrationRun& run);
// The calibrated error distances' histogram with the 50, 95 and 99 % lines.
figures::Figure HistogramFigure(const std::string& dir, const std::vector<double>& distances_mm,
                                const AxisStatistics& distance);
// The residual vectors at the validation targets: top view (x, y) and side view (x, z) on
// equal scales, arrows magnified with a scale bar. `poses[i]`: residual i's pose (null when
// not known: left out).
figures::Figure VectorsFigure(const std::string& dir, const std::vector<Eigen::Vector3d>& residuals,
                              const std::vector<const MeasuredPose*>& poses);
// How far each version moved the arm (ReportDrift): the largest predicted-position
// difference against the set it is compared with, ±2σ, and the tolerance line; the
// versions made active marked in a row of their own below the axis. Nullopt when there is
// nothing to compare (fewer than two versions).
std::optional<figures::Figure> DriftFigure(const std::string& dir, const ReportDrift& drift,
                                           const std::vector<ReportHistoryPoint>& history);
// The drift chart's axis top (mm): every point and its 2σ, unless one reaches five times
// beyond the others and the tolerance; then three times what those reach, the one beyond
// drawn at the top with its value written.
double DriftAxisTop(const ReportDrift& drift);
// Error distance against each joint's angle, one small figure per joint.
std::vector<figures::Figure> JointFigures(const std::string& dir, int joints,
                                          const std::vector<double>& distances_mm,
                                          const std::vector<const MeasuredPose*>& poses);
// The residual map's cross-validation curve: CV mean against the length scale, a line per
// regularisation, the parametric level, the chosen point ringed. Nullopt without a grid.
std::optional<figures::Figure> ResidualMapFigure(const std::string& dir,
                                                 const calibration::ResidualMapFit& map);
// Error distance against the air temperature, with the least-squares trend when given
// (only where its span allows: TemperatureTrendRefusal). Nullopt for no temperatures: no
// empty panel.
std::optional<figures::Figure> TemperatureFigure(const std::string& dir,
                                                 const std::vector<double>& temperatures_c,
                                                 const std::vector<double>& errors_mm,
                                                 int validation_poses,
                                                 const std::optional<LinearTrend>& trend);

}  // namespace armsig::report
