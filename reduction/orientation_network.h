// The orientation problem indexed (stations, observations, which rays see which point) and
// what makes it unsolvable, said before anything is adjusted: no scale, a scale bar on a
// point that cannot be determined, control points all in one place, a station with too
// few rays to points others fix. Internal to Orient.
#pragma once

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
  std::vector<int> obs_of_source;  // index into obs of each problem observation (−1: refused)
  std::map<std::string, std::vector<int>> rays_of_point;  // indices into obs
  std::map<std::string, std::set<int>> stations_of_point;
  std::set<std::string> usable;  // points with two rays, a distance, or control
  bool use_control = false;      // two or more control points fix the datum
  int fixed_control = 0;         // control points without sigmas
};

// Indexes the problem; appends to `refusals` what makes it inconsistent (a station listed
// twice, a control point given twice, a station sighting itself).
IndexedNetwork IndexNetwork(const OrientationProblem& problem, std::vector<std::string>& refusals);

// Appends to `refusals` every reason the indexed network cannot be solved.
void RefuseUnsolvable(const OrientationProblem& problem, const IndexedNetwork& network,
                      std::vector<std::string>& refusals);

}  // namespace armsig::reduction
