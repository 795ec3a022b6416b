// Estimation of the arm signature: paper eq. (8)–(15), the linearised least squares
// A p − r = ε, iterated to convergence (Levenberg–Marquardt) on the identifiable
// subset chosen once from the data at the nominal model.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstdint>
#include <map>
#include <limits>
#include <optional>
#include <string>
#include <vector>

#include "calibration/cross_validation.h"
#include "calibration/identifiability.h"
#include "calibration/model.h"
#include "core/error.h"
#include "core/stop_token.h"
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

// The same for orientation errors: the angles (rad) of the poses that have one.
struct AngleStats {
  int poses = 0;
  double mean_rad = 0.0;
  double max_rad = 0.0;
  double rms_rad = 0.0;
};
AngleStats SummariseAngles(const std::vector<double>& angles_rad);

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

// The robot base in each measurement frame (MeasuredPose::frame): world_from_base of the
// poses measured in that frame.
using FrameBases = std::map<int64_t, Eigen::Isometry3d>;
// The frames the poses were measured in, ascending.
std::vector<int64_t> FramesOf(const std::vector<MeasuredPose>& poses);
// Residuals with each pose's own frame's base. std::invalid_argument when a pose's frame
// has no base.
std::vector<Eigen::Vector3d> Residuals(const RobotModel& model, const FrameBases& bases,
                                       const Eigen::VectorXd& params,
                                       const std::vector<MeasuredPose>& poses);
// The base of every frame with a non-degenerate set of poses, by a rigid best fit of the
// positions under `params` (AlignBaseWithParams) to that frame's poses; frames whose poses
// cannot place it (fewer than three, or on one line) are left out.
FrameBases AlignFrameBases(const RobotModel& model, const Eigen::VectorXd& params,
                           const std::vector<MeasuredPose>& poses);
std::vector<double> Distances(const std::vector<Eigen::Vector3d>& residuals);

// The target frame's rotation in the last link frame, per measurement frame: how the 6-DoF
// probe sits on the flange in each set-up (calibration/orientation.h).
using ToolRotations = std::map<int64_t, Eigen::Matrix3d>;
// Orientation residuals (the rotation vector of R_measᵀ·R_pred, rad, target frame) of the
// poses that have a measured orientation and whose frame has a tool rotation; nullopt for
// the others. std::invalid_argument when a pose's frame has no base.
std::vector<std::optional<Eigen::Vector3d>> OrientationResiduals(
    const RobotModel& model, const FrameBases& bases, const ToolRotations& tools,
    const Eigen::VectorXd& params, const std::vector<MeasuredPose>& poses);
// Their angles (the rotation vectors' norms), for SummariseAngles.
std::vector<double> Angles(const std::vector<std::optional<Eigen::Vector3d>>& residuals);

struct EstimationOptions {
  std::vector<int> parameters;  // candidates (indices); empty = all of the model's
  IdentifiabilityOptions identifiability;
  int max_iterations = 50;
  double function_tolerance = 1e-12;   // relative change of the cost
  double parameter_tolerance = 1e-12;  // relative step
  // > 0: Huber loss on each pose's error distance with this threshold (mm), so blunder
  // poses are down-weighted (and reported) instead of pulling the fit.
  double robust_threshold_mm = 0.0;
  // Poses with a measured orientation (MeasuredPose::orientation) add three equations
  // each: the orientation residual, weighted against the positions by this many mm per rad
  // (the position error one rad of orientation error counts as), or, at 0, by variance
  // components: the weight is re-estimated until it is the ratio of the two groups'
  // a-posteriori sigmas (the fit's own answer to "how well does the model do each"). Each
  // measurement frame with orientations gets its target's rotation on the last link among
  // the unknowns (three more). false: orientations are ignored, a position-only fit.
  bool use_orientation = true;
  double orientation_weight_mm_per_rad = 0.0;
  // One tool rotation for every frame instead of one each: the probe stayed on the flange
  // between the set-ups, so the orientations of a new set-up's poses also turn its base.
  bool shared_tool_rotation = false;
  // Looked at before every iteration: a stop request throws core::Stopped.
  core::StopToken stop;
  void Check() const;
};

struct EstimationResult {
  // kOk: converged. kNotConverged: the iteration limit was reached, the result is the last
  // accepted step. kTooFewObservations: 3m equations cannot determine the identifiable
  // parameters. kDegenerate: base: auto with degenerate nominal positions. kNonFinite: an
  // estimate, its sigma, σ0 or a residual is not a finite number.
  SolveStatus status;
  int iterations = 0;
  // Poses from several measurement frames (MeasuredPose::frame) are fitted with one base
  // per frame. The reference frame (the highest frame number: the latest session) is the
  // datum: its base is aligned (or given) and held, as with a single frame, so the first
  // joint's parameters carry what is left of its base error; every other frame's base is
  // estimated with the parameters (six more unknowns each). `world_from_base` is the
  // reference frame's, `bases` has every frame's.
  Eigen::Isometry3d world_from_base = Eigen::Isometry3d::Identity();
  int64_t reference_frame = 0;
  FrameBases bases;
  Eigen::VectorXd params;      // all parameters; unidentified stay exactly zero
  Eigen::VectorXd sigmas;      // NaN for unidentified
  Eigen::MatrixXd covariance;  // identified subset, in the order of identifiability.identified
  IdentifiabilityReport identifiability;
  double sigma0_mm = 0.0;  // a posteriori σ of one coordinate
  // 3m − rank − 6 × (frames − 1), and with orientations + 3m_o − 3 × (frames with them)
  int redundancy = 0;
  double cost = 0.0;       // Σ weighted squared residuals (mm²)
  std::vector<Eigen::Vector3d> nominal_residuals, fit_residuals;
  ErrorStats nominal, fit;
  std::vector<int> downweighted;  // poses the robust loss treated as blunders (indices)

  // With orientation equations (some poses carry a measured orientation and
  // EstimationOptions::use_orientation): the target's rotation on the last link of every
  // frame that has them, the weight used (0: no orientation equations), the a-posteriori
  // σ of one orientation residual component, and the residuals (nullopt for a pose without
  // an orientation).
  ToolRotations tool_rotations;
  bool tool_rotation_shared = false;  // every frame's is the same unknown
  double orientation_weight_mm_per_rad = 0.0;
  double sigma0_rad = std::numeric_limits<double>::quiet_NaN();
  int orientation_poses = 0;
  std::vector<std::optional<Eigen::Vector3d>> nominal_orientation_residuals,
      fit_orientation_residuals;
  AngleStats nominal_angle, fit_angle;

  // Its numbers are results (converged, or stopped at the iteration limit); kNonFinite
  // never is.
  bool usable() const { return status.ok() || status.code == SolveCode::kNotConverged; }
  // The base of a pose's measurement frame (world_from_base when the frame has none).
  const Eigen::Isometry3d& base_of(int64_t frame) const {
    const auto it = bases.find(frame);
    return it != bases.end() ? it->second : world_from_base;
  }
  // The tool rotation of a frame (the reference frame's when it has none); nullptr when
  // the fit had no orientation equations.
  const Eigen::Matrix3d* tool_rotation_of(int64_t frame) const {
    auto it = tool_rotations.find(frame);
    if (it == tool_rotations.end()) it = tool_rotations.find(reference_frame);
    return it != tool_rotations.end() ? &it->second : nullptr;
  }
};

// Fits the model to the poses. N1 of the reference frame: model.base, or AlignBase on that
// frame's poses when the model says auto; the other frames' bases start from AlignBase on
// theirs (kDegenerate when a frame's poses cannot place it).
EstimationResult Estimate(const RobotModel& model, const std::vector<MeasuredPose>& poses,
                          const EstimationOptions& options);

// The fit linearised at its solution, for K-fold cross-validation (the folds of the poses
// given): columns `leading` (model parameters), then three per frame with a tool rotation,
// then `trailing`; rows the positions, then the orientation equations weighted as the fit
// weighted them. The bases of further frames are held at the fit's value.
LinearisedCrossValidation CrossValidationAtFit(const RobotModel& model, const EstimationResult& fit,
                                               const std::vector<MeasuredPose>& poses,
                                               const std::vector<int>& leading,
                                               const std::vector<int>& trailing,
                                               const std::vector<int>& fold_of_pose, int folds);

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
  // The held-out folds: whole sessions, or whole regions of joint space when there is one
  // session (calibration/transfer_folds.h), so that a term is kept only when it pays on data
  // the fit did not see from another set-up or another part of the work volume. false:
  // poses dealt at random (what the fit poses themselves say, the pre-transfer rule).
  bool transfer_folds = true;
  double min_cv_gain = 0.005;  // relative decrease of the CV mean a term must bring
  void Check() const;
};
struct AutoSelection {
  std::vector<int> parameters;
  std::string folds;  // how the poses were held out ("5 joint-space blocks held out in turn")
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
