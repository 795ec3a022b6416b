// Has the robot changed between two of its parameter sets? Compared by what users feel:
// the positions the two models predict over configurations spread over the work volume,
// the second model's positions rigidly aligned onto the first's (the measuring frame
// and the base gauge are not properties of the robot), against the uncertainty both
// fits propagate to those positions.
#pragma once

#include <Eigen/Core>
#include <optional>
#include <vector>

#include "calibration/identifiability.h"
#include "calibration/model.h"

namespace armsig::calibration {

// Drift needs two sets' predicted positions to differ by more than this (mm) too: the
// nightly job's default gate, and what a stored set's report judges by when it stored none.
inline constexpr double kDefaultDriftMm = 0.05;

// One fitted parameter set: values of every parameter, and the covariance of the
// identified ones (rows in the order of `identified`).
struct FittedSet {
  Eigen::VectorXd params;
  std::vector<int> identified;
  Eigen::MatrixXd covariance;
};

// One parameter's change between two sets in one gauge (see CompareModels).
struct ParameterDrift {
  int parameter = -1;
  double change = 0.0;  // b − a, the part that changes the arm's shape (mm or rad)
  double sigma = 0.0;   // its propagated standard deviation
  double z = 0.0;       // change / sigma
};

struct ModelComparison {
  int configurations = 0;
  double mean_mm = 0.0, max_mm = 0.0, rms_mm = 0.0;  // |Δx| after the rigid alignment
  int worst = -1;                                    // configuration with the largest |Δx|
  double chi2 = 0.0;  // Δᵀ C⁺ Δ, C = J_a Σ_a J_aᵀ + J_b Σ_b J_bᵀ over all configurations
  int dof = 0;        // rank of C, at most the shape changes the identified parameters make
  double p_value = 1.0;  // of chi2 under "the same robot, only noise"
  // false when the sets identified different subsets: chi2 is then taken on the shape
  // changes both can make (the intersection of their spaces), not on everything.
  bool shared_shape_space = true;
  // Per parameter identified by both sets, largest |z| first. Each fit's base is aligned
  // on its own data, so the parameters next to the base (and any that together move the
  // whole arm rigidly) also carry the difference of the two alignments; that part — the
  // combinations of parameters whose effect on the positions is a rigid motion — is taken
  // out (weighted by the parameters' sigmas) before the changes and their sigmas are
  // reported, so a name here means the arm itself changed there.
  std::vector<ParameterDrift> parameters;
};

// b's predicted positions against a's at `configurations` (robot frame): b's rigidly aligned
// onto a's (no scale: the measuring frame and the base gauge are not the robot's), the
// difference (3 per configuration, stacked), the Jacobian of a's positions (3m × every
// parameter), the sum of both sets' covariances over every parameter (zero where not
// identified) and a factor of the difference's covariance under "the same robot":
// J (Σ_a + Σ_b) Jᵀ = noise_factor · noise_factorᵀ.
struct PredictedDifference {
  Eigen::Matrix3Xd positions_a;
  Eigen::MatrixXd jacobian;
  Eigen::VectorXd change;
  Eigen::MatrixXd covariance_sum;
  Eigen::MatrixXd noise_factor;
};
PredictedDifference PredictDifference(const RobotModel& model, const FittedSet& a,
                                      const FittedSet& b,
                                      const std::vector<Eigen::VectorXd>& configurations);

// The difference at each configuration, as a drift figure draws it: |Δx| after the rigid
// alignment (PredictDifference), and the standard deviation of |Δx| along Δx from both
// sets' covariances, less what the alignment absorbs (the six small rigid motions of the
// positions). `worst`: the configuration with the largest |Δx| (−1 for none).
struct DifferenceProfile {
  std::vector<double> distance_mm, sigma_mm;
  int worst = -1;
};
DifferenceProfile ProfileDifference(const RobotModel& model, const FittedSet& a,
                                    const FittedSet& b,
                                    const std::vector<Eigen::VectorXd>& configurations);

// `configurations`: joint angles (rad) spread over the work volume, the same for every
// comparison of one robot (SpreadConfigurations). Sets with no identified parameter
// have no uncertainty (then chi2 is 0 and p_value 1 unless the other set has one).
ModelComparison CompareModels(const RobotModel& model, const FittedSet& a, const FittedSet& b,
                              const std::vector<Eigen::VectorXd>& configurations);

// The parameters this robot's model identifies from configurations spread over its joint
// limits, among `candidates`: decided once from the model alone (deterministic), so every
// parameter set of the robot estimates the same parameters in the same gauge.
// The whole analysis behind it: the candidates, the identified subset, and how each
// parameter left out depends on the identified ones. `orientation`: the data measure the
// target frame's orientation too (a 6-DoF probe, its rotation on the flange unknown), which
// identifies what positions alone cannot (the last axis' tilt).
IdentifiabilityReport ModelIdentifiability(const RobotModel& model,
                                           const std::vector<int>& candidates,
                                           double relative_tolerance = 1e-7,
                                           bool orientation = false);
std::vector<int> ModelIdentifiableSubset(const RobotModel& model,
                                         const std::vector<int>& candidates,
                                         double relative_tolerance = 1e-7);

}  // namespace armsig::calibration
