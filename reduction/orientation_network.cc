#include "reduction/orientation_network.h"

#include <Eigen/Eigenvalues>

#include "reduction/observation.h"

namespace armsig::reduction {

namespace {

// Stations in datum order: the problem's list, then those that only appear in observations.
void IndexStations(const OrientationProblem& problem, IndexedNetwork& network,
                   std::vector<std::string>& refusals) {
  for (const auto& id : problem.station_ids) {
    if (!network.station_index.emplace(id, static_cast<int>(network.station_ids.size())).second) {
      refusals.push_back("station " + id + " is listed twice");
      continue;
    }
    network.station_ids.push_back(id);
  }
  for (const auto& obs : problem.observations) {
    if (network.station_index.emplace(obs.station, static_cast<int>(network.station_ids.size()))
            .second) {
      network.station_ids.push_back(obs.station);
    }
  }
  const int ns = static_cast<int>(network.station_ids.size());
  network.station_info.resize(ns);
  for (int i = 0; i < ns; ++i) {
    Station& s = network.station_info[i];
    s.pose.id = network.station_ids[i];
    if (auto it = problem.sigma_hz_rad.find(s.pose.id); it != problem.sigma_hz_rad.end())
      s.sigma_hz_rad = it->second;
    if (auto it = problem.sigma_v_rad.find(s.pose.id); it != problem.sigma_v_rad.end())
      s.sigma_v_rad = it->second;
  }
}

// The control points fix position, orientation and scale only when they are spread: all in
// one place they fix no azimuth and no scale; on one line, no rotation about it when no
// station is levelled.
void RefuseClusteredControl(const OrientationProblem& problem, const IndexedNetwork& network,
                            std::vector<std::string>& refusals) {
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (const auto& c : problem.control) mean += c.position_mm;
  mean /= static_cast<double>(problem.control.size());
  Eigen::Matrix3d scatter = Eigen::Matrix3d::Zero();
  for (const auto& c : problem.control) {
    scatter += (c.position_mm - mean) * (c.position_mm - mean).transpose();
  }
  const Eigen::Vector3d spread = Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(scatter)
                                     .eigenvalues()
                                     .cwiseMax(0)
                                     .cwiseSqrt();
  bool all_unlevelled = !network.station_ids.empty();
  for (const auto& id : network.station_ids) all_unlevelled &= problem.unlevelled.count(id) > 0;
  constexpr double kSpreadMm = 1e-3;  // a µm: below any survey, above rounding
  if (!(spread(2) > kSpreadMm)) {
    refusals.push_back(
        "the control points all lie in one place: they fix no orientation and no scale "
        "(give control points at different places)");
  } else if (all_unlevelled && !(spread(1) > kSpreadMm)) {
    refusals.push_back(
        "the control points lie on one line and no station is levelled: the network can "
        "turn about that line (give a control point off the line)");
  }
}

// A scale from bars, distances or control; bars between two determinable points.
void RefuseWithoutScale(const OrientationProblem& problem, const IndexedNetwork& network,
                        std::vector<std::string>& refusals) {
  bool has_distance = false;
  for (const auto& o : network.obs) has_distance |= o.distance.has_value();
  if (problem.scale_bars.empty() && !has_distance && !network.use_control) {
    refusals.push_back(
        "no scale: give a scale bar (--scale-bar A:B=LEN_MM), distances, or control points "
        "(--control)");
  }
  // Constraints between two things must join two different ones: Ceres is never given one
  // parameter block twice (it aborts the process on that).
  for (const auto& bar : problem.scale_bars) {
    if (bar.from == bar.to) {
      refusals.push_back("scale bar " + bar.from + ":" + bar.to +
                         ": both ends are the same point");
      continue;
    }
    for (const auto* end : {&bar.from, &bar.to}) {
      if (!network.usable.count(*end)) {
        refusals.push_back("scale bar " + bar.from + ":" + bar.to + ": point " + *end +
                           (network.rays_of_point.count(*end) ? " has only one ray"
                                                              : " is never observed"));
      }
    }
  }
}

// Every station observed, and tied to the others by enough rays (the datum station needs
// none when no control fixes the datum).
void RefuseLooseStations(const OrientationProblem& problem, const IndexedNetwork& network,
                         std::vector<std::string>& refusals) {
  const int ns = static_cast<int>(network.station_ids.size());
  for (int i = 0; i < ns; ++i) {
    bool observed = false;
    for (const auto& o : network.obs) observed |= o.station == i || o.target_station == i;
    if (!observed) refusals.push_back("station " + network.station_ids[i] + " has no observations");
  }
  for (int i = 0; i < ns; ++i) {
    if (i == 0 && !network.use_control) continue;  // the datum station
    int tie = 0;
    for (const auto& o : network.obs) {
      if (o.station == i) {
        tie += o.target_station >= 0 || network.stations_of_point.at(o.point).size() >= 2 ||
               network.control.count(o.point);
      } else if (o.target_station == i) {
        ++tie;
      }
    }
    const int needed = problem.unlevelled.count(network.station_ids[i]) ? 3 : 2;
    if (tie < needed) {
      refusals.push_back("station " + network.station_ids[i] + " has " + std::to_string(tie) +
                         " rays to points other stations or control points fix (needs at least " +
                         std::to_string(needed) + ")");
    }
  }
}

}  // namespace

IndexedNetwork IndexNetwork(const OrientationProblem& problem, std::vector<std::string>& refusals) {
  IndexedNetwork network;
  IndexStations(problem, network, refusals);
  for (const auto& c : problem.control) {
    if (!network.control.emplace(c.id, c).second)
      refusals.push_back("control point " + c.id + " is given twice");
    network.fixed_control += !c.sigma_mm.has_value();
  }
  network.use_control = problem.control.size() >= 2;
  network.obs_of_source.assign(problem.observations.size(), -1);
  for (size_t k = 0; k < problem.observations.size(); ++k) {
    const Observation& o = problem.observations[k];
    IndexedObservation x;
    x.station = network.station_index.at(o.station);
    const AngleReading face1 = ToFaceOne(o.reading);
    x.hz = face1.hz_rad;
    x.v = face1.v_rad;
    x.distance = o.distance_mm;
    x.sigma = SigmasOf(o, &network.station_info[x.station], problem.defaults);
    x.source = static_cast<int>(k);
    x.point = o.point;
    if (auto it = network.station_index.find(o.point); it != network.station_index.end()) {
      x.target_station = it->second;
      if (x.target_station == x.station) {
        refusals.push_back("observation " + std::to_string(k + 1) + ": station " + o.station +
                           " sights itself");
        continue;
      }
    } else {
      network.rays_of_point[o.point].push_back(static_cast<int>(network.obs.size()));
      network.stations_of_point[o.point].insert(x.station);
    }
    network.obs_of_source[k] = static_cast<int>(network.obs.size());
    network.obs.push_back(x);
  }
  // Points that cannot be determined: one ray without distance and not a control point.
  for (const auto& [point, rays] : network.rays_of_point) {
    bool distance = false;
    for (int r : rays) distance |= network.obs[r].distance.has_value();
    if (rays.size() >= 2 || distance || network.control.count(point)) network.usable.insert(point);
  }
  return network;
}

void RefuseUnsolvable(const OrientationProblem& problem, const IndexedNetwork& network,
                      std::vector<std::string>& refusals) {
  RefuseWithoutScale(problem, network, refusals);
  if (network.use_control) RefuseClusteredControl(problem, network, refusals);
  RefuseLooseStations(problem, network, refusals);
}

}  // namespace armsig::reduction
