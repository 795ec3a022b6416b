// Initial values of the station orientation, found from the observations alone:
// resection from known points, relative orientation of station pairs, then the scale
// (bars, distances) or a similarity onto the control points. Internal to Orient.
#pragma once

#include <Eigen/Core>
#include <map>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "reduction/network.h"
#include "reduction/orientation.h"

namespace armsig::reduction {

// One observation of an orientation problem, indexed: face-I reading and sigmas resolved.
struct IndexedObservation {
  int station = 0;
  int target_station = -1;  // mutual pointing
  std::string point;
  double hz = 0.0, v = 0.0;
  std::optional<double> distance;
  EffectiveSigmas sigma{};
  int source = 0;  // index into problem.observations
};

// The problem indexed by Orient: stations (problem order, then order of appearance),
// observations, which rays see which point.
struct IndexedNetwork {
  std::vector<std::string> station_ids;
  std::map<std::string, int> station_index;
  std::vector<Station> station_info;  // id and a-priori sigmas
  std::map<std::string, ControlPoint> control;
  std::vector<IndexedObservation> obs;
  std::map<std::string, std::vector<int>> rays_of_point;  // indices into obs
  std::map<std::string, std::set<int>> stations_of_point;
  std::set<std::string> usable;  // points with two rays, a distance, or control
  bool use_control = false;      // two or more control points fix the datum
};

struct StationState {
  bool placed = false;
  bool levelled = true;
  Eigen::Vector3d position = Eigen::Vector3d::Zero();
  double azimuth = 0.0;
  Eigen::Matrix3d rotation = Eigen::Matrix3d::Identity();  // world_from_station
  Eigen::Vector3d angle_axis = Eigen::Vector3d::Zero();
};

struct InitialValues {
  std::vector<StationState> stations;             // by station index
  std::map<std::string, Eigen::Vector3d> points;  // approximate coordinates
};

// Approximate poses and coordinates; appends to `refusals` (and returns nullopt) when a
// station cannot be placed or the control points cannot be reached.
std::optional<InitialValues> FindInitialValues(const OrientationProblem& problem,
                                               const IndexedNetwork& network,
                                               std::vector<std::string>& refusals);

}  // namespace armsig::reduction
