#include "reduction/orientation_initial.h"

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <Eigen/SVD>
#include <algorithm>
#include <cmath>
#include <functional>

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
  const Eigen::Matrix3Xd centred = to.colwise() - to.rowwise().mean();
  const Eigen::JacobiSVD<Eigen::Matrix3Xd> svd(centred);
  if (!(svd.singularValues()(1) > 1e-3 * svd.singularValues()(0))) return false;  // a line
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

}  // namespace

std::optional<InitialValues> FindInitialValues(const OrientationProblem& problem,
                                               const IndexedNetwork& network,
                                               std::vector<std::string>& refusals) {
  using Obs = IndexedObservation;
  const std::vector<std::string>& station_ids = network.station_ids;
  const int ns = static_cast<int>(station_ids.size());
  const std::vector<Obs>& obs = network.obs;
  const auto& rays_of_point = network.rays_of_point;
  const auto& stations_of_point = network.stations_of_point;
  const auto& control = network.control;
  const bool use_control = network.use_control;
  auto refuse = [&](std::string why) { refusals.push_back(std::move(why)); };

  std::vector<StationState> st(ns);
  for (int i = 0; i < ns; ++i) st[i].levelled = !problem.unlevelled.count(station_ids[i]);
  std::map<std::string, Eigen::Vector3d> known;  // points with approximate coordinates
  for (const auto& c : problem.control) known[c.id] = c.position_mm;

  auto dir_in_station = [&](const Obs& o) {
    return DirectionInStation(AngleReading{o.hz, o.v, 1});
  };
  auto intersect_known = [&]() {
    for (const auto& [point, rays] : rays_of_point) {
      if (control.count(point)) continue;
      std::vector<Eigen::Vector3d> origins, dirs;
      Eigen::Vector3d polar = Eigen::Vector3d::Zero();
      int polar_count = 0;
      for (int r : rays) {
        const Obs& o = obs[r];
        if (!st[o.station].placed) continue;
        const Eigen::Vector3d u = st[o.station].rotation * dir_in_station(o);
        origins.push_back(st[o.station].position);
        dirs.push_back(u);
        if (o.distance) {
          polar += st[o.station].position + *o.distance * u;
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
          spread = dirs[a].cross(dirs[b]).norm() > 1e-3 &&
                   (origins[a] - origins[b]).norm() > 0;
      if (spread) {
        known[point] = ClosestPointOfLines(origins, dirs, nullptr);
      } else if (polar_count > 0) {
        known[point] = polar / polar_count;
      }
    }
  };

  // Whether known points are in true scale (from control points): only then do a polar
  // station's distances place it (in a local frame the scale comes last).
  bool metric_frame = use_control;
  // Resection of station i from known points and placed stations it sights or that sight it.
  // Each sighted point counts once: a repeated sighting of one point (the same line twice in
  // a file) is no second direction, and two rays to one point place the station on that
  // point.
  auto try_resect = [&](int i) {
    std::vector<Eigen::Vector3d> points, dirs, polar_points, polar;
    std::set<std::string> sighted;
    for (const auto& o : obs) {
      if (o.station != i) continue;
      const Eigen::Vector3d* at = nullptr;
      if (o.target_station >= 0) {
        if (st[o.target_station].placed) at = &st[o.target_station].position;
      } else if (auto it = known.find(o.point); it != known.end()) {
        at = &it->second;
      }
      if (!at || !sighted.insert(o.point).second) continue;
      points.push_back(*at);
      dirs.push_back(dir_in_station(o));
      if (o.distance) {
        polar_points.push_back(*at);
        polar.push_back(*o.distance * dirs.back());
      }
    }
    if (metric_frame && ResectPolar(polar_points, polar, st[i])) return true;
    if (!st[i].levelled && ResectUnlevelled(points, dirs, st[i])) return true;
    if (points.size() < 2) return false;
    bool apart = false;  // at least two of the points are distinct places
    for (size_t k = 1; k < points.size() && !apart; ++k) {
      apart = (points[k] - points[0]).norm() > 1e-6 * std::max(1.0, points[0].norm());
    }
    if (!apart) return false;
    auto cost = [&](double az) {
      std::vector<Eigen::Vector3d> world(dirs.size());
      const Eigen::Matrix3d r = LevelledRotation(az);
      for (size_t k = 0; k < dirs.size(); ++k) world[k] = r * dirs[k];
      double c = 0;
      ClosestPointOfLines(points, world, &c);
      return c;
    };
    const double az = BestAzimuth(cost);
    std::vector<Eigen::Vector3d> world(dirs.size());
    for (size_t k = 0; k < dirs.size(); ++k) world[k] = LevelledRotation(az) * dirs[k];
    SetLevelled(st[i], az, ClosestPointOfLines(points, world, nullptr));
    return true;
  };

  // Relative orientation of station j to placed station i (levelled approximation),
  // baseline length `base` (arbitrary until the scale is applied).
  auto relative = [&](int i, int j) {
    const Obs* ij = nullptr;
    const Obs* ji = nullptr;
    for (const auto& o : obs) {
      if (o.station == i && o.target_station == j) ij = &o;
      if (o.station == j && o.target_station == i) ji = &o;
    }
    // Common points: world directions from i, station directions from j.
    std::vector<Eigen::Vector3d> u, w;
    for (const auto& [point, rays] : rays_of_point) {
      const Obs* from_i = nullptr;
      const Obs* from_j = nullptr;
      for (int r : rays) {
        if (obs[r].station == i) from_i = &obs[r];
        if (obs[r].station == j) from_j = &obs[r];
      }
      if (from_i && from_j) {
        u.push_back(st[i].rotation * dir_in_station(*from_i));
        w.push_back(dir_in_station(*from_j));
      }
    }
    double length = 1000.0;
    if (ij && ij->distance)
      length = *ij->distance;
    else if (ji && ji->distance)
      length = *ji->distance;

    double az = 0.0;
    Eigen::Vector3d baseline;
    if (ij) {
      baseline = st[i].rotation * dir_in_station(*ij);
      if (ji) {
        // Paper-free geodesy: the azimuth of j→i is that of i→j plus 200 gon.
        const double azimuth_ij = std::atan2(baseline.x(), baseline.y());
        az = WrapTwoPi(azimuth_ij + kPi - ji->hz);
      } else {
        az = BestAzimuth([&](double a) {
          double c = 0;
          for (size_t k = 0; k < u.size(); ++k) {
            const double e = baseline.dot(u[k].cross(LevelledRotation(a) * w[k]));
            c += e * e;
          }
          return c;
        });
      }
    } else if (ji) {
      az = BestAzimuth([&](double a) {
        const Eigen::Vector3d b = -(LevelledRotation(a) * dir_in_station(*ji));
        double c = 0;
        for (size_t k = 0; k < u.size(); ++k) {
          const double e = b.dot(u[k].cross(LevelledRotation(a) * w[k]));
          c += e * e;
        }
        return c;
      });
      baseline = -(LevelledRotation(az) * dir_in_station(*ji));
    } else {
      if (u.size() < 3) return false;
      auto null_vector = [&](double a, double* smallest) {
        Eigen::MatrixXd m(u.size(), 3);
        for (size_t k = 0; k < u.size(); ++k) {
          const Eigen::Vector3d n = u[k].cross(LevelledRotation(a) * w[k]);
          m.row(k) = n.transpose();
        }
        Eigen::JacobiSVD<Eigen::MatrixXd> svd(m, Eigen::ComputeFullV);
        if (smallest) *smallest = svd.singularValues()(2);
        return Eigen::Vector3d(svd.matrixV().col(2));
      };
      az = BestAzimuth([&](double a) {
        double s = 0;
        null_vector(a, &s);
        return s;
      });
      baseline = null_vector(az, nullptr);
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
    }
    SetLevelled(st[j], az, st[i].position + length * baseline.normalized());
    return true;
  };

  bool local_frame = !use_control;
  if (use_control) {
    // Start from stations that see control points, then grow.
    for (int i = 0; i < ns; ++i) try_resect(i);
    bool any = false;
    for (const auto& s : st) any |= s.placed;
    if (!any) local_frame = true;  // fall back: build locally, then fit to the control
  }
  if (local_frame) {
    metric_frame = false;
    for (auto& s : st) s.placed = false;
    known.clear();
    SetLevelled(st[0], 0.0, Eigen::Vector3d::Zero());
  }
  for (int round = 0; round < 4 * ns; ++round) {
    intersect_known();
    bool progress = false;
    for (int i = 0; i < ns; ++i) {
      if (!st[i].placed && try_resect(i)) progress = true;
    }
    if (progress) continue;
    // No station can be resected: relative orientation to the placed station it shares
    // most with.
    int best_i = -1, best_j = -1, best_common = 0;
    for (int j = 0; j < ns; ++j) {
      if (st[j].placed) continue;
      for (int i = 0; i < ns; ++i) {
        if (!st[i].placed) continue;
        int common = 0;
        for (const auto& [point, stations] : stations_of_point)
          common += stations.count(i) && stations.count(j);
        for (const auto& o : obs)
          common += 3 * ((o.station == i && o.target_station == j) ||
                         (o.station == j && o.target_station == i));
        if (common > best_common) {
          best_common = common;
          best_i = i;
          best_j = j;
        }
      }
    }
    if (best_j < 0 || !relative(best_i, best_j)) break;
  }
  intersect_known();
  for (int i = 0; i < ns; ++i) {
    if (!st[i].placed) {
      refuse("station " + station_ids[i] +
             ": no initial pose could be found from its rays (too few points shared with "
             "the other stations)");
    }
  }
  if (!refusals.empty()) return std::nullopt;

  if (local_frame && use_control) {
    // Similarity transform of the local network onto the control points.
    std::vector<Eigen::Vector3d> from, to;
    for (const auto& c : problem.control) {
      if (auto it = known.find(c.id); it != known.end()) {
        from.push_back(it->second);
        to.push_back(c.position_mm);
      }
    }
    if (from.size() < 3) {
      refuse("control points: fewer than 3 of them are intersected from the stations");
      return std::nullopt;
    }
    Eigen::Matrix3Xd a(3, from.size()), b(3, from.size());
    for (size_t k = 0; k < from.size(); ++k) {
      a.col(k) = from[k];
      b.col(k) = to[k];
    }
    const Eigen::Matrix4d t = Eigen::umeyama(a, b, true);
    const double scale = t.topLeftCorner<3, 3>().col(0).norm();
    const Eigen::Matrix3d r = t.topLeftCorner<3, 3>() / scale;
    for (auto& s : st) {
      s.position = t.topLeftCorner<3, 3>() * s.position + t.topRightCorner<3, 1>();
      s.rotation = r * s.rotation;
      if (s.levelled) s.azimuth = WrapTwoPi(-std::atan2(s.rotation(1, 0), s.rotation(0, 0)));
      Eigen::AngleAxisd aa(s.rotation);
      s.angle_axis = aa.angle() * aa.axis();
    }
    known.clear();
    for (const auto& c : problem.control) known[c.id] = c.position_mm;
    intersect_known();
  } else if (!use_control) {
    // Scale from bars and distances (median of known / current).
    std::vector<double> factors;
    for (const auto& bar : problem.scale_bars) {
      const double current = (known.at(bar.to) - known.at(bar.from)).norm();
      if (current > 0) factors.push_back(bar.length_mm / current);
    }
    for (const auto& o : obs) {
      if (!o.distance) continue;
      const Eigen::Vector3d target = o.target_station >= 0  ? st[o.target_station].position
                                     : known.count(o.point) ? known.at(o.point)
                                                            : st[o.station].position;
      const double current = (target - st[o.station].position).norm();
      if (current > 0) factors.push_back(*o.distance / current);
    }
    if (!factors.empty()) {
      std::nth_element(factors.begin(), factors.begin() + factors.size() / 2, factors.end());
      const double f = factors[factors.size() / 2];
      for (auto& s : st) s.position *= f;
      for (auto& [id, x] : known) x *= f;
    }
  }
  return InitialValues{std::move(st), std::move(known)};
}

}  // namespace armsig::reduction
