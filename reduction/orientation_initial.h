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
#include "reduction/orientation_network.h"

namespace armsig::reduction {

// Beyond this angle (about 2 gon) a ray cannot be one of its point's rays, even in the
// rough geometry of initial values: a blunder (a misread digit, a confused face, a wrong
// point), left out of a start so that it cannot carry the others away.
inline constexpr double kStartOutlierRad = 0.03;

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
