// Simulated sessions of a PUMA 760 whose truth the test knows, stored as a capture
// would store them (configurations and reduced points), for the nightly-job tests.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <string>

#include "db/database.h"

namespace armsig::testing {

// One session of `count` configurations of the true robot (base = identity, 0.01 mm
// noise); `blunder_fraction` of its points are moved by millimetres. `lab_yaml` is
// stored with the session. The robot (a PUMA 760 model) is registered as `robot`.
// `world_from_base`: where the instruments saw the robot that night (a new set-up moves it).
// The configurations are the lab's test design (calibration::LabTestConfigurations) from its
// start, every `stride`-th of it (a short session spread over the whole design: stride > 1).
void AddSession(db::Database& db, const Eigen::VectorXd& truth, int count, unsigned seed,
                double blunder_fraction = 0.0, const std::string& lab_yaml = "",
                const std::string& robot = "puma",
                const Eigen::Isometry3d& world_from_base = Eigen::Isometry3d::Identity(),
                int stride = 1);
// A set-up of the instruments for night `seed`: the robot's base some decimetres away and
// turned (the same seed, the same set-up).
Eigen::Isometry3d NightFrame(unsigned seed);
int ActiveVersion(const std::string& db_path);
int Versions(const std::string& db_path);

}  // namespace armsig::testing
