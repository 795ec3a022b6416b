// Synthetic robots and measurements with known truth, for tests, benchmarks and the
// demo's virtual lab. Deterministic for a given seed.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <random>
#include <vector>

#include "calibration/model.h"
#include "core/types.h"

namespace armsig::calibration {

// The paper's Table 3 (43 parameters) as a PUMA 760 parameter vector: a realistic
// hidden truth for a simulated PUMA (values in mm and rad).
Eigen::VectorXd PaperTable3Parameters();

// Random parameter errors: lengths N(0, sigma_mm), angles N(0, sigma_rad), h-terms
// N(0, sigma_h_rad).
Eigen::VectorXd RandomParameters(const RobotModel& model, double sigma_mm, double sigma_rad,
                                 double sigma_h_rad, std::mt19937& rng);

// Random configurations uniformly within the model's limits (or `range_rad` around zero).
std::vector<Eigen::VectorXd> RandomConfigurations(const RobotModel& model, int count,
                                                  std::mt19937& rng, double range_rad = 2.5);

// A candidate pool like the paper's NBS data (about 200 configurations from
// "single-joint rotation tests and programmed line and circle tests"): each joint swept
// alone from a few postures, plus short smooth paths where all joints move a little.
// Heavily clustered, as real lab data are.
std::vector<Eigen::VectorXd> LabTestConfigurations(const RobotModel& model, std::mt19937& rng,
                                                   double range_rad = 2.5);

// Measured poses of the true robot: position + N(0, noise_mm) per coordinate.
std::vector<MeasuredPose> SimulatePoses(const RobotModel& model,
                                        const Eigen::Isometry3d& world_from_base,
                                        const Eigen::VectorXd& true_params,
                                        const std::vector<Eigen::VectorXd>& joints_rad,
                                        double noise_mm, std::mt19937& rng);

// The same poses measured by a 6-DoF target: each gets the true target frame's orientation,
// R_last · tool_rotation, turned by a random rotation vector N(0, noise_rad) per component
// in the target frame (the position noise as SimulatePoses, from the same generator).
std::vector<MeasuredPose> SimulateSixDofPoses(const RobotModel& model,
                                              const Eigen::Isometry3d& world_from_base,
                                              const Eigen::VectorXd& true_params,
                                              const Eigen::Matrix3d& tool_rotation,
                                              const std::vector<Eigen::VectorXd>& joints_rad,
                                              double noise_mm, double noise_rad,
                                              std::mt19937& rng);

}  // namespace armsig::calibration
