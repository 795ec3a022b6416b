#include "reduction/orientation_initial.h"

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <Eigen/SVD>
#include <algorithm>
#include <cmath>
#include <functional>

#include "core/spread.h"
#include "core/units.h"
#include "reduction/observation.h"

namespace armsig::reduction {

namespace {

// Minimises a function of the azimuth: 0.5° grid, then golden-section refinement.
double BestAzimuth(const std::function<double(double)>& cost) {
  const int steps = 720;
  double best = 0.0, best_cost = INFINITY;
  for (int k = 0; k < steps; ++k) {
    const double az = 2.0 * kPi * k / steps;
    const double c = cost(az);
    if (c < best_cost) {
      best_cost = c;
      best = az;
    }
  }
  double lo = best - 2.0 * kPi / steps, hi = best + 2.0 * kPi / steps;
  const double phi = (std::sqrt(5.0) - 1.0) / 2.0;
  for (int it = 0; it < 60; ++it) {
    const double a = hi - phi * (hi - lo), b = lo + phi * (hi - lo);
    if (cost(a) < cost(b))
      hi = b;
    else
      lo = a;
  }
  return WrapTwoPi(0.5 * (lo + hi));
}

// Closest point of lines through `points` with directions `dirs` (resection position).
Eigen::Vector3d ClosestPointOfLines(const std::vector<Eigen::Vector3d>& points,
                                    const std::vector<Eigen::Vector3d>& dirs, double* cost) {
  Eigen::Matrix3d m = Eigen::Matrix3d::Zero();
  Eigen::Vector3d b = Eigen::Vector3d::Zero();
  for (size_t k = 0; k < points.size(); ++k) {
    const Eigen::Matrix3d p = Eigen::Matrix3d::Identity() - dirs[k] * dirs[k].transpose();
    m += p;
    b += p * points[k];
  }
  const Eigen::Vector3d x = m.ldlt().solve(b);
  if (cost) {
    double c = 0.0;
    for (size_t k = 0; k < points.size(); ++k) {
      const Eigen::Vector3d to = points[k] - x;
      c += (to - to.dot(dirs[k]) * dirs[k]).squaredNorm() / std::max(1e-9, to.squaredNorm());
      if (to.dot(dirs[k]) < 0) c += 10.0;  // the point must lie in front of the station
    }
    *cost = c;
  }
  return x;
}

// Rotation from the "direction DLT": w_k ∝ M X_k + m with M = Rᵀ, ≥ 6 known points.
bool ResectUnlevelled(const std::vector<Eigen::Vector3d>& points,
                      const std::vector<Eigen::Vector3d>& dirs_in_station, StationState& s) {
  const int k = static_cast<int>(points.size());
  if (k < 6) return false;
  Eigen::MatrixXd a(3 * k, 12);
  a.setZero();
  for (int i = 0; i < k; ++i) {
    const Eigen::Vector3d& w = dirs_in_station[i];
    Eigen::Matrix3d wx;
    wx << 0, -w.z(), w.y(), w.z(), 0, -w.x(), -w.y(), w.x(), 0;
    // [w]× (M X + m) = 0, unknowns row-major M (9) then m (3).
    for (int r = 0; r < 3; ++r) {
      for (int c = 0; c < 3; ++c) {
        for (int j = 0; j < 3; ++j) a(3 * i + r, 3 * c + j) = wx(r, c) * points[i](j);
        a(3 * i + r, 9 + c) = wx(r, c);
      }
    }
  }
  Eigen::JacobiSVD<Eigen::MatrixXd> svd(a, Eigen::ComputeFullV);
  Eigen::VectorXd h = svd.matrixV().col(11);
  Eigen::Matrix3d m;
  m << h(0), h(1), h(2), h(3), h(4), h(5), h(6), h(7), h(8);
  Eigen::Vector3d t = h.tail<3>();
  if (m.determinant() < 0) {
    m = -m;
    t = -t;
  }
  const double scale = std::cbrt(m.determinant());
  if (!(scale > 0)) return false;
  Eigen::JacobiSVD<Eigen::Matrix3d> r_svd(m, Eigen::ComputeFullU | Eigen::ComputeFullV);
  const Eigen::Matrix3d station_from_world = r_svd.matrixU() * r_svd.matrixV().transpose();
  // Directions must point at the points (positive depth).
  int front = 0;
  for (int i = 0; i < k; ++i) front += (m * points[i] + t).dot(dirs_in_station[i]) > 0;
  if (front < k / 2) return false;
  s.rotation = station_from_world.transpose();
  s.position = -s.rotation * (t / scale);
  Eigen::AngleAxisd aa(s.rotation);
  s.angle_axis = aa.angle() * aa.axis();
  s.placed = true;
  return true;
}

void SetLevelled(StationState& s, double azimuth, const Eigen::Vector3d& position) {
  s.azimuth = azimuth;
  s.rotation = LevelledRotation(azimuth);
  s.position = position;
  s.angle_axis = Eigen::Vector3d(0, 0, -azimuth);
  s.placed = true;
}

// A polar station (laser tracker, total station) from ≥ 3 known points it measured with
// distances, not on one line: the rigid best fit (Umeyama, no scale) of its polar points
// d·u onto the known ones gives its full pose, however it is tilted; a levelled station
// keeps the azimuth of that rotation.
bool ResectPolar(const std::vector<Eigen::Vector3d>& points,
                 const std::vector<Eigen::Vector3d>& polar_in_station, StationState& s) {
  const int k = static_cast<int>(points.size());
  if (k < 3) return false;
  Eigen::Matrix3Xd from(3, k), to(3, k);
  for (int i = 0; i < k; ++i) {
    from.col(i) = polar_in_station[i];
    to.col(i) = points[i];
  }
  const Eigen::Vector3d spread = PrincipalSpread(to);
  if (!(spread(1) > 1e-3 * spread(0))) return false;  // a line
  const Eigen::Matrix4d t = Eigen::umeyama(from, to, false);
  if (!t.allFinite()) return false;
  const Eigen::Matrix3d r = t.topLeftCorner<3, 3>();
  if (s.levelled) {
    SetLevelled(s, WrapTwoPi(-std::atan2(r(1, 0), r(0, 0))), t.topRightCorner<3, 1>());
    return true;
  }
  s.rotation = r;
  s.position = t.topRightCorner<3, 1>();
  Eigen::AngleAxisd aa(s.rotation);
  s.angle_axis = aa.angle() * aa.axis();
  s.placed = true;
  return true;
}


// Sine of the angle by which the ray from `origin` along `dir` misses `x`; a point behind
// the station misses by 1 (90°) or more.
double RayMiss(const Eigen::Vector3d& origin, const Eigen::Vector3d& dir, const Eigen::Vector3d& x) {
  const Eigen::Vector3d to = x - origin;
  const double length = to.norm();
  if (!(length > 0)) return 1.0;
  const double across = to.cross(dir).norm() / length;
  return to.dot(dir) < 0 ? 2.0 - across : across;
}

// The closest point of lines, robust to one wrong ray among three or more: when a ray
// misses the point of all of them by more than kStartOutlierRad, the point of the others
// (the subset whose rays agree best) is taken instead.
Eigen::Vector3d ConsensusPointOfLines(const std::vector<Eigen::Vector3d>& origins,
                                      const std::vector<Eigen::Vector3d>& dirs) {
  auto worst_miss = [&](const Eigen::Vector3d& x, size_t skip) {
    double worst = 0.0;
    for (size_t k = 0; k < origins.size(); ++k)
      if (k != skip) worst = std::max(worst, RayMiss(origins[k], dirs[k], x));
    return worst;
  };
  const Eigen::Vector3d all = ClosestPointOfLines(origins, dirs, nullptr);
  if (origins.size() < 3 || worst_miss(all, origins.size()) <= kStartOutlierRad) return all;
  Eigen::Vector3d best = all;
  double best_miss = INFINITY;
  for (size_t skip = 0; skip < origins.size(); ++skip) {
    std::vector<Eigen::Vector3d> o, d;
    for (size_t k = 0; k < origins.size(); ++k) {
      if (k == skip) continue;
      o.push_back(origins[k]);
      d.push_back(dirs[k]);
    }
    const Eigen::Vector3d x = ClosestPointOfLines(o, d, nullptr);
    const double miss = worst_miss(x, skip);
    if (x.allFinite() && miss < best_miss) {
      best_miss = miss;
      best = x;
    }
  }
  return best;
}

// A truncated square: one ray far off counts as much as any ray beyond kStartOutlierRad.
double Truncated(double e) { return std::min(e * e, kStartOutlierRad * kStartOutlierRad); }
}  // namespace

namespace {

using Obs = IndexedObservation;

// The start, step by step: stations placed by resection from known points (and the
// placed stations they sight) or, when none can be, by relative orientation to the placed
// station they share most with; known points intersected from the placed stations after
// every step; then the scale, or the similarity onto the control points.
class StartFinder {
 public:
  StartFinder(const OrientationProblem& problem, const IndexedNetwork& network,
              std::vector<std::string>& refusals)
      : problem_(problem), network_(network), refusals_(refusals) {
    st_.resize(network.station_ids.size());
    for (size_t i = 0; i < st_.size(); ++i)
      st_[i].levelled = !problem.unlevelled.count(network.station_ids[i]);
  }

  std::optional<InitialValues> Run() {
    if (!PlaceStations()) return std::nullopt;
    if (local_frame_ && network_.use_control) {
      if (!FitToControl()) return std::nullopt;
    } else if (!network_.use_control) {
      ApplyScale();
    }
    return InitialValues{std::move(st_), std::move(known_)};
  }

 private:
  static Eigen::Vector3d DirInStation(const Obs& o) {
    return DirectionInStation(AngleReading{o.hz, o.v, 1});
  }

  // Every point seen from placed stations: the consensus point of its rays.
  void IntersectKnown() {
    for (const auto& [point, rays] : network_.rays_of_point) {
      if (network_.control.count(point)) continue;
      std::vector<Eigen::Vector3d> origins, dirs;
      Eigen::Vector3d polar = Eigen::Vector3d::Zero();
      int polar_count = 0;
      for (int r : rays) {
        const Obs& o = network_.obs[r];
        if (!st_[o.station].placed) continue;
        const Eigen::Vector3d u = st_[o.station].rotation * DirInStation(o);
        origins.push_back(st_[o.station].position);
        dirs.push_back(u);
        if (o.distance) {
          polar += st_[o.station].position + *o.distance * u;
          ++polar_count;
        }
      }
      // Directions from two or more places first: they hold whatever the distances say,
      // so that one wrong distance (a blunder, a ray read at the zenith) cannot carry the
      // point away from its other rays, and they need no scale (the network's scale is
      // still provisional here). A polar point only for a point no two rays intersect.
      bool spread = false;
      for (size_t a = 0; a < dirs.size() && !spread; ++a)
        for (size_t b = a + 1; b < dirs.size() && !spread; ++b)
          spread = dirs[a].cross(dirs[b]).norm() > 1e-3 && (origins[a] - origins[b]).norm() > 0;
      if (spread) {
        known_[point] = ConsensusPointOfLines(origins, dirs);
      } else if (polar_count > 0) {
        known_[point] = polar / polar_count;
      }
    }
  }

  // Resection of station i from known points and placed stations it sights. Each sighted
  // point counts once: a repeated sighting of one point (the same line twice in a file) is
  // no second direction, and two rays to one point place the station on that point.
  bool TryResect(int i) {
    std::vector<Eigen::Vector3d> points, dirs, polar_points, polar;
    std::set<std::string> sighted;
    for (const auto& o : network_.obs) {
      if (o.station != i) continue;
      const Eigen::Vector3d* at = nullptr;
      if (o.target_station >= 0) {
        if (st_[o.target_station].placed) at = &st_[o.target_station].position;
      } else if (auto it = known_.find(o.point); it != known_.end()) {
        at = &it->second;
      }
      if (!at || !sighted.insert(o.point).second) continue;
      points.push_back(*at);
      dirs.push_back(DirInStation(o));
      if (o.distance) {
        polar_points.push_back(*at);
        polar.push_back(*o.distance * dirs.back());
      }
    }
    if (metric_frame_ && ResectPolar(polar_points, polar, st_[i])) return true;
    if (!st_[i].levelled && ResectUnlevelled(points, dirs, st_[i])) return true;
    if (points.size() < 2) return false;
    bool apart = false;  // at least two of the points are distinct places
    for (size_t k = 1; k < points.size() && !apart; ++k) {
      apart = (points[k] - points[0]).norm() > 1e-6 * std::max(1.0, points[0].norm());
    }
    if (!apart) return false;
    auto world_dirs = [&](double az) {
      std::vector<Eigen::Vector3d> world(dirs.size());
      const Eigen::Matrix3d r = LevelledRotation(az);
      for (size_t k = 0; k < dirs.size(); ++k) world[k] = r * dirs[k];
      return world;
    };
    // The azimuth whose lines meet best, each line's miss truncated (one wrong ray cannot
    // turn the station), then the consensus point of the lines.
    const double az = BestAzimuth([&](double a) {
      const std::vector<Eigen::Vector3d> world = world_dirs(a);
      const Eigen::Vector3d x = ClosestPointOfLines(points, world, nullptr);
      double c = 0.0;
      for (size_t k = 0; k < points.size(); ++k) c += Truncated(RayMiss(x, world[k], points[k]));
      return c;
    });
    SetLevelled(st_[i], az, ConsensusPointOfLines(points, world_dirs(az)));
    return true;
  }

  // Relative orientation of station j to placed station i (levelled approximation), baseline
  // `length` (arbitrary until the scale is applied).
  bool Relative(int i, int j) {
    const Obs* ij = nullptr;
    const Obs* ji = nullptr;
    for (const auto& o : network_.obs) {
      if (o.station == i && o.target_station == j) ij = &o;
      if (o.station == j && o.target_station == i) ji = &o;
    }
    // Common points: world directions from i, station directions from j.
    std::vector<Eigen::Vector3d> u, w;
    for (const auto& [point, rays] : network_.rays_of_point) {
      const Obs* from_i = nullptr;
      const Obs* from_j = nullptr;
      for (int r : rays) {
        if (network_.obs[r].station == i) from_i = &network_.obs[r];
        if (network_.obs[r].station == j) from_j = &network_.obs[r];
      }
      if (from_i && from_j) {
        u.push_back(st_[i].rotation * DirInStation(*from_i));
        w.push_back(DirInStation(*from_j));
      }
    }
    double length = 1000.0;
    if (ij && ij->distance)
      length = *ij->distance;
    else if (ji && ji->distance)
      length = *ji->distance;
    const std::optional<RelativePose> pose = BestRelativePose(st_[i].rotation, ij, ji, u, w);
    if (!pose) return false;
    SetLevelled(st_[j], pose->azimuth, st_[i].position + length * pose->baseline.normalized());
    return true;
  }

  struct RelativePose {
    double azimuth;
    Eigen::Vector3d baseline;  // world direction from i to j
  };

  // The candidates a pair's observations give (the mutual pointings' azimuths; either
  // pointing's baseline with the azimuth that makes the common rays coplanar; the common
  // rays alone), chosen by consensus: the one most common points agree with (their rays
  // and the baseline coplanar within kStartOutlierRad), so that one wrong pointing or
  // reading cannot set the pair's geometry.
  std::optional<RelativePose> BestRelativePose(const Eigen::Matrix3d& ri, const Obs* ij,
                                               const Obs* ji,
                                               const std::vector<Eigen::Vector3d>& u,
                                               const std::vector<Eigen::Vector3d>& w) const {
    auto coplanarity = [&](const Eigen::Matrix3d& r, const Eigen::Vector3d& b, size_t k) {
      return b.dot(u[k].cross(r * w[k]));
    };
    auto cost = [&](double a, const Eigen::Vector3d& b) {
      const Eigen::Matrix3d r = LevelledRotation(a);
      const Eigen::Vector3d unit = b.normalized();
      double c = 0.0;
      for (size_t k = 0; k < u.size(); ++k) c += Truncated(coplanarity(r, unit, k));
      return c;
    };
    // Generated in order of cost; the first that every common point agrees with is taken.
    std::vector<std::function<std::optional<RelativePose>()>> generators;
    if (ij && ji) {
      generators.push_back([&]() -> std::optional<RelativePose> {
        // The azimuth of j→i is that of i→j plus 200 gon.
        const Eigen::Vector3d b = ri * DirInStation(*ij);
        return RelativePose{WrapTwoPi(std::atan2(b.x(), b.y()) + kPi - ji->hz), b};
      });
    }
    if (ij) {
      generators.push_back([&]() -> std::optional<RelativePose> {
        const Eigen::Vector3d b = ri * DirInStation(*ij);
        return RelativePose{BestAzimuth([&](double a) { return cost(a, b); }), b};
      });
    }
    if (ji) {
      generators.push_back([&]() -> std::optional<RelativePose> {
        auto b_of = [&](double a) -> Eigen::Vector3d {
          return -(LevelledRotation(a) * DirInStation(*ji));
        };
        const double a = BestAzimuth([&](double x) { return cost(x, b_of(x)); });
        return RelativePose{a, b_of(a)};
      });
    }
    if (u.size() >= 3) generators.push_back([&] { return CoplanarPose(u, w); });
    std::optional<RelativePose> best;
    int best_agree = -1;
    double best_cost = INFINITY;
    for (const auto& generate : generators) {
      const std::optional<RelativePose> c = generate();
      if (!c) continue;
      int agree = 0;
      const Eigen::Matrix3d r = LevelledRotation(c->azimuth);
      for (size_t k = 0; k < u.size(); ++k)
        agree += std::abs(coplanarity(r, c->baseline.normalized(), k)) <= kStartOutlierRad;
      const double total = cost(c->azimuth, c->baseline);
      if (agree > best_agree || (agree == best_agree && total < best_cost)) {
        best = c;
        best_agree = agree;
        best_cost = total;
      }
      if (agree == static_cast<int>(u.size())) break;
    }
    return best;
  }

  // The common rays alone (three or more): the azimuth at which their coplanarity normals
  // leave a direction (the baseline) they are all perpendicular to; the points in front of
  // both stations.
  static std::optional<RelativePose> CoplanarPose(const std::vector<Eigen::Vector3d>& u,
                                                  const std::vector<Eigen::Vector3d>& w) {
    auto null_vector = [&](double a) {
      Eigen::MatrixXd m(u.size(), 3);
      const Eigen::Matrix3d r = LevelledRotation(a);
      for (size_t k = 0; k < u.size(); ++k) m.row(k) = u[k].cross(r * w[k]).transpose();
      Eigen::JacobiSVD<Eigen::MatrixXd> svd(m, Eigen::ComputeFullV);
      return Eigen::Vector3d(svd.matrixV().col(2));
    };
    const double az = BestAzimuth([&](double a) {
      const Eigen::Vector3d b = null_vector(a);
      const Eigen::Matrix3d r = LevelledRotation(a);
      double c = 0.0;
      for (size_t k = 0; k < u.size(); ++k) c += Truncated(b.dot(u[k].cross(r * w[k])));
      return c;
    });
    Eigen::Vector3d baseline = null_vector(az);
    // Cheirality: the common points must lie in front of both stations.
    int front = 0;
    for (size_t k = 0; k < u.size(); ++k) {
      const Eigen::Vector3d v = LevelledRotation(az) * w[k];
      // Solve S_i + λ u = S_i + t + μ v in the least-squares sense.
      Eigen::Matrix<double, 3, 2> a;
      a << u[k], -v;
      const Eigen::Vector2d lm = a.colPivHouseholderQr().solve(baseline);
      front += (lm(0) > 0 && lm(1) > 0) ? 1 : -1;
    }
    if (front < 0) baseline = -baseline;
    return RelativePose{az, baseline};
  }

  // Resection where possible, else relative orientation to the placed station sharing most.
  bool PlaceStations() {
    const int ns = static_cast<int>(st_.size());
    metric_frame_ = network_.use_control;
    for (const auto& c : problem_.control) known_[c.id] = c.position_mm;
    local_frame_ = !network_.use_control;
    if (network_.use_control) {
      // Start from stations that see control points, then grow.
      for (int i = 0; i < ns; ++i) TryResect(i);
      bool any = false;
      for (const auto& s : st_) any |= s.placed;
      if (!any) local_frame_ = true;  // fall back: build locally, then fit to the control
    }
    if (local_frame_) {
      metric_frame_ = false;
      for (auto& s : st_) s.placed = false;
      known_.clear();
      SetLevelled(st_[0], 0.0, Eigen::Vector3d::Zero());
    }
    for (int round = 0; round < 4 * ns; ++round) {
      IntersectKnown();
      bool progress = false;
      for (int i = 0; i < ns; ++i) {
        if (!st_[i].placed && TryResect(i)) progress = true;
      }
      if (progress) continue;
      const auto [i, j] = BestPair();
      if (j < 0 || !Relative(i, j)) break;
    }
    IntersectKnown();
    for (int i = 0; i < ns; ++i) {
      if (!st_[i].placed) {
        refusals_.push_back("station " + network_.station_ids[i] +
                            ": no initial pose could be found from its rays (too few points "
                            "shared with the other stations)");
      }
    }
    return refusals_.empty();
  }

  // The unplaced station sharing most with a placed one (a mutual pointing counts 3).
  std::pair<int, int> BestPair() const {
    const int ns = static_cast<int>(st_.size());
    int best_i = -1, best_j = -1, best_common = 0;
    for (int j = 0; j < ns; ++j) {
      if (st_[j].placed) continue;
      for (int i = 0; i < ns; ++i) {
        if (!st_[i].placed) continue;
        int common = 0;
        for (const auto& [point, stations] : network_.stations_of_point)
          common += stations.count(i) && stations.count(j);
        for (const auto& o : network_.obs)
          common += 3 * ((o.station == i && o.target_station == j) ||
                         (o.station == j && o.target_station == i));
        if (common > best_common) {
          best_common = common;
          best_i = i;
          best_j = j;
        }
      }
    }
    return {best_i, best_j};
  }

  // Similarity transform of the local network onto the control points.
  bool FitToControl() {
    std::vector<Eigen::Vector3d> from, to;
    for (const auto& c : problem_.control) {
      if (auto it = known_.find(c.id); it != known_.end()) {
        from.push_back(it->second);
        to.push_back(c.position_mm);
      }
    }
    if (from.size() < 3) {
      refusals_.push_back("control points: fewer than 3 of them are intersected from the stations");
      return false;
    }
    Eigen::Matrix3Xd a(3, from.size()), b(3, from.size());
    for (size_t k = 0; k < from.size(); ++k) {
      a.col(k) = from[k];
      b.col(k) = to[k];
    }
    const Eigen::Matrix4d t = Eigen::umeyama(a, b, true);
    const double scale = t.topLeftCorner<3, 3>().col(0).norm();
    const Eigen::Matrix3d r = t.topLeftCorner<3, 3>() / scale;
    for (auto& s : st_) {
      s.position = t.topLeftCorner<3, 3>() * s.position + t.topRightCorner<3, 1>();
      s.rotation = r * s.rotation;
      if (s.levelled) s.azimuth = WrapTwoPi(-std::atan2(s.rotation(1, 0), s.rotation(0, 0)));
      Eigen::AngleAxisd aa(s.rotation);
      s.angle_axis = aa.angle() * aa.axis();
    }
    known_.clear();
    for (const auto& c : problem_.control) known_[c.id] = c.position_mm;
    IntersectKnown();
    return true;
  }

  // Scale from bars and distances (the median of known / current: robust to a wrong one).
  void ApplyScale() {
    std::vector<double> factors;
    for (const auto& bar : problem_.scale_bars) {
      const double current = (known_.at(bar.to) - known_.at(bar.from)).norm();
      if (current > 0) factors.push_back(bar.length_mm / current);
    }
    for (const auto& o : network_.obs) {
      if (!o.distance) continue;
      const Eigen::Vector3d target = o.target_station >= 0  ? st_[o.target_station].position
                                     : known_.count(o.point) ? known_.at(o.point)
                                                             : st_[o.station].position;
      const double current = (target - st_[o.station].position).norm();
      if (current > 0) factors.push_back(*o.distance / current);
    }
    if (factors.empty()) return;
    std::nth_element(factors.begin(), factors.begin() + factors.size() / 2, factors.end());
    const double f = factors[factors.size() / 2];
    for (auto& s : st_) s.position *= f;
    for (auto& [id, x] : known_) x *= f;
  }

  const OrientationProblem& problem_;
  const IndexedNetwork& network_;
  std::vector<std::string>& refusals_;
  std::vector<StationState> st_;
  std::map<std::string, Eigen::Vector3d> known_;  // points with approximate coordinates
  // Whether known points are in true scale (from control points): only then do a polar
  // station's distances place it (in a local frame the scale comes last).
  bool metric_frame_ = false;
  bool local_frame_ = true;
};

}  // namespace

std::optional<InitialValues> FindInitialValues(const OrientationProblem& problem,
                                               const IndexedNetwork& network,
                                               std::vector<std::string>& refusals) {
  return StartFinder(problem, network, refusals).Run();
}

}  // namespace armsig::reduction
