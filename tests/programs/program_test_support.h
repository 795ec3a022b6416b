// Robots for the program tests: the shipped KUKA KR 16-2, ABB IRB 4600 and UR10 models (the
// demo's virtual robots' nominal arms, in their controllers' joint conventions), and planted
// errors of a real arm's size.
#pragma once

#include <random>

#include "calibration/model.h"
#include "calibration/synthetic.h"
#include "test_support.h"

namespace armsig::testing {

inline calibration::RobotModel Kr16_2() { return io::LoadRobotModel(SourcePath("models/kr16_2.yaml")); }
inline calibration::RobotModel Irb4600() { return io::LoadRobotModel(SourcePath("models/irb4600.yaml")); }

// Planted errors: lengths 0.3 mm, angles 0.3 mrad, the model's non-geometric terms 0.2 mrad
// (the UR10's harmonic terms among them: joint errors periodic in their own angle).
inline Eigen::VectorXd PlantedErrors(const calibration::RobotModel& model, unsigned seed) {
  std::mt19937 rng(seed);
  return calibration::RandomParameters(model, 0.3, 3e-4, 2e-4, rng);
}

}  // namespace armsig::testing
