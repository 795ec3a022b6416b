#include "calibration/iso9283_path.h"

#include <algorithm>
#include <limits>
#include <optional>
#include <sstream>
#include <stdexcept>
#include <string>

#include "calibration/iso9283_figures.h"

namespace armsig::calibration::iso9283 {

namespace {

constexpr double kInfinity = std::numeric_limits<double>::infinity();

std::string Number(double x) {
  std::ostringstream out;
  out << x;
  return out.str();
}

// The commanded polyline without repeated vertices: path positions, segment directions and
// where each vertex came from.
struct Polyline {
  std::vector<Eigen::Vector3d> v;
  std::vector<int> source;         // index into PathCommand::vertices_mm
  std::vector<double> s;           // path position of each vertex
  std::vector<Eigen::Vector3d> d;  // unit direction of segment k, v[k] → v[k + 1]
  int Segments() const { return static_cast<int>(d.size()); }
  double Length() const { return s.back(); }
  // The segment holding path position `at`: the outgoing one at a vertex, the last at the end.
  int SegmentAt(double at) const {
    const int k = static_cast<int>(std::upper_bound(s.begin(), s.end(), at) - s.begin()) - 1;
    return std::clamp(k, 0, Segments() - 1);
  }
  Eigen::Vector3d PointAt(double at) const {
    const int k = SegmentAt(at);
    return v[k] + (at - s[k]) * d[k];
  }
};

Polyline MakePolyline(const PathCommand& command) {
  Polyline path;
  for (size_t i = 0; i < command.vertices_mm.size(); ++i) {
    const Eigen::Vector3d& x = command.vertices_mm[i];
    if (!x.allFinite())
      throw std::invalid_argument("path command: vertex " + std::to_string(i) + " is not finite");
    if (!path.v.empty() && x == path.v.back()) continue;
    if (!path.v.empty()) {
      const Eigen::Vector3d step = x - path.v.back();
      path.d.push_back(step.normalized());
      path.s.push_back(path.s.back() + step.norm());
    } else {
      path.s.push_back(0.0);
    }
    path.v.push_back(x);
    path.source.push_back(static_cast<int>(i));
  }
  if (path.v.size() < 2)
    throw std::invalid_argument("path command: fewer than two distinct vertices (" +
                                std::to_string(path.v.size()) + ")");
  return path;
}

// The nearest point of segments [first, last) of `path` to `p`: its path position and
// distance.
struct Nearest {
  double s = 0.0;
  double distance = kInfinity;
};
Nearest NearestOnPath(const Polyline& path, const Eigen::Vector3d& p, int first, int last) {
  Nearest best;
  for (int k = first; k < last; ++k) {
    const double along = std::clamp(path.d[k].dot(p - path.v[k]), 0.0, path.s[k + 1] - path.s[k]);
    const double distance = (p - (path.v[k] + along * path.d[k])).norm();
    if (distance < best.distance) best = {path.s[k] + along, distance};
  }
  return best;
}

// The corners, the legs between them and the steady part (the header's PathMargins).
struct Corner {
  int vertex = 0;  // into Polyline::v
  double turn_rad = 0.0;
  double margin_mm = 0.0;  // on either side, along the path
};
struct Stretch {
  double from = 0.0, to = 0.0;
};
struct Layout {
  std::vector<Corner> corners;
  double end_margin_mm = 0.0;
  std::vector<Stretch> steady;
  // The steady stretch holding path position `at`, −1 for none.
  int StretchOf(double at) const {
    for (size_t i = 0; i < steady.size(); ++i)
      if (at >= steady[i].from && at <= steady[i].to) return static_cast<int>(i);
    return -1;
  }
};

Layout MakeLayout(const Polyline& path, const PathOptions& options) {
  Layout layout;
  for (int k = 1; k + 1 < static_cast<int>(path.v.size()); ++k) {
    const double turn = std::acos(std::clamp(path.d[k - 1].dot(path.d[k]), -1.0, 1.0));
    if (turn > options.corner_threshold_rad) layout.corners.push_back({k, turn, 0.0});
  }
  const double length = path.Length();
  // Leg i runs from break i to break i + 1: the path's start, its corners, its end.
  std::vector<double> breaks = {0.0};
  for (const auto& c : layout.corners) breaks.push_back(path.s[c.vertex]);
  breaks.push_back(length);
  for (size_t i = 0; i < layout.corners.size(); ++i)
    layout.corners[i].margin_mm =
        options.margins.corners_fraction *
        std::min(breaks[i + 1] - breaks[i], breaks[i + 2] - breaks[i + 1]);
  layout.end_margin_mm = options.margins.ends_fraction * length;

  const double last = length - layout.end_margin_mm;
  double from = layout.end_margin_mm;
  auto add = [&](double a, double b) {
    if (b > a) layout.steady.push_back({a, b});
  };
  for (const auto& c : layout.corners) {
    const double at = path.s[c.vertex];
    add(from, std::min(at - c.margin_mm, last));
    from = std::max(from, at + c.margin_mm);
  }
  add(from, last);
  return layout;
}

void CheckCycles(const std::vector<AttainedCycle>& cycles) {
  if (cycles.empty()) throw std::invalid_argument("path: no attained cycles");
  for (size_t c = 0; c < cycles.size(); ++c) {
    const auto& samples = cycles[c].samples;
    const std::string where = "attained cycle " + std::to_string(c);
    if (samples.size() < 2)
      throw std::invalid_argument(where + ": fewer than two samples (" +
                                  std::to_string(samples.size()) + ")");
    for (size_t i = 0; i < samples.size(); ++i) {
      const std::string sample = where + ", sample " + std::to_string(i);
      if (!std::isfinite(samples[i].t_s) || !samples[i].position_mm.allFinite())
        throw std::invalid_argument(sample + ": time or position not finite");
      if (i > 0 && !(samples[i].t_s > samples[i - 1].t_s))
        throw std::invalid_argument(sample + ": time " + Number(samples[i].t_s) +
                                    " s does not increase on the previous sample's " +
                                    Number(samples[i - 1].t_s) + " s");
    }
  }
}

// The planes' spacing h: plane_spacing_mm, or less so that at least min_planes of the
// points j · h lie in the steady part (length U). A stretch of length w holds at least
// floor(w / h) of them, so h ≤ U / (min_planes + stretches) is enough. NaN for no steady part.
double PlaneSpacing(const Layout& layout, const PathOptions& options) {
  double steady_mm = 0.0;
  for (const auto& stretch : layout.steady) steady_mm += stretch.to - stretch.from;
  if (!(steady_mm > 0.0)) return NAN;
  return std::min(options.plane_spacing_mm,
                  steady_mm / (options.min_planes + static_cast<double>(layout.steady.size())));
}

// The normal planes at s_j = j · h in the steady part.
std::vector<PlaneFigures> MakePlanes(const Polyline& path, const Layout& layout,
                                     double spacing_mm) {
  std::vector<PlaneFigures> planes;
  if (std::isnan(spacing_mm)) return planes;
  for (const auto& stretch : layout.steady) {
    const double first = std::ceil(stretch.from / spacing_mm);
    const double last = std::floor(stretch.to / spacing_mm);
    for (double j = first; j <= last; j += 1.0) {
      const double at = j * spacing_mm;
      if (!planes.empty() && at <= planes.back().s_mm) continue;  // on two stretches' border
      PlaneFigures plane;
      plane.s_mm = at;
      plane.commanded_mm = path.PointAt(at);
      plane.normal = path.d[path.SegmentAt(at)];
      planes.push_back(plane);
    }
  }
  return planes;
}

// For every plane, each cycle's crossing nearest its commanded point (within `reach_mm`).
// Segment by segment of the command: the planes on segment k are perpendicular to d_k at
// path positions s_j, and a sample pair crosses those whose s_j lies between the pair's
// own positions along d_k.
std::vector<std::vector<std::optional<Eigen::Vector3d>>> Crossings(
    const Polyline& path, const std::vector<PlaneFigures>& planes,
    const std::vector<AttainedCycle>& cycles, double reach_mm) {
  const int segments = path.Segments();
  std::vector<double> at(planes.size());
  std::vector<int> first(segments + 1, static_cast<int>(planes.size()));
  for (size_t j = 0; j < planes.size(); ++j) at[j] = planes[j].s_mm;
  for (int j = static_cast<int>(planes.size()) - 1; j >= 0; --j) first[path.SegmentAt(at[j])] = j;
  for (int k = segments - 1; k >= 0; --k) first[k] = std::min(first[k], first[k + 1]);

  std::vector<std::vector<std::optional<Eigen::Vector3d>>> crossing(
      planes.size(), std::vector<std::optional<Eigen::Vector3d>>(cycles.size()));
  std::vector<double> nearest(planes.size());
  for (size_t c = 0; c < cycles.size(); ++c) {
    std::fill(nearest.begin(), nearest.end(), kInfinity);
    const auto& samples = cycles[c].samples;
    for (size_t i = 0; i + 1 < samples.size(); ++i) {
      const Eigen::Vector3d& a = samples[i].position_mm;
      const Eigen::Vector3d& b = samples[i + 1].position_mm;
      for (int k = 0; k < segments; ++k) {
        if (first[k] == first[k + 1]) continue;
        const double ua = path.s[k] + path.d[k].dot(a - path.v[k]);
        const double ub = path.s[k] + path.d[k].dot(b - path.v[k]);
        if (ua == ub) continue;  // parallel to the planes: its ends are its neighbours' ends
        const double lo = std::min(ua, ub), hi = std::max(ua, ub);
        auto j = std::lower_bound(at.begin() + first[k], at.begin() + first[k + 1], lo);
        for (; j != at.begin() + first[k + 1] && *j <= hi; ++j) {
          const size_t plane = j - at.begin();
          const Eigen::Vector3d x = a + (*j - ua) / (ub - ua) * (b - a);
          const double distance = (x - planes[plane].commanded_mm).norm();
          if (distance <= reach_mm && distance < nearest[plane]) {
            nearest[plane] = distance;
            crossing[plane][c] = x;
          }
        }
      }
    }
  }
  return crossing;
}

// CR and CO of one corner in one cycle (the header's definitions).
struct CornerDeviation {
  double cr_mm = NAN, co_mm = NAN;
};
CornerDeviation Deviate(const Polyline& path, const Layout& layout, size_t corner,
                        const AttainedCycle& cycle) {
  const Corner& c = layout.corners[corner];
  const Eigen::Vector3d& x = path.v[c.vertex];
  const auto& samples = cycle.samples;
  CornerDeviation out;
  out.cr_mm = kInfinity;
  size_t closest = 0;
  for (size_t i = 0; i + 1 < samples.size(); ++i) {
    const Eigen::Vector3d& a = samples[i].position_mm;
    const Eigen::Vector3d ab = samples[i + 1].position_mm - a;
    const double squared = ab.squaredNorm();
    const double t = squared > 0.0 ? std::clamp((x - a).dot(ab) / squared, 0.0, 1.0) : 0.0;
    const double distance = (a + t * ab - x).norm();
    if (distance < out.cr_mm) {
      out.cr_mm = distance;
      closest = i;
    }
  }
  // The outgoing leg: segments c.vertex … up to the next corner or the path's end; the
  // window ends where the steady part does.
  const bool followed = corner + 1 < layout.corners.size();
  const int leg_end = followed ? layout.corners[corner + 1].vertex : path.Segments();
  const double window_mm = path.s[leg_end] - path.s[c.vertex] -
                           (followed ? layout.corners[corner + 1].margin_mm : layout.end_margin_mm);
  if (!(window_mm > 0.0)) return out;
  double largest = -1.0;
  for (size_t i = closest + 1; i < samples.size(); ++i) {
    const Nearest n = NearestOnPath(path, samples[i].position_mm, c.vertex, leg_end);
    const double past = n.s - path.s[c.vertex];
    if (past > window_mm) break;
    if (past > 0.0) largest = std::max(largest, n.distance);
  }
  if (largest >= 0.0) out.co_mm = largest;
  return out;
}

// The cycle's speeds: chords `stride` samples apart over their times, both ends in one
// steady stretch.
std::vector<double> Speeds(const Polyline& path, const Layout& layout, const AttainedCycle& cycle,
                           int stride) {
  const auto& samples = cycle.samples;
  std::vector<int> stretch(samples.size());
  for (size_t i = 0; i < samples.size(); ++i)
    stretch[i] =
        layout.StretchOf(NearestOnPath(path, samples[i].position_mm, 0, path.Segments()).s);
  const size_t step = static_cast<size_t>(stride);
  std::vector<double> v;
  for (size_t i = 0; i + step < samples.size(); ++i) {
    const size_t j = i + step;
    if (stretch[i] < 0 || stretch[i] != stretch[j]) continue;
    v.push_back((samples[j].position_mm - samples[i].position_mm).norm() /
                (samples[j].t_s - samples[i].t_s));
  }
  return v;
}

double Mean(const std::vector<double>& v) {
  double sum = 0.0;
  for (double x : v) sum += x;
  return sum / static_cast<double>(v.size());
}

}  // namespace

void PathOptions::Check() const {
  auto fail = [](const std::string& what) { throw std::invalid_argument("path options: " + what); };
  if (!(plane_spacing_mm > 0.0) || !std::isfinite(plane_spacing_mm))
    fail("plane_spacing_mm must be positive (got " + Number(plane_spacing_mm) + ")");
  if (min_planes < 1)
    fail("min_planes must be at least 1 (got " + std::to_string(min_planes) + ")");
  if (!(max_crossing_distance_mm > 0.0))
    fail("max_crossing_distance_mm must be positive (got " + Number(max_crossing_distance_mm) +
         ")");
  if (!(corner_threshold_rad > 0.0 && corner_threshold_rad < kPi))
    fail("corner_threshold_rad must be in (0, π) (got " + Number(corner_threshold_rad) + ")");
  if (!(margins.ends_fraction >= 0.0 && margins.ends_fraction < 0.5))
    fail("margins.ends_fraction must be in [0, 0.5) (got " + Number(margins.ends_fraction) + ")");
  if (!(margins.corners_fraction >= 0.0 && margins.corners_fraction < 0.5))
    fail("margins.corners_fraction must be in [0, 0.5) (got " + Number(margins.corners_fraction) +
         ")");
  if (speed_stride < 1)
    fail("speed_stride must be at least 1 (got " + std::to_string(speed_stride) + ")");
}

PathFigures EvaluatePath(const PathCommand& command, const std::vector<AttainedCycle>& cycles,
                         const PathOptions& options) {
  options.Check();
  const Polyline path = MakePolyline(command);
  if (!(command.speed_mm_s > 0.0) || !std::isfinite(command.speed_mm_s))
    throw std::invalid_argument("path command: the speed must be positive and finite (got " +
                                Number(command.speed_mm_s) + " mm/s)");
  CheckCycles(cycles);
  const Layout layout = MakeLayout(path, options);

  PathFigures f;
  f.n = static_cast<int>(cycles.size());
  f.length_mm = path.Length();
  f.commanded_speed_mm_s = command.speed_mm_s;

  // Path accuracy and repeatability: in each plane the pose figures of the crossings.
  f.plane_spacing_mm = PlaneSpacing(layout, options);
  f.planes = MakePlanes(path, layout, f.plane_spacing_mm);
  const auto crossing = Crossings(path, f.planes, cycles, options.max_crossing_distance_mm);
  double at_sum = 0.0;
  for (size_t j = 0; j < f.planes.size(); ++j) {
    PlaneFigures& plane = f.planes[j];
    PointData point;
    point.commanded_mm = plane.commanded_mm;
    for (size_t c = 0; c < cycles.size(); ++c) {
      if (crossing[j][c])
        point.samples.push_back({static_cast<int>(c), 0, *crossing[j][c], std::nullopt});
      else
        ++f.missed_crossings;
    }
    plane.n = static_cast<int>(point.samples.size());
    if (plane.n == 0) {
      ++f.planes_skipped;
      continue;
    }
    ++f.planes_used;
    const PointFigures p = EvaluatePoint(point);
    plane.barycentre_mm = p.barycentre_mm;
    plane.at_xyz_mm = p.ap_xyz_mm;
    plane.at_mm = p.ap_mm;
    plane.mean_l_mm = p.mean_l_mm;
    plane.s_l_mm = p.s_l_mm;
    plane.rt_mm = p.rp_mm;
    at_sum += plane.at_mm;
    if (f.at_plane < 0 || plane.at_mm > f.at_mm) {
      f.at_mm = plane.at_mm;
      f.at_plane = static_cast<int>(j);
      f.at_xyz_mm = plane.at_xyz_mm;
    }
    if (plane.n >= 2 && (f.rt_plane < 0 || plane.rt_mm > f.rt_mm)) {
      f.rt_mm = plane.rt_mm;
      f.rt_plane = static_cast<int>(j);
    }
  }
  if (f.planes_used > 0) f.mean_at_mm = at_sum / f.planes_used;

  // Corner deviations.
  for (size_t k = 0; k < layout.corners.size(); ++k) {
    CornerFigures corner;
    corner.vertex = path.source[layout.corners[k].vertex];
    corner.corner_mm = path.v[layout.corners[k].vertex];
    corner.turn_rad = layout.corners[k].turn_rad;
    for (const auto& cycle : cycles) {
      const CornerDeviation d = Deviate(path, layout, k, cycle);
      corner.cr_mm.push_back(d.cr_mm);
      corner.co_mm.push_back(d.co_mm);
      if (!(d.cr_mm <= corner.cr_max_mm)) corner.cr_max_mm = d.cr_mm;  // NaN: the first
      if (!std::isnan(d.co_mm) && !(d.co_mm <= corner.co_max_mm)) corner.co_max_mm = d.co_mm;
    }
    f.corners.push_back(corner);
  }

  // Path velocity: v̄ over every steady speed of every cycle; S_v over the cycle means.
  std::vector<double> all, means;
  for (const auto& cycle : cycles) {
    const std::vector<double> v = Speeds(path, layout, cycle, options.speed_stride);
    CycleSpeed speed;
    speed.count = static_cast<int>(v.size());
    if (!v.empty()) {
      speed.mean_mm_s = Mean(v);
      speed.min_mm_s = *std::min_element(v.begin(), v.end());
      speed.max_mm_s = *std::max_element(v.begin(), v.end());
      means.push_back(speed.mean_mm_s);
      all.insert(all.end(), v.begin(), v.end());
      const double fluctuation = speed.max_mm_s - speed.min_mm_s;
      if (!(fluctuation <= f.fv_mm_s)) f.fv_mm_s = fluctuation;  // NaN: the first
    }
    f.speeds.push_back(speed);
  }
  if (!all.empty()) {
    f.mean_speed_mm_s = Mean(all);
    f.av_percent = (f.mean_speed_mm_s - command.speed_mm_s) / command.speed_mm_s * 100.0;
  }
  if (means.size() >= 2) {
    const double m = Mean(means);
    double squares = 0.0;
    for (double x : means) squares += (x - m) * (x - m);
    f.s_v_mm_s = std::sqrt(squares / static_cast<double>(means.size() - 1));
    f.rv_percent = 3.0 * f.s_v_mm_s / command.speed_mm_s * 100.0;
  }
  return f;
}

TestPaths BuildTestPaths(const TestCube& cube, int circle_segments) {
  if (!(cube.edge_mm > 0.0) || !cube.centre_mm.allFinite())
    throw std::invalid_argument("test paths: the cube's edge must be positive (got " +
                                Number(cube.edge_mm) + " mm)");
  if (circle_segments < 360)
    throw std::invalid_argument("test paths: a circle needs at least 360 segments (got " +
                                std::to_string(circle_segments) + ")");
  const auto c = CubeCorners(cube);
  const auto p = TestPoints(cube);
  const Eigen::Vector3d e1 = (c[1] - c[0]).normalized();  // C1 → C2
  const Eigen::Vector3d e2 = (c[7] - c[0]).normalized();  // C1 → C8
  TestPaths paths;
  paths.line_mm = {p[1].position_mm, p[3].position_mm};
  const Eigen::Vector3d start = 0.5 * (p[4].position_mm + p[1].position_mm);  // P5–P2
  paths.rectangle_mm = {
      start, p[1].position_mm, p[2].position_mm, p[3].position_mm, p[4].position_mm, start};
  auto circle = [&](double diameter_mm) {
    std::vector<Eigen::Vector3d> v;
    for (int k = 0; k < circle_segments; ++k) {
      const double angle = 2.0 * kPi * k / circle_segments;
      v.push_back(p[0].position_mm +
                  0.5 * diameter_mm * (std::cos(angle) * e1 + std::sin(angle) * e2));
    }
    v.push_back(v.front());
    return v;
  };
  const double large_mm = kLargeCircleFraction * cube.edge_mm;
  paths.large_circle_mm = circle(large_mm);
  paths.small_circle_mm = circle(kSmallCircleFraction * large_mm);
  return paths;
}

std::optional<CircleArc> ArcThrough(const Eigen::Vector3d& from, const Eigen::Vector3d& via,
                                    const Eigen::Vector3d& to) {
  // The circumcentre of the triangle (0, a, b) with `from` at the origin:
  // p = ((|a|² b − |b|² a) × (a × b)) / (2 |a × b|²).
  const Eigen::Vector3d a = via - from, b = to - from, n = a.cross(b);
  const double scale = std::max({a.norm(), b.norm(), 1e-12});
  if (!(n.norm() > 1e-9 * scale * scale) || !n.allFinite()) return std::nullopt;
  const Eigen::Vector3d p = (a.squaredNorm() * b - b.squaredNorm() * a).cross(n) / (2.0 * n.squaredNorm());
  CircleArc arc;
  arc.centre_mm = from + p;
  arc.radius_mm = p.norm();
  arc.e1 = -p / arc.radius_mm;
  // The triangle from → via → to turns about n: the arc through them in that order too.
  arc.e2 = n.normalized().cross(arc.e1);
  const Eigen::Vector3d c = to - arc.centre_mm;
  double angle = std::atan2(c.dot(arc.e2), c.dot(arc.e1));
  if (angle <= 0.0) angle += 2.0 * kPi;
  arc.angle_rad = angle;
  return arc;
}

std::vector<Eigen::Vector3d> ArcPolyline(const CircleArc& arc, double max_step_rad) {
  const int n = std::max(1, static_cast<int>(std::ceil(arc.angle_rad / max_step_rad - 1e-9)));
  std::vector<Eigen::Vector3d> out;
  for (int k = 1; k <= n; ++k) out.push_back(arc.At(static_cast<double>(k) / n));
  return out;
}

}  // namespace armsig::calibration::iso9283
