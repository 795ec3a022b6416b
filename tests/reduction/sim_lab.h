// A simulated theodolite lab with known truth: levelled stations 3–4 m from a 2 m
// work volume, readings with 0.5″ noise.
#pragma once

#include <random>
#include <string>
#include <vector>

#include "core/units.h"
#include "reduction/intersection.h"
#include "reduction/network.h"
#include "reduction/observation.h"

namespace armsig::testing {

inline constexpr double kSigmaAngle = 0.5 * kRadPerArcsec;

struct SimLab {
  std::vector<reduction::Station> stations;
  std::vector<Eigen::Vector3d> targets;  // truth
  std::mt19937 rng{42};

  explicit SimLab(int station_count = 3, unsigned seed = 42) : rng(seed) {
    std::uniform_real_distribution<double> unit(0.0, 1.0);
    for (int s = 0; s < station_count; ++s) {
      reduction::Station st;
      st.pose.id = "S" + std::to_string(s + 1);
      const double angle = 2.0 * kPi * s / station_count + 0.3 * unit(rng);
      const double radius = 3000.0 + 1000.0 * unit(rng);
      st.pose.position_mm = {radius * std::sin(angle), radius * std::cos(angle),
                             1400.0 + 300.0 * unit(rng)};
      st.pose.azimuth_rad = 2.0 * kPi * unit(rng);
      st.pose.world_from_station = reduction::LevelledRotation(st.pose.azimuth_rad);
      st.sigma_hz_rad = kSigmaAngle;
      st.sigma_v_rad = kSigmaAngle;
      stations.push_back(st);
    }
  }

  Eigen::Vector3d RandomTarget() {
    std::uniform_real_distribution<double> u(-1000.0, 1000.0);
    return {u(rng), u(rng), 1000.0 + u(rng)};
  }

  // A noisy face-I reading of `target` from station s.
  AngleReading Read(int s, const Eigen::Vector3d& target, double sigma = kSigmaAngle) {
    std::normal_distribution<double> noise(0.0, sigma);
    AngleReading r = reduction::PredictReading(stations[s].pose.position_mm,
                                               stations[s].pose.world_from_station, target);
    r.hz_rad = WrapTwoPi(r.hz_rad + noise(rng));
    r.v_rad += noise(rng);
    return r;
  }

  reduction::Observation ObserveTo(int s, const std::string& point, const Eigen::Vector3d& target) {
    reduction::Observation o;
    o.station = stations[s].pose.id;
    o.point = point;
    o.reading = Read(s, target);
    o.sigma_hz_rad = kSigmaAngle;
    o.sigma_v_rad = kSigmaAngle;
    return o;
  }

  reduction::Ray RayTo(int s, const Eigen::Vector3d& target) {
    return reduction::RayOf(ObserveTo(s, "target", target), stations[s],
                            reduction::InstrumentDefaults{});
  }
};

}  // namespace armsig::testing
