// Which parameters can the data determine? Paper: "only 25 can be estimated. The
// other 14 parameters maintain their nominal values of zero." The count comes from
// the data's own Jacobian: columns scaled to unit norm, then QR with column pivoting.
#pragma once

#include <Eigen/Core>
#include <string>
#include <vector>

#include "calibration/model.h"

namespace armsig::calibration {

struct IdentifiabilityOptions {
  // A pivot |R_kk| ≤ tolerance · |R_00| of the scaled Jacobian counts as zero.
  double relative_tolerance = 1e-7;
  void Check() const;
};

struct Dependency {
  int parameter = -1;                      // a parameter left out
  std::vector<std::pair<int, double>> on;  // identified parameters and coefficients
  double residual = 0.0;                   // how exact the dependency is (scaled)
};

struct FrozenJoint {
  int joint = -1;             // 0-based
  double range_rad = 0.0;     // spread of its encoder angles in the data
  std::vector<int> affected;  // parameters in the dependencies it creates
};

struct IdentifiabilityReport {
  std::vector<int> candidates;    // parameters asked for
  std::vector<int> identified;    // chosen subset, ascending parameter index
  std::vector<int> unidentified;  // kept at zero, ascending
  // Held at zero by the model itself (RobotModel::HeldParameters: a known tool mounting's
  // offset at the target and gamma{n}), never candidates, ascending.
  std::vector<int> held;
  int rank = 0;
  int structural_rank = -1;       // rank on well-spread configurations (-1: not computed)
  double condition_number = 0.0;  // of the scaled Jacobian of the identified subset
  std::vector<Dependency> dependencies;
  std::vector<FrozenJoint> frozen_joints;
};

// Rank and identified subset of `candidates` from a stacked Jacobian (3m × P).
IdentifiabilityReport AnalyseJacobian(const Eigen::MatrixXd& jacobian,
                                      const std::vector<int>& candidates,
                                      const IdentifiabilityOptions& options = {});

// Which configurations were measured with their orientation (a 6-DoF target), and in which
// set-up. The target's rotation on the last link is estimated per set-up (like its base),
// so a set-up's orientation equations enter the analysis with their mean over its
// configurations taken out: what that rotation cannot explain.
struct OrientationRows {
  std::vector<int> setup;  // per configuration: its set-up (≥ 0), or −1 without orientation
  // The orientation equations in mm-equivalent (a rad counts as this many mm): a metre's
  // lever, as a wrist rotation moves a target a metre out.
  double weight_mm_per_rad = 1000.0;
};

// Stacked Jacobian of all parameters at `params` for every configuration: three position
// rows each, then, with `orientation`, three rows for each configuration that has one
// (the last link's rotation in its own frame, weighted, with its set-up's mean taken out).
Eigen::MatrixXd StackedJacobian(const RobotModel& model, const Eigen::Isometry3d& world_from_base,
                                const Eigen::VectorXd& params,
                                const std::vector<Eigen::VectorXd>& joints_rad,
                                const OrientationRows* orientation = nullptr);

// The full analysis on the data: rank, dependencies, the structural rank of the model
// (deterministic well-spread configurations) and joints the data never moves, with the
// parameters their missing motion makes inseparable. With `orientation` the data's
// orientation equations count too, and the structural rank is that of spread
// configurations measured with their orientation in one set-up.
IdentifiabilityReport AnalyseIdentifiability(const RobotModel& model,
                                             const Eigen::Isometry3d& world_from_base,
                                             const std::vector<Eigen::VectorXd>& joints_rad,
                                             const std::vector<int>& candidates,
                                             const IdentifiabilityOptions& options = {},
                                             const OrientationRows* orientation = nullptr);

// Well-spread deterministic configurations within the model's joint limits (or ±π).
std::vector<Eigen::VectorXd> SpreadConfigurations(const RobotModel& model, int count,
                                                  unsigned seed = 12345);

}  // namespace armsig::calibration
