#include "reduction/orientation.h"

#include <ceres/ceres.h>
#include <ceres/rotation.h>

#include <Eigen/Eigenvalues>
#include <Eigen/SVD>
#include <Eigen/SparseCholesky>
#include <algorithm>
#include <cmath>
#include <functional>
#include <stdexcept>

#include "core/units.h"
#include "reduction/observation.h"

namespace armsig::reduction {

void OrientationOptions::Check() const {
  if (max_iterations < 1) throw std::invalid_argument("max_iterations must be ≥ 1");
  if (!(critical_w > 0)) throw std::invalid_argument("critical_w must be > 0");
}

namespace {

constexpr double kArcsecPerRad = 1.0 / kRadPerArcsec;

// ---------------------------------------------------------------------------------
// Ceres residuals (whitened: divided by the a-priori sigma).

// Hz and V of a point (or another station's centre) seen from a station.
// kOrientationSize 1: levelled, the azimuth (world_from_station = Rz(−azimuth));
// 3: angle-axis of world_from_station.
template <int kOrientationSize>
struct AngleResidual {
  AngleResidual(double hz, double v, double sigma_hz, double sigma_v)
      : hz(hz), v(v), sigma_hz(sigma_hz), sigma_v(sigma_v) {}

  template <typename T>
  bool operator()(const T* station, const T* orientation, const T* point, T* residual) const {
    const T world[3] = {point[0] - station[0], point[1] - station[1], point[2] - station[2]};
    T d[3];
    if constexpr (kOrientationSize == 1) {
      // station_from_world = Rz(azimuth).
      const T c = cos(orientation[0]), s = sin(orientation[0]);
      d[0] = c * world[0] - s * world[1];
      d[1] = s * world[0] + c * world[1];
      d[2] = world[2];
    } else {
      const T inverse[3] = {-orientation[0], -orientation[1], -orientation[2]};
      ceres::AngleAxisRotatePoint(inverse, world, d);
    }
    const T delta_hz = atan2(d[0], d[1]) - T(hz);
    residual[0] = atan2(sin(delta_hz), cos(delta_hz)) / T(sigma_hz);
    residual[1] = (atan2(sqrt(d[0] * d[0] + d[1] * d[1]), d[2]) - T(v)) / T(sigma_v);
    return true;
  }

  static ceres::CostFunction* Create(double hz, double v, double sigma_hz, double sigma_v) {
    return new ceres::AutoDiffCostFunction<AngleResidual, 2, 3, kOrientationSize, 3>(
        new AngleResidual(hz, v, sigma_hz, sigma_v));
  }

  double hz, v, sigma_hz, sigma_v;
};

// A slope distance, or a scale-bar length, between two 3-vectors.
struct LengthResidual {
  LengthResidual(double length, double sigma) : length(length), sigma(sigma) {}
  template <typename T>
  bool operator()(const T* a, const T* b, T* residual) const {
    const T dx = b[0] - a[0], dy = b[1] - a[1], dz = b[2] - a[2];
    residual[0] = (sqrt(dx * dx + dy * dy + dz * dz) - T(length)) / T(sigma);
    return true;
  }
  static ceres::CostFunction* Create(double length, double sigma) {
    return new ceres::AutoDiffCostFunction<LengthResidual, 1, 3, 3>(
        new LengthResidual(length, sigma));
  }
  double length, sigma;
};

// A weighted control point.
struct ControlResidual {
  ControlResidual(Eigen::Vector3d known, Eigen::Vector3d sigma) : known(known), sigma(sigma) {}
  template <typename T>
  bool operator()(const T* x, T* residual) const {
    for (int i = 0; i < 3; ++i) residual[i] = (x[i] - T(known(i))) / T(sigma(i));
    return true;
  }
  static ceres::CostFunction* Create(const Eigen::Vector3d& known, const Eigen::Vector3d& sigma) {
    return new ceres::AutoDiffCostFunction<ControlResidual, 3, 3>(
        new ControlResidual(known, sigma));
  }
  Eigen::Vector3d known, sigma;
};

// ---------------------------------------------------------------------------------
// Initial values.

struct StationState {
  bool placed = false;
  bool levelled = true;
  Eigen::Vector3d position = Eigen::Vector3d::Zero();
  double azimuth = 0.0;
  Eigen::Matrix3d rotation = Eigen::Matrix3d::Identity();  // world_from_station
  Eigen::Vector3d angle_axis = Eigen::Vector3d::Zero();
};

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

}  // namespace

OrientationResult Orient(const OrientationProblem& problem, const OrientationOptions& options) {
  options.Check();
  OrientationResult result;
  auto refuse = [&](std::string why) { result.refusals.push_back(std::move(why)); };

  // --- Index stations, points and observations.
  std::vector<std::string> station_ids = problem.station_ids;
  std::map<std::string, int> station_index;
  for (const auto& id : station_ids)
    station_index.emplace(id, static_cast<int>(station_index.size()));
  for (const auto& obs : problem.observations) {
    if (!station_index.count(obs.station)) {
      station_index.emplace(obs.station, static_cast<int>(station_ids.size()));
      station_ids.push_back(obs.station);
    }
  }
  const int ns = static_cast<int>(station_ids.size());
  std::vector<Station> station_info(ns);
  for (int i = 0; i < ns; ++i) {
    station_info[i].pose.id = station_ids[i];
    if (auto it = problem.sigma_hz_rad.find(station_ids[i]); it != problem.sigma_hz_rad.end())
      station_info[i].sigma_hz_rad = it->second;
    if (auto it = problem.sigma_v_rad.find(station_ids[i]); it != problem.sigma_v_rad.end())
      station_info[i].sigma_v_rad = it->second;
  }
  std::map<std::string, ControlPoint> control;
  for (const auto& c : problem.control) control[c.id] = c;

  struct Obs {
    int station;
    int target_station = -1;  // mutual pointing
    std::string point;
    double hz, v, distance;
    EffectiveSigmas sigma;
    int source;
  };
  std::vector<Obs> obs;
  std::map<std::string, std::vector<int>> rays_of_point;
  std::map<std::string, std::set<int>> stations_of_point;
  for (size_t k = 0; k < problem.observations.size(); ++k) {
    const Observation& o = problem.observations[k];
    Obs x;
    x.station = station_index.at(o.station);
    const AngleReading face1 = ToFaceOne(o.reading);
    x.hz = face1.hz_rad;
    x.v = face1.v_rad;
    x.distance = o.distance_mm ? *o.distance_mm : NAN;
    x.sigma = SigmasOf(o, &station_info[x.station], problem.defaults);
    x.source = static_cast<int>(k);
    x.point = o.point;
    if (auto it = station_index.find(o.point); it != station_index.end()) {
      x.target_station = it->second;
      if (x.target_station == x.station) {
        refuse("observation " + std::to_string(k + 1) + ": station " + o.station +
               " sights itself");
        continue;
      }
    } else {
      rays_of_point[o.point].push_back(static_cast<int>(obs.size()));
      stations_of_point[o.point].insert(x.station);
    }
    obs.push_back(x);
  }

  // Points that cannot be determined: one ray without distance and not a control point.
  std::set<std::string> usable;
  for (const auto& [point, rays] : rays_of_point) {
    bool distance = false;
    for (int r : rays) distance |= std::isfinite(obs[r].distance);
    if (rays.size() >= 2 || distance || control.count(point)) usable.insert(point);
  }

  // --- Refusals: scale, rays per station, scale-bar end points.
  int fixed_control = 0;
  for (const auto& c : problem.control) fixed_control += !c.sigma_mm.has_value();
  bool has_distance = false;
  for (const auto& o : obs) has_distance |= std::isfinite(o.distance);
  const bool use_control = problem.control.size() >= 2;
  if (problem.scale_bars.empty() && !has_distance && !use_control) {
    refuse(
        "no scale: give a scale bar (--scale-bar A:B=LEN_MM), distances, or control points "
        "(--control)");
  }
  for (const auto& bar : problem.scale_bars) {
    for (const auto* end : {&bar.from, &bar.to}) {
      if (!usable.count(*end)) {
        refuse("scale bar " + bar.from + ":" + bar.to + ": point " + *end +
               (rays_of_point.count(*end) ? " has only one ray" : " is never observed"));
      }
    }
  }
  for (int i = 0; i < ns; ++i) {
    const bool levelled = !problem.unlevelled.count(station_ids[i]);
    if (i == 0 && !use_control) continue;  // the datum station
    int tie = 0;
    for (const auto& o : obs) {
      if (o.station == i) {
        if (o.target_station >= 0)
          ++tie;
        else if (stations_of_point[o.point].size() >= 2 || control.count(o.point))
          ++tie;
      } else if (o.target_station == i) {
        ++tie;
      }
    }
    const int needed = levelled ? 2 : 3;
    if (tie < needed) {
      refuse("station " + station_ids[i] + " has " + std::to_string(tie) +
             " rays to points other stations or control points fix (needs at least " +
             std::to_string(needed) + ")");
    }
  }
  if (!result.refusals.empty()) return result;

  // --- Initial values.
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
        if (std::isfinite(o.distance)) {
          polar += st[o.station].position + o.distance * u;
          ++polar_count;
        }
      }
      if (polar_count > 0) {
        known[point] = polar / polar_count;
      } else if (origins.size() >= 2) {
        bool spread = false;
        for (size_t a = 0; a < dirs.size() && !spread; ++a)
          for (size_t b = a + 1; b < dirs.size(); ++b)
            spread |= dirs[a].cross(dirs[b]).norm() > 1e-3;
        if (spread) known[point] = ClosestPointOfLines(origins, dirs, nullptr);
      }
    }
  };

  // Resection of station i from known points and placed stations it sights or that sight it.
  auto try_resect = [&](int i) {
    std::vector<Eigen::Vector3d> points, dirs;
    for (const auto& o : obs) {
      if (o.station != i) continue;
      if (o.target_station >= 0) {
        if (st[o.target_station].placed) {
          points.push_back(st[o.target_station].position);
          dirs.push_back(dir_in_station(o));
        }
      } else if (auto it = known.find(o.point); it != known.end()) {
        points.push_back(it->second);
        dirs.push_back(dir_in_station(o));
      }
    }
    if (!st[i].levelled && ResectUnlevelled(points, dirs, st[i])) return true;
    if (points.size() < 2) return false;
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
    if (ij && std::isfinite(ij->distance))
      length = ij->distance;
    else if (ji && std::isfinite(ji->distance))
      length = ji->distance;

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
  if (!result.refusals.empty()) return result;

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
      return result;
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
      if (!std::isfinite(o.distance)) continue;
      const Eigen::Vector3d target = o.target_station >= 0  ? st[o.target_station].position
                                     : known.count(o.point) ? known.at(o.point)
                                                            : st[o.station].position;
      const double current = (target - st[o.station].position).norm();
      if (current > 0) factors.push_back(o.distance / current);
    }
    if (!factors.empty()) {
      std::nth_element(factors.begin(), factors.begin() + factors.size() / 2, factors.end());
      const double f = factors[factors.size() / 2];
      for (auto& s : st) s.position *= f;
      for (auto& [id, x] : known) x *= f;
    }
  }

  // --- The bundle. Coordinates are shifted to the first station's start so that large
  // coordinates (1e7 mm) keep their precision; shifted back at the end.
  const Eigen::Vector3d offset = st[0].position;
  std::vector<Eigen::Vector3d> station_pos(ns);
  std::vector<Eigen::Vector3d> station_rot(ns);  // azimuth in [0] or angle-axis
  for (int i = 0; i < ns; ++i) {
    station_pos[i] = st[i].position - offset;
    station_rot[i] = st[i].levelled ? Eigen::Vector3d(st[i].azimuth, 0, 0) : st[i].angle_axis;
  }
  std::vector<std::string> point_ids;
  std::map<std::string, int> point_index;
  for (const auto& id : usable) {
    if (!known.count(id)) continue;
    point_index[id] = static_cast<int>(point_ids.size());
    point_ids.push_back(id);
  }
  for (const auto& [id, rays] : rays_of_point) {
    if (!usable.count(id)) {
      result.excluded_points.push_back({id, "one ray and no distance"});
    } else if (!point_index.count(id)) {
      result.excluded_points.push_back({id, "rays nearly parallel: no approximate position"});
    }
  }
  std::vector<Eigen::Vector3d> point_pos(point_ids.size());
  for (size_t k = 0; k < point_ids.size(); ++k) point_pos[k] = known.at(point_ids[k]) - offset;

  ceres::Problem::Options problem_options;
  ceres::Problem bundle(problem_options);
  struct Row {
    ResidualReport::Kind kind;
    int source;
    std::string label;
    double sigma;  // a priori, report units (arcsec or mm): whitened residual × sigma = residual
    std::string group;
  };
  std::vector<ceres::ResidualBlockId> blocks;
  std::vector<std::vector<Row>> block_rows;
  for (const auto& o : obs) {
    double* point = nullptr;
    if (o.target_station >= 0)
      point = station_pos[o.target_station].data();
    else if (auto it = point_index.find(o.point); it != point_index.end())
      point = point_pos[it->second].data();
    else
      continue;  // one-ray point: reported, not adjusted
    ceres::CostFunction* cost =
        st[o.station].levelled ? AngleResidual<1>::Create(o.hz, o.v, o.sigma.hz_rad, o.sigma.v_rad)
                               : AngleResidual<3>::Create(o.hz, o.v, o.sigma.hz_rad, o.sigma.v_rad);
    blocks.push_back(bundle.AddResidualBlock(cost, nullptr, station_pos[o.station].data(),
                                             station_rot[o.station].data(), point));
    const std::string label = station_ids[o.station] + "->" + o.point;
    const std::string group = o.target_station >= 0 ? "mutual pointings" : "angles";
    block_rows.push_back(
        {{ResidualReport::Kind::kHz, o.source, label, o.sigma.hz_rad * kArcsecPerRad, group},
         {ResidualReport::Kind::kV, o.source, label, o.sigma.v_rad * kArcsecPerRad, group}});
    if (std::isfinite(o.distance)) {
      blocks.push_back(
          bundle.AddResidualBlock(LengthResidual::Create(o.distance, o.sigma.distance_mm), nullptr,
                                  station_pos[o.station].data(), point));
      block_rows.push_back(
          {{ResidualReport::Kind::kDistance, o.source, label, o.sigma.distance_mm, "distances"}});
    }
  }
  for (size_t b = 0; b < problem.scale_bars.size(); ++b) {
    const auto& bar = problem.scale_bars[b];
    blocks.push_back(bundle.AddResidualBlock(LengthResidual::Create(bar.length_mm, bar.sigma_mm),
                                             nullptr, point_pos[point_index.at(bar.from)].data(),
                                             point_pos[point_index.at(bar.to)].data()));
    block_rows.push_back({{ResidualReport::Kind::kScaleBar, static_cast<int>(b),
                           bar.from + ":" + bar.to, bar.sigma_mm, "scale bars"}});
  }
  std::string datum;
  for (size_t c = 0; c < problem.control.size(); ++c) {
    const auto& cp = problem.control[c];
    auto it = point_index.find(cp.id);
    if (it == point_index.end()) continue;
    double* x = point_pos[it->second].data();
    if (cp.sigma_mm) {
      blocks.push_back(bundle.AddResidualBlock(
          ControlResidual::Create(cp.position_mm - offset, *cp.sigma_mm), nullptr, x));
      std::vector<Row> rows;
      for (int i = 0; i < 3; ++i) {
        rows.push_back({ResidualReport::Kind::kControl, static_cast<int>(c), cp.id,
                        (*cp.sigma_mm)(i), "control"});
      }
      block_rows.push_back(rows);
    } else {
      bundle.SetParameterBlockConstant(x);
    }
  }
  if (use_control) {
    datum = "control points (" + std::to_string(fixed_control) + " fixed, " +
            std::to_string(problem.control.size() - fixed_control) + " weighted)";
  } else {
    // SPEC datum: the first station at the origin, levelled, circle zero = azimuth 0.
    // Fixing its position and azimuth removes exactly the 4 degrees of freedom a levelled
    // network has; the scale comes from bars and distances.
    bundle.SetParameterBlockConstant(station_pos[0].data());
    bundle.SetParameterBlockConstant(station_rot[0].data());
    datum = "station " + station_ids[0] + " at the origin, levelled, azimuth 0";
  }
  result.datum = datum;

  ceres::Solver::Options solver_options;
  solver_options.linear_solver_type = ceres::DENSE_SCHUR;
  solver_options.max_num_iterations = options.max_iterations;
  solver_options.function_tolerance = 1e-14;
  solver_options.gradient_tolerance = 1e-14;
  solver_options.parameter_tolerance = 1e-14;
  solver_options.num_threads = 1;
  solver_options.logging_type = ceres::SILENT;
  ceres::Solver::Summary summary;
  ceres::Solve(solver_options, &bundle, &summary);
  result.iterations = static_cast<int>(summary.iterations.size());
  result.converged = summary.termination_type == ceres::CONVERGENCE;

  // --- Statistics from the whitened Jacobian at the solution.
  std::vector<double*> free_blocks;
  std::map<const double*, int> column_of;
  int columns = 0;
  auto add_block = [&](double* block, int size) {
    if (bundle.IsParameterBlockConstant(block)) return;
    column_of[block] = columns;
    columns += size;
    free_blocks.push_back(block);
  };
  for (int i = 0; i < ns; ++i) {
    add_block(station_pos[i].data(), 3);
    add_block(station_rot[i].data(), st[i].levelled ? 1 : 3);
  }
  for (auto& p : point_pos) {
    if (bundle.HasParameterBlock(p.data())) add_block(p.data(), 3);
  }
  ceres::Problem::EvaluateOptions eval;
  eval.parameter_blocks = free_blocks;
  eval.residual_blocks = blocks;
  eval.apply_loss_function = false;
  std::vector<double> residuals;
  ceres::CRSMatrix crs;
  bundle.Evaluate(eval, nullptr, &residuals, nullptr, &crs);
  Eigen::SparseMatrix<double> j(crs.num_rows, crs.num_cols);
  {
    std::vector<Eigen::Triplet<double>> triplets;
    for (int r = 0; r < crs.num_rows; ++r) {
      for (int idx = crs.rows[r]; idx < crs.rows[r + 1]; ++idx) {
        triplets.emplace_back(r, crs.cols[idx], crs.values[idx]);
      }
    }
    j.setFromTriplets(triplets.begin(), triplets.end());
  }
  const Eigen::SparseMatrix<double> normal = Eigen::SparseMatrix<double>(j.transpose()) * j;
  Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> ldlt(normal);
  // Singularity test on the column-scaled normal matrix (units differ: mm and rad).
  {
    // Adjusted target points all on one line: the likely cause, named in the message.
    bool targets_collinear = false;
    std::vector<Eigen::Vector3d> pts;
    for (size_t k = 0; k < point_ids.size(); ++k) {
      if (!control.count(point_ids[k])) pts.push_back(point_pos[k]);
    }
    if (pts.size() >= 2) {
      Eigen::Vector3d mean = Eigen::Vector3d::Zero();
      for (const auto& p : pts) mean += p;
      mean /= pts.size();
      Eigen::Matrix3d scatter = Eigen::Matrix3d::Zero();
      for (const auto& p : pts) scatter += (p - mean) * (p - mean).transpose();
      Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(scatter);
      targets_collinear = eig.eigenvalues()(1) < 1e-6 * eig.eigenvalues()(2);
    }
    Eigen::VectorXd scale = normal.diagonal().cwiseMax(1e-300).cwiseSqrt().cwiseInverse();
    const Eigen::SparseMatrix<double> scaled = scale.asDiagonal() * normal * scale.asDiagonal();
    Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> check(scaled);
    const bool singular = check.info() != Eigen::Success || ldlt.info() != Eigen::Success ||
                          check.vectorD().minCoeff() < 1e-8;  // healthy networks: ~1e-3
    if (singular) {
      refuse(targets_collinear
                 ? "all target points lie on one line: the stations can turn about it, the "
                   "network has no unique shape (add targets off the line, distances or mutual "
                   "pointings)"
                 : "the network is singular: its shape, datum or scale is not determined by "
                   "the observations");
      return result;
    }
  }
  Eigen::MatrixXd q = ldlt.solve(Eigen::MatrixXd::Identity(columns, columns));

  result.observations = crs.num_rows;
  result.unknowns = columns;
  result.dof = result.observations - result.unknowns;
  double vtpv = 0.0;
  for (double r : residuals) vtpv += r * r;
  result.sigma0 = result.dof > 0 ? std::sqrt(vtpv / result.dof) : 0.0;

  const Eigen::SparseMatrix<double, Eigen::RowMajor> jr(j);
  std::map<std::string, GroupVariance> groups;
  int row = 0;
  for (size_t b = 0; b < block_rows.size(); ++b) {
    for (const Row& meta : block_rows[b]) {
      // r_i = 1 − a_i Q a_iᵀ over the few columns a_i touches.
      double aqa = 0.0;
      for (Eigen::SparseMatrix<double, Eigen::RowMajor>::InnerIterator a(jr, row); a; ++a) {
        for (Eigen::SparseMatrix<double, Eigen::RowMajor>::InnerIterator c(jr, row); c; ++c) {
          aqa += a.value() * q(a.col(), c.col()) * c.value();
        }
      }
      const double redundancy = std::max(0.0, 1.0 - aqa);
      ResidualReport rep;
      rep.kind = meta.kind;
      rep.observation = meta.source;
      rep.label = meta.label;
      rep.residual = residuals[row] * meta.sigma;
      rep.sigma = meta.sigma;
      rep.redundancy = redundancy;
      rep.w = redundancy > 1e-6 ? residuals[row] / std::sqrt(redundancy) : 0.0;
      rep.mdb = redundancy > 1e-6 ? meta.sigma * options.delta0 / std::sqrt(redundancy) : INFINITY;
      result.residuals.push_back(rep);
      auto& g = groups[meta.group];
      g.group = meta.group;
      ++g.count;
      g.redundancy += redundancy;
      g.sigma0 += residuals[row] * residuals[row];  // Σv² for now
      ++row;
    }
  }
  for (auto& [name, g] : groups) {
    g.sigma0 = g.redundancy > 1e-9 ? std::sqrt(g.sigma0 / g.redundancy) : 0.0;
    result.groups.push_back(g);
  }

  // --- Free network: S-transformation of the covariance to the inner-constraint datum.
  if (problem.free_datum && !use_control) {
    struct Block {
      double* data;
      int size;
      int kind;  // 0 position, 1 azimuth, 2 angle-axis
      std::string id;
    };
    std::vector<Block> all;
    for (int i = 0; i < ns; ++i) {
      all.push_back({station_pos[i].data(), 3, 0, station_ids[i]});
      all.push_back(
          {station_rot[i].data(), st[i].levelled ? 1 : 3, st[i].levelled ? 1 : 2, station_ids[i]});
    }
    for (size_t k = 0; k < point_ids.size(); ++k)
      all.push_back({point_pos[k].data(), 3, 0, point_ids[k]});
    std::map<const double*, int> full_of;
    int nf = 0;
    for (const auto& b : all) {
      full_of[b.data] = nf;
      nf += b.size;
    }
    Eigen::MatrixXd qf = Eigen::MatrixXd::Zero(nf, nf);
    for (const auto& a : all) {
      auto ia = column_of.find(a.data);
      if (ia == column_of.end()) continue;
      for (const auto& b : all) {
        auto ib = column_of.find(b.data);
        if (ib == column_of.end()) continue;
        qf.block(full_of[a.data], full_of[b.data], a.size, b.size) =
            q.block(ia->second, ib->second, a.size, b.size);
      }
    }
    auto in_datum = [&](const Block& b) {
      return b.kind == 0 && (problem.datum_points.empty() || problem.datum_points.count(b.id));
    };
    Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
    int count = 0;
    for (const auto& b : all) {
      if (in_datum(b)) {
        centroid += Eigen::Map<Eigen::Vector3d>(b.data);
        ++count;
      }
    }
    if (count >= 2) {
      centroid /= count;
      // G: how a translation (x, y, z) and a rotation about z move every unknown.
      Eigen::MatrixXd g = Eigen::MatrixXd::Zero(nf, 4);
      Eigen::VectorXd e = Eigen::VectorXd::Zero(nf);
      for (const auto& b : all) {
        const int i = full_of[b.data];
        if (b.kind == 0) {
          const Eigen::Vector3d x = Eigen::Map<Eigen::Vector3d>(b.data) - centroid;
          g.block<3, 3>(i, 0).setIdentity();
          g(i, 3) = -x.y();
          g(i + 1, 3) = x.x();
          if (in_datum(b)) e.segment<3>(i).setOnes();
        } else if (b.kind == 1) {
          g(i, 3) = -1.0;  // turning the frame by ω about z lowers every azimuth by ω
        } else {
          g(i + 2, 3) = 1.0;  // small-angle approximation for a free rotation
        }
      }
      const Eigen::MatrixXd ge = e.asDiagonal() * g;
      const Eigen::Matrix4d m = g.transpose() * ge;
      const Eigen::MatrixXd sm =
          Eigen::MatrixXd::Identity(nf, nf) - g * m.ldlt().solve(ge.transpose());
      q = sm * qf * sm.transpose();
      column_of = full_of;
      result.datum += "; covariance by inner constraints over " +
                      (problem.datum_points.empty() ? std::string("all points and stations")
                                                    : std::to_string(count) + " datum points");
    }
  }

  // --- Results back in the input frame.
  for (int i = 0; i < ns; ++i) {
    Station s = station_info[i];
    s.pose.levelled = st[i].levelled;
    s.pose.position_mm = station_pos[i] + offset;
    if (st[i].levelled) {
      s.pose.azimuth_rad = WrapTwoPi(station_rot[i](0));
      s.pose.world_from_station = LevelledRotation(s.pose.azimuth_rad);
    } else {
      double r[9];
      ceres::AngleAxisToRotationMatrix(station_rot[i].data(), ceres::ColumnMajorAdapter3x3(r));
      s.pose.world_from_station = Eigen::Map<Eigen::Matrix3d>(r);
    }
    if (auto it = column_of.find(station_pos[i].data()); it != column_of.end()) {
      for (int k = 0; k < 3; ++k)
        s.sigma_position_mm(k) = std::sqrt(q(it->second + k, it->second + k));
    }
    if (auto it = column_of.find(station_rot[i].data()); it != column_of.end()) {
      if (st[i].levelled)
        s.sigma_azimuth_rad = std::sqrt(q(it->second, it->second));
      else
        for (int k = 0; k < 3; ++k)
          s.sigma_rotation_rad(k) = std::sqrt(q(it->second + k, it->second + k));
    }
    result.stations.push_back(s);
  }
  for (size_t k = 0; k < point_ids.size(); ++k) {
    PointEstimate p;
    p.id = point_ids[k];
    p.position_mm = point_pos[k] + offset;
    p.rays = static_cast<int>(rays_of_point[p.id].size());
    p.control = control.count(p.id) > 0;
    if (auto it = column_of.find(point_pos[k].data()); it != column_of.end()) {
      p.covariance_mm2 = q.block<3, 3>(it->second, it->second);
    }
    result.points.push_back(p);
  }
  result.ok = true;
  return result;
}

}  // namespace armsig::reduction
