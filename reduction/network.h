// Observations, stations and results of a theodolite / laser-tracker network.
// Pure data: loaders live in io/, the database in db/.
#pragma once

#include <Eigen/Core>
#include <optional>
#include <string>
#include <vector>

#include "core/types.h"

namespace armsig::reduction {

// One ray: a reading of `point` from `station` (face I or II), optional slope distance.
struct Observation {
  std::string point;
  std::string station;
  AngleReading reading;
  std::optional<double> distance_mm;
  // A-priori standard deviations; absent = the station's, else the defaults.
  std::optional<double> sigma_hz_rad, sigma_v_rad, sigma_distance_mm;
  int source_line = 0;            // for messages: line of the file it came from
  int source_station_column = 0;  // and the column of its station id (0: unknown)
};

struct Station {
  StationPose pose;  // id, position, world_from_station, levelled, azimuth
  std::optional<double> sigma_hz_rad, sigma_v_rad;  // a-priori reading sigmas, if given
  // Precision after orientation (zero when fixed / given).
  Eigen::Vector3d sigma_position_mm = Eigen::Vector3d::Zero();
  double sigma_azimuth_rad = 0.0;
  Eigen::Vector3d sigma_rotation_rad = Eigen::Vector3d::Zero();  // unlevelled
  // The adjustment that oriented it (armsig orient, the demo), when known: σ0 a
  // posteriori, its degrees of freedom and how (mutual+scale_bar, control, …). Carried by
  // the stations file into the set-ups a session stores.
  std::optional<double> orientation_sigma0{};
  int orientation_dof = 0;
  std::string orientation_method{};
};

// Defaults when neither the observation nor its station gives a sigma.
struct InstrumentDefaults {
  double sigma_hz_rad = 0.5 * 4.84813681109536e-6;  // 0.5″
  double sigma_v_rad = 0.5 * 4.84813681109536e-6;
  double sigma_distance_mm = 0.5;
};

// Effective sigmas of an observation: its own, else its station's, else the defaults.
struct EffectiveSigmas {
  double hz_rad, v_rad, distance_mm;
};
EffectiveSigmas SigmasOf(const Observation& obs, const Station* station,
                         const InstrumentDefaults& defaults);

// A length between two target points (a scale bar).
struct ScaleBar {
  std::string from, to;
  double length_mm = 0.0;
  double sigma_mm = 0.005;
};

// A point with known coordinates; held fixed unless sigmas are given.
struct ControlPoint {
  std::string id;
  Eigen::Vector3d position_mm = Eigen::Vector3d::Zero();
  std::optional<Eigen::Vector3d> sigma_mm;  // nullopt = fixed
};

// χ²(3) 95 % quantile: the 95 % error ellipsoid's semi-axes are 2.7955·√λ.
inline constexpr double kEllipsoid95Scale = 2.7954834829151074;

struct ErrorEllipsoid {
  Eigen::Vector3d semi_axes_mm = Eigen::Vector3d::Zero();  // 95 %, descending
  Eigen::Matrix3d axes = Eigen::Matrix3d::Identity();      // columns: directions
};
ErrorEllipsoid EllipsoidOf(const Eigen::Matrix3d& covariance_mm2);

}  // namespace armsig::reduction
