// Robots for the program tests: the virtual cells' KUKA- and ABB-sized arms
// (simulation/virtual_arms.h), the shipped UR10, and planted errors of a real arm's size.
#pragma once

#include <random>

#include "calibration/model.h"
#include "calibration/synthetic.h"
#include "simulation/virtual_arms.h"
#include "test_support.h"

namespace armsig::testing {

inline calibration::RobotModel KukaLike() { return simulation::KukaKr16Like(); }
inline calibration::RobotModel AbbLike() { return simulation::AbbIrb4600Like(); }

// Planted errors: lengths 0.3 mm, angles 0.3 mrad, the model's non-geometric terms 0.2 mrad
// (the UR10's harmonic terms among them: joint errors periodic in their own angle).
inline Eigen::VectorXd PlantedErrors(const calibration::RobotModel& model, unsigned seed) {
  std::mt19937 rng(seed);
  return calibration::RandomParameters(model, 0.3, 3e-4, 2e-4, rng);
}

}  // namespace armsig::testing
