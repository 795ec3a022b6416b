#include "report/report_statistics.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <numeric>

#include "calibration/statistics.h"
#include "report/figures.h"

namespace armsig::report {

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
    const double z =
        t.sigma_slope > 0.0 ? t.slope / t.sigma_slope : std::numeric_limits<double>::infinity();
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

ReportDriftPoint DriftPointOf(const calibration::RobotModel& model,
                              const calibration::FittedSet& before,
                              const calibration::FittedSet& after,
                              const std::vector<Eigen::VectorXd>& configurations) {
  ReportDriftPoint point;
  const auto profile = calibration::ProfileDifference(model, before, after, configurations);
  if (profile.worst < 0) return point;
  point.max_mm = profile.distance_mm[profile.worst];
  point.sigma_max_mm = profile.sigma_mm[profile.worst];
  double sum = 0.0;
  for (double d : profile.distance_mm) sum += d;
  point.mean_mm = sum / static_cast<double>(profile.distance_mm.size());
  return point;
}

std::string TemperatureTrendRefusal(const std::vector<double>& temperatures_c) {
  if (temperatures_c.empty()) return "no temperatures";
  const auto [lo, hi] = std::minmax_element(temperatures_c.begin(), temperatures_c.end());
  const double span = *hi - *lo;
  if (span < kMinTrendSpanC) {
    return fmt::format("the temperatures span only {:.2f} °C; a slope needs at least {:g} °C", span,
                       kMinTrendSpanC);
  }
  if (static_cast<int>(temperatures_c.size()) < kMinTrendPoints) {
    return fmt::format("only {} a temperature; a slope needs at least {}",
                       temperatures_c.size() == 1
                           ? std::string("1 pose has")
                           : fmt::format("{} poses have", temperatures_c.size()),
                       kMinTrendPoints);
  }
  return "";
}

}  // namespace armsig::report
