// Estimation of the arm signature: paper eq. (8)–(15), the linearised least squares
// A p − r = ε, iterated to convergence (Levenberg–Marquardt) on the identifiable
// subset chosen once from the data at the nominal model.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <limits>
#include <optional>
#include <string>
#include <vector>

#include "calibration/identifiability.h"
#include "calibration/model.h"
#include "core/types.h"

namespace armsig::calibration {

// Parses a --params spec: "geometric", "all", or a comma list mixing "geometric",
// "all", generated families ("compliance", "harmonics": every term of that family in the
// model, calibration/terms.h) and parameter names ("geometric,h3,h4"). Returns ascending
// indices. Throws std::invalid_argument naming an unknown parameter and listing the known
// ones, or a family the model has no terms of.
std::vector<int> ParseParameterSpec(const RobotModel& model, const std::string& spec);

struct ErrorStats {
  int poses = 0;
  double mean_mm = 0.0;
  double max_mm = 0.0;
  double rms_mm = 0.0;
};
ErrorStats Summarise(const std::vector<double>& distances_mm);

// N1 by a rigid best fit (Umeyama/Horn, no scale) of the nominal target positions to the
// measured ones: works for any rotation and translation between the measuring frame
// and the robot. nullopt when the nominal positions are degenerate (fewer than three
// poses or all on one line).
std::optional<Eigen::Isometry3d> AlignBase(const RobotModel& model,
                                           const std::vector<MeasuredPose>& poses);

// Error vectors (model − measured) and distances for `params`.
std::vector<Eigen::Vector3d> Residuals(const RobotModel& model,
                                       const Eigen::Isometry3d& world_from_base,
                                       const Eigen::VectorXd& params,
                                       const std::vector<MeasuredPose>& poses);
std::vector<double> Distances(const std::vector<Eigen::Vector3d>& residuals);

struct EstimationOptions {
  std::vector<int> parameters;  // candidates (indices); empty = all of the model's
  IdentifiabilityOptions identifiability;
  int max_iterations = 50;
  double function_tolerance = 1e-12;   // relative change of the cost
  double parameter_tolerance = 1e-12;  // relative step
  // > 0: Huber loss on each pose's error distance with this threshold (mm), so blunder
  // poses are down-weighted (and reported) instead of pulling the fit.
  double robust_threshold_mm = 0.0;
  void Check() const;
};

enum class EstimationStatus {
  kConverged,
  kNoConvergence,    // iteration limit reached; result is the last accepted step
  kTooFewEquations,  // 3m equations cannot determine the identifiable parameters
  kDegenerateBase,   // base: auto with degenerate nominal positions
  kNonFinite,        // an estimate, its sigma, σ0 or a residual is not a finite number
};

struct EstimationResult {
  EstimationStatus status = EstimationStatus::kConverged;
  std::string message;
  int iterations = 0;
  Eigen::Isometry3d world_from_base = Eigen::Isometry3d::Identity();
  Eigen::VectorXd params;      // all parameters; unidentified stay exactly zero
  Eigen::VectorXd sigmas;      // NaN for unidentified
  Eigen::MatrixXd covariance;  // identified subset, in the order of identifiability.identified
  IdentifiabilityReport identifiability;
  double sigma0_mm = 0.0;  // a posteriori σ of one coordinate
  int redundancy = 0;      // 3m − rank
  double cost = 0.0;       // Σ weighted squared residuals (mm²)
  std::vector<Eigen::Vector3d> nominal_residuals, fit_residuals;
  ErrorStats nominal, fit;
  std::vector<int> downweighted;  // poses the robust loss treated as blunders (indices)

  // kNonFinite is never ok: its numbers are not results.
  bool ok() const {
    return status == EstimationStatus::kConverged || status == EstimationStatus::kNoConvergence;
  }
};

// Fits the model to the poses. world_from_base: N1 to use; nullopt = model.base, or
// AlignBase when the model says auto.
EstimationResult Estimate(const RobotModel& model, const std::vector<MeasuredPose>& poses,
                          const EstimationOptions& options);

// Nested-model F-test: does adding terms improve the fit significantly?
struct FTest {
  std::string added;  // names of the added terms
  double rss_reduced = 0.0, rss_full = 0.0;
  int df_added = 0, df_residual = 0;
  double f = 0.0, p_value = 1.0;
  bool significant = false;
  // --params auto: cross-validated mean error distance (mm) of the model with the term
  // (NaN when not computed: not significant, or cross-validation off), and whether the term
  // was added. Tests of candidates come from the linearised model at the current fit
  // (exact for a model linear in its parameters); the test of a term that is added is
  // then redone with both models fitted (CompareNested).
  double cv_mean_mm = std::numeric_limits<double>::quiet_NaN();
  bool accepted = false;
};
FTest CompareNested(const EstimationResult& reduced, const EstimationResult& full,
                    const std::string& added, double alpha);

// --params auto: start from the geometric model and add the model's non-geometric terms
// (the paper's h-terms and the generated compliance and harmonic families alike) one at
// a time. Each round every candidate the data can identify next to the current set is
// F-tested; among the significant ones the term that lowers the K-fold cross-validated
// mean error on the fit poses the most is added, if it lowers it by at least
// `min_cv_gain` (relative). It stops when no term passes both.
struct TermSelectionOptions {
  double alpha = 0.01;         // significance of the F-tests
  bool cross_validate = true;  // false: the paper-era rule, the largest significant F
  int folds = 5;
  unsigned seed = 1;           // of the fold assignment
  double min_cv_gain = 0.005;  // relative decrease of the CV mean a term must bring
  void Check() const;
};
struct AutoSelection {
  std::vector<int> parameters;
  std::vector<FTest> tests;  // every test made, in order (accepted ones flagged)
  double cv_mean_mm_geometric = std::numeric_limits<double>::quiet_NaN();
  double cv_mean_mm = std::numeric_limits<double>::quiet_NaN();  // of the selected model
};
AutoSelection SelectTerms(const RobotModel& model, const std::vector<MeasuredPose>& poses,
                          const EstimationOptions& options,
                          const TermSelectionOptions& selection = {});
// The same with the default selection options at significance `alpha`.
AutoSelection SelectTermsByFTest(const RobotModel& model, const std::vector<MeasuredPose>& poses,
                                 const EstimationOptions& options, double alpha = 0.01);

}  // namespace armsig::calibration
