#include "calibration/iso9283_figures.h"

#include <Eigen/SVD>
#include <algorithm>
#include <cmath>
#include <map>
#include <random>
#include <stdexcept>

#include "core/spread.h"
#include "core/units.h"

namespace armsig::calibration::iso9283 {

namespace {

// Mean and sample standard deviation (n − 1; NaN for one value).
struct MeanSd {
  double mean = NAN, sd = NAN;
};
MeanSd MeanAndSd(const std::vector<double>& v) {
  MeanSd m;
  if (v.empty()) return m;
  double sum = 0.0;
  for (double x : v) sum += x;
  m.mean = sum / static_cast<double>(v.size());
  if (v.size() >= 2) {
    double squares = 0.0;
    for (double x : v) squares += (x - m.mean) * (x - m.mean);
    m.sd = std::sqrt(squares / static_cast<double>(v.size() - 1));
  }
  return m;
}

Eigen::Vector3d Barycentre(const std::vector<Eigen::Vector3d>& x) {
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  for (const auto& p : x) sum += p;
  return sum / static_cast<double>(x.size());
}

// The largest distance between any two of `centres`.
double LargestSpread(const std::vector<Eigen::Vector3d>& centres) {
  double largest = 0.0;
  for (size_t h = 0; h < centres.size(); ++h)
    for (size_t k = h + 1; k < centres.size(); ++k)
      largest = std::max(largest, (centres[h] - centres[k]).norm());
  return largest;
}

}  // namespace

double PoseRepeatability(const std::vector<Eigen::Vector3d>& positions_mm) {
  if (positions_mm.size() < 2) return NAN;
  const Eigen::Vector3d centre = Barycentre(positions_mm);
  std::vector<double> l;
  for (const auto& p : positions_mm) l.push_back((p - centre).norm());
  const MeanSd m = MeanAndSd(l);
  return m.mean + 3.0 * m.sd;
}

PointFigures EvaluatePoint(const PointData& point) {
  if (point.samples.empty())
    throw std::invalid_argument("test point " + point.name + " has no attained pose");
  PointFigures f;
  f.name = point.name;
  f.n = static_cast<int>(point.samples.size());
  f.commanded_mm = point.commanded_mm;
  std::vector<Eigen::Vector3d> x;
  for (const auto& s : point.samples) x.push_back(s.position_mm);
  f.barycentre_mm = Barycentre(x);
  f.ap_xyz_mm = f.barycentre_mm - point.commanded_mm;
  f.ap_mm = f.ap_xyz_mm.norm();
  for (const auto& p : x) f.l_mm.push_back((p - f.barycentre_mm).norm());
  if (f.n >= 2) {
    const MeanSd l = MeanAndSd(f.l_mm);
    f.mean_l_mm = l.mean;
    f.s_l_mm = l.sd;
    f.rp_mm = l.mean + 3.0 * l.sd;
  }

  // Orientation: each angle's deviation from the command (or the first sample), on (−π, π].
  const bool oriented = std::all_of(point.samples.begin(), point.samples.end(),
                                    [](const Sample& s) { return s.orientation_rad.has_value(); });
  std::vector<std::vector<double>> deviation(3);
  if (oriented) {
    const Eigen::Vector3d reference =
        point.commanded_orientation_rad.value_or(*point.samples.front().orientation_rad);
    for (const auto& s : point.samples)
      for (int k = 0; k < 3; ++k)
        deviation[k].push_back(WrapPi((*s.orientation_rad)(k)-reference(k)));
    Eigen::Vector3d mean, sd;
    for (int k = 0; k < 3; ++k) {
      const MeanSd m = MeanAndSd(deviation[k]);
      mean(k) = m.mean;
      sd(k) = m.sd;
    }
    if (point.commanded_orientation_rad) f.ap_abc_rad = mean;
    if (f.n >= 2) {
      f.s_abc_rad = sd;
      f.rp_abc_rad = 3.0 * sd;
    }
  }

  // Multi-directional: the barycentre (and mean orientation) of each approach direction.
  std::map<int, std::vector<int>> by_approach;
  for (int j = 0; j < f.n; ++j) by_approach[point.samples[j].approach].push_back(j);
  f.approaches = static_cast<int>(by_approach.size());
  if (by_approach.size() >= 2) {
    std::vector<Eigen::Vector3d> centres, angles;
    for (const auto& [approach, members] : by_approach) {
      std::vector<Eigen::Vector3d> group;
      Eigen::Vector3d angle = Eigen::Vector3d::Zero();
      for (int j : members) {
        group.push_back(x[j]);
        if (oriented)
          for (int k = 0; k < 3; ++k)
            angle(k) += deviation[k][j] / static_cast<double>(members.size());
      }
      centres.push_back(Barycentre(group));
      angles.push_back(angle);
    }
    f.vap_mm = LargestSpread(centres);
    if (oriented) {
      Eigen::Vector3d largest = Eigen::Vector3d::Zero();
      for (size_t h = 0; h < angles.size(); ++h)
        for (size_t k = h + 1; k < angles.size(); ++k)
          largest = largest.cwiseMax((angles[h] - angles[k]).cwiseAbs());
      f.vap_abc_rad = largest;
    }
  }
  return f;
}

std::optional<DistanceFigures> EvaluateDistance(const PointData& a, const PointData& b) {
  std::map<std::pair<int, int>, Eigen::Vector3d> at_b;
  for (const auto& s : b.samples) at_b[{s.cycle, s.approach}] = s.position_mm;
  DistanceFigures d;
  d.from = a.name;
  d.to = b.name;
  d.commanded_mm = (a.commanded_mm - b.commanded_mm).norm();
  for (const auto& s : a.samples) {
    const auto it = at_b.find({s.cycle, s.approach});
    if (it != at_b.end()) d.d_mm.push_back((s.position_mm - it->second).norm());
  }
  if (d.d_mm.empty()) return std::nullopt;
  d.n = static_cast<int>(d.d_mm.size());
  const MeanSd m = MeanAndSd(d.d_mm);
  d.mean_mm = m.mean;
  d.ad_mm = m.mean - d.commanded_mm;
  if (d.n >= 2) {
    d.s_d_mm = m.sd;
    d.rd_mm = 3.0 * m.sd;
  }
  return d;
}

std::optional<Interval> BootstrapRpInterval(const std::vector<Eigen::Vector3d>& positions_mm,
                                            int resamples, double level, unsigned seed) {
  const int n = static_cast<int>(positions_mm.size());
  if (n < 3 || resamples < 10 || !(level > 0 && level < 1)) return std::nullopt;
  std::mt19937 rng(seed);
  std::uniform_int_distribution<int> pick(0, n - 1);
  std::vector<double> rp;
  rp.reserve(resamples);
  std::vector<Eigen::Vector3d> draw(n);
  for (int b = 0; b < resamples; ++b) {
    for (int j = 0; j < n; ++j) draw[j] = positions_mm[pick(rng)];
    rp.push_back(PoseRepeatability(draw));
  }
  std::sort(rp.begin(), rp.end());
  // Quantile by linear interpolation between order statistics.
  auto quantile = [&](double q) {
    const double at = q * (resamples - 1);
    const int below = static_cast<int>(std::floor(at));
    const int above = std::min(below + 1, resamples - 1);
    return rp[below] + (at - below) * (rp[above] - rp[below]);
  };
  Interval i;
  i.level = level;
  i.resamples = resamples;
  i.lo = quantile((1.0 - level) / 2.0);
  i.hi = quantile((1.0 + level) / 2.0);
  return i;
}

Eigen::Matrix3d RotationFromAbc(const Eigen::Vector3d& abc) {
  return (Eigen::AngleAxisd(abc(2), Eigen::Vector3d::UnitZ()) *
          Eigen::AngleAxisd(abc(1), Eigen::Vector3d::UnitY()) *
          Eigen::AngleAxisd(abc(0), Eigen::Vector3d::UnitX()))
      .toRotationMatrix();
}

Eigen::Vector3d AbcFromRotation(const Eigen::Matrix3d& r) {
  // R = Rz(c)·Ry(b)·Rx(a): R20 = −sin b, R21 = cos b sin a, R22 = cos b cos a,
  // R10 = sin c cos b, R00 = cos c cos b.
  return {std::atan2(r(2, 1), r(2, 2)), std::atan2(-r(2, 0), std::hypot(r(2, 1), r(2, 2))),
          std::atan2(r(1, 0), r(0, 0))};
}

std::optional<Alignment> AlignRigidly(const std::vector<Eigen::Vector3d>& attained_mm,
                                      const std::vector<Eigen::Vector3d>& commanded_mm) {
  const int m = static_cast<int>(attained_mm.size());
  if (m < 3 || static_cast<int>(commanded_mm.size()) != m) return std::nullopt;
  Eigen::Matrix3Xd from(3, m), to(3, m);
  for (int i = 0; i < m; ++i) {
    from.col(i) = attained_mm[i];
    to.col(i) = commanded_mm[i];
  }
  const Eigen::Vector3d spread = PrincipalSpread(to);
  if (!(spread(1) > 1e-6 * spread(0))) return std::nullopt;
  Alignment a;
  a.commanded_from_attained.matrix() = Eigen::umeyama(from, to, false);
  double squares = 0.0;
  for (int i = 0; i < m; ++i) {
    a.residual_mm.push_back((a.commanded_from_attained * attained_mm[i] - commanded_mm[i]).norm());
    squares += a.residual_mm.back() * a.residual_mm.back();
  }
  a.rms_mm = std::sqrt(squares / m);
  return a;
}

void TransformSamples(PointData& point, const Eigen::Isometry3d& t) {
  for (auto& s : point.samples) {
    s.position_mm = t * s.position_mm;
    if (s.orientation_rad)
      s.orientation_rad = AbcFromRotation(t.linear() * RotationFromAbc(*s.orientation_rad));
  }
}

}  // namespace armsig::calibration::iso9283
