// The residual map: what the parametric model still leaves, learned as a smooth
// function of the joint angles and added to its predictions — but only where it has been
// shown to help, and only where it has data. Two stages, fitted and cross-validated
// together:
//
// 1. Joint curves (calibration/joint_curves.h): each joint's angle error as a periodic
//    cubic spline of its own encoder angle, `curve_knots` knots per turn, applied to the
//    encoder angles before the parametric model. Fitted by penalised least squares to the
//    parametric residuals through each joint's lever (∂x/∂θ_j at the fitted parameters),
//    with a second-difference penalty whose weight is chosen by cross-validation. An
//    encoder's or a gear's error depends on that joint's angle only, so a curve carries to
//    configurations no fit pose is near, as long as each joint's angle was measured.
// 2. A kernel over all joints together, for what the curves leave:
//
// Model. Kernel ridge regression (the mean of a Gaussian process) of the 3-D residual on
// the joint angles of the joints that move the target. Features u(θ̄) = (a_j sin θ̄_j,
// b_j cos θ̄_j)_j, periodic in every joint (359° and −1° are one configuration), each
// column scaled (`feature_scale`: by default standardised on the fit poses, so a joint
// that moved little is not drowned by one that moved a lot); the Gaussian kernel on them,
//   k(θ̄, c) = exp(−|u(θ̄) − u(c)|² / (2ℓ²)),
//   correction(θ̄) = Σ_c weights_c k(θ̄, c),   weights = (K + λI)⁻¹ Y,
// with the fit poses as centres and Y their corrections (measured − parametric). Exact:
// on the UR10 the residual varies over a tenth of the joints' spread, which a few hundred
// inducing points (Nyström) cannot follow; at most `max_training_poses` fit poses (chosen
// by farthest-point sampling) train the map, which bounds the cubic cost. As a Gaussian
// process with prior amplitude s² (its maximum-likelihood value given ℓ and λ,
// s² = tr(Yᵀ(K + λI)⁻¹Y)/3n) and noise σ² = λ s² per coordinate, the latent variance of the
// correction is s² (1 − k_Nᵀ (K_NN + λI)⁻¹ k_N) conditioned on the N = 32 centres nearest
// the configuration: the kernel is local (ℓ a fraction of the spread), so this is the full
// posterior's near the data and a conservative (larger) value where more centres matter.
// No matrix is stored for it. A new measurement's predictive variance adds σ².
//
// Corrections are measured − parametric position, in the robot's base frame (the frame
// world_from_base maps from), so a map applies in any measuring frame; with output frame
// "joint1" they are in the frame turning with joint 1 (base z, by the encoder angle).
//
// Support. A map never extrapolates silently: a configuration whose nearest centre is
// farther than `support_radius` in the scaled feature space gets no correction (the
// parametric prediction) and supported = false. The radius is set at the fit from the fit
// poses themselves: the 99th percentile of their leave-one-out nearest-centre distances,
// times 1.25. So a configuration like the fit poses is flagged about 1 % of the time or
// less, one outside their cloud always.
//
// Selection. ℓ and λ by K-fold cross-validation on the fit poses only, nested honestly:
// in each fold the parametric model is refitted without the fold (one Gauss–Newton step,
// calibration/cross_validation.h), the map is trained on the other folds' residuals of
// that refit and predicts the fold. The search walks a log grid from its middle to the
// best neighbour until no neighbour is better. The map is used only when its
// cross-validated mean error beats the parametric model's by `required_gain` (5 %): both
// figures are reported either way.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <array>
#include <limits>
#include <string>
#include <vector>

#include "calibration/cross_validation.h"
#include "calibration/estimation.h"
#include "calibration/joint_curves.h"
#include "calibration/model.h"
#include "core/types.h"

namespace armsig::calibration {

// Everything a stored map is: plain values, for JSON and the database (io/residual_map_json.h).
struct ResidualMapData {
  // Version 1: the kernel alone (maps stored before the joint curves; still read).
  static constexpr int kVersion = 2;
  static constexpr const char* kKind = "gaussian_kernel_ridge";
  int version = kVersion;
  std::string kind = kKind;           // Gaussian kernel on sin/cos joint features
  std::string output_frame = "base";  // "base" | "joint1"
  int num_joints = 0;                 // of the model the map belongs to
  std::vector<int> joints;            // 0-based joints whose sin/cos are the features
  std::vector<double> feature_scale;  // (a_j, b_j) per feature joint: sin, cos scales
  double length_scale = 1.0;          // ℓ, scaled feature units
  double regularisation = 0.1;        // λ (= σ² / s²)
  double noise_sigma_mm = 0.0;        // σ per coordinate (GP noise; prior amplitude s² = σ²/λ)
  double support_radius = 0.0;  // scaled feature units; farther from every centre: not applied
  std::vector<std::vector<double>> centres_rad;   // M × joints.size(): training poses' angles
  std::vector<std::array<double, 3>> weights_mm;  // M × 3
  JointCurvesData curves;                         // the first stage (empty: none)
};

struct MapPrediction {
  Eigen::Vector3d correction_in_base_mm = Eigen::Vector3d::Zero();  // zero when unsupported
  bool supported = false;
  double support_distance = 0.0;  // to the nearest centre, scaled feature units
};

// Evaluates a map (immutable; share it across threads).
class ResidualMap {
 public:
  // Throws std::invalid_argument when the data are inconsistent (sizes, non-finite
  // numbers, ℓ ≤ 0, an unknown kind, version or frame).
  explicit ResidualMap(ResidualMapData data);

  const ResidualMapData& data() const { return data_; }
  int centres() const { return static_cast<int>(data_.centres_rad.size()); }

  // The kernel's correction (stage 2) at the encoder angles.
  MapPrediction Predict(const double* joints_rad) const;
  // Stage 1: the angles the parametric model is evaluated at (encoder angles + the joint
  // curves; a copy when the map has none), num_joints of them. False when some joint's
  // angle lies where its curve had no data (the correction is applied all the same).
  bool CorrectJoints(const double* joints_rad, double* corrected_rad) const;
  bool has_curves() const { return !data_.curves.empty(); }
  // The same with ∂correction/∂θ̄ (3 × num_joints; zero when unsupported), for compensation.
  MapPrediction PredictWithJacobian(
      const double* joints_rad,
      Eigen::Ref<Eigen::Matrix<double, 3, Eigen::Dynamic>> d_correction_d_joints) const;
  // Many configurations at once (columns of `joints_rad`, num_joints × B), the fast path:
  // matrix products in single precision (agrees with Predict to ~1e-6 of the correction).
  // Corrections 3 × B in the base frame.
  void PredictBatch(const Eigen::MatrixXd& joints_rad, Eigen::Matrix3Xd& corrections_in_base_mm,
                    std::vector<char>& supported, int threads = 1) const;
  // Latent standard deviation of the correction, per coordinate (mm), by the local GP
  // variance above. Meaningful whether supported or not (far away it is s).
  double CorrectionSigmaMm(const double* joints_rad) const;

 private:
  // Scaled features of the feature joints' angles; half squared distances to every centre.
  void Features(const double* angles, double* u) const;
  void HalfDistances(const double* u, Eigen::Ref<Eigen::VectorXd> half_d2) const;
  void PredictRange(const Eigen::MatrixXd& joints_rad, Eigen::Index begin, Eigen::Index end,
                    Eigen::Matrix3Xd& corrections_in_base_mm, std::vector<char>& supported) const;
  MapPrediction Evaluate(const double* joints_rad,
                         Eigen::Matrix<double, 3, Eigen::Dynamic>* d_correction_d_joints) const;

  ResidualMapData data_;
  Eigen::MatrixXd centre_features_;    // M × 2J
  Eigen::VectorXd centre_half_norm2_;  // |u(c)|² / 2 per centre
  Eigen::Matrix<double, Eigen::Dynamic, 3> weights_;
  // Batch path (single precision): features centred on their mean.
  Eigen::VectorXd feature_mean_;
  Eigen::MatrixXf centred_features_f_;
  Eigen::VectorXf centred_half_norm2_f_;
  Eigen::Matrix<float, Eigen::Dynamic, 3> weights_f_;
  double cutoff_half_d2_ = 0.0;  // kernel below 1e-15 beyond this
};

// Positions with a map: the parametric model at the curve-corrected angles, + R·correction
// where the kernel has support.
struct MappedPosition {
  Eigen::Vector3d position_mm = Eigen::Vector3d::Zero();    // what to use
  Eigen::Vector3d parametric_mm = Eigen::Vector3d::Zero();  // the parametric model's
  bool map_applied = false;   // all of the map applied (false: no map, or see extrapolated)
  bool extrapolated = false;  // outside the kernel's support, or a joint outside its curve's
  double sigma_mm = 0.0;      // latent σ of the correction per coordinate (NaN if not asked)
};
// `map` may be null (parametric only). Sigma is computed only when `with_sigma` (about
// 30 µs a configuration). `threads` > 1 splits large batches (≥ 1024 configurations each).
std::vector<MappedPosition> PredictPositions(const RobotModel& model,
                                             const Eigen::Isometry3d& world_from_base,
                                             const Eigen::VectorXd& params, const ResidualMap* map,
                                             const std::vector<Eigen::VectorXd>& joints_rad,
                                             bool with_sigma = false, int threads = 1);

enum class FeatureScaling {
  kStandardised,  // each sin / cos column divided by its spread over the fit poses
  kUnit,          // unscaled: a joint turned by Δ moves its features by 2 sin(Δ/2)
};

struct ResidualMapOptions {
  int folds = 5;
  unsigned seed = 1;  // of the fold assignment
  FeatureScaling scaling = FeatureScaling::kStandardised;
  // The search grid (ascending): ℓ in scaled feature units, λ relative to the kernel's
  // unit amplitude. The search starts in the middle and walks to better neighbours.
  std::vector<double> length_scales = {0.25, 0.35, 0.5, 0.7, 1.0, 1.4, 2.0};
  std::vector<double> regularisations = {0.01, 0.03, 0.1, 0.3, 1.0};
  int max_training_poses = 2000;  // above: a farthest-point subset trains the map
  // CV mean with the map ≤ (1 − gain) × parametric CV mean. 5 %: on a complete model whose
  // residual is the instruments' noise (the PUMA demo's 43 parameters) the map's CV gain is
  // 2–3 %, chance structure that does not carry to new poses.
  double required_gain = 0.05;
  std::string output_frame = "base";
  double support_quantile = 0.99;
  double support_margin = 1.25;
  int threads = 2;  // folds evaluated in parallel
  // Joint curves: knots per turn (0: no curves) and the penalty weights searched (relative
  // to the data's mean weight per coefficient), walked from the middle like the grid above.
  // 180 (2°): chosen on an inner split of the UR10's fit poses (docs/explanation/residual-map.md).
  int curve_knots = 180;
  // Fewer training poses than this: no curves. On the UR10 with about 100 (the nightly job's
  // paper-sized selection) the curves' 900 coefficients still help by cross-validation, but
  // two nights' fits of an unchanged robot differ by more than the 0.02 mm the nightly gate
  // allows between versions; from 150 on they are steady (docs/explanation/residual-map.md).
  int curve_min_poses = 150;
  std::vector<double> curve_smoothing = {1e-4, 1e-3, 1e-2, 0.1, 1.0, 10.0};
  // Transfer check (calibration/transfer_folds.h): with the hyperparameters chosen, the two
  // stages are cross-validated again with whole sessions or joint-space regions held out.
  // The curves are kept only when they beat the parametric model there too, the kernel only
  // when it does not make the held-out regions worse (it is local: far from its centres it
  // gives nothing, by construction, and where it does reach it must not hurt). false: the
  // random folds alone decide (the pre-transfer rule).
  bool transfer_check = true;
  // Looked at between cross-validations (never inside the parallel folds): a stop request
  // throws core::Stopped.
  core::StopToken stop;
  void Check() const;
};

struct CrossValidationPoint {
  double length_scale = 0.0, regularisation = 0.0;
  double cv_mean_mm = 0.0;
};

// The result: the map (with its hyperparameters) whether used or not, and both CV figures
// (on the poses that train the map: all fit poses up to max_training_poses).
struct ResidualMapFit {
  bool used = false;
  std::string decision;  // why (used or not), in words
  // NaN when not computed (too few poses, no fit).
  double cv_mean_mm_parametric = std::numeric_limits<double>::quiet_NaN();
  double cv_mean_mm_with_map = std::numeric_limits<double>::quiet_NaN();
  // The joint curves alone (stage 1): NaN when the map has none.
  double cv_mean_mm_curves = std::numeric_limits<double>::quiet_NaN();
  // The transfer check's figures (NaN when it was not made): held-out mean error distance
  // of the parametric model, with the curves, and with curves and kernel, on folds that hold
  // out whole sessions or joint-space regions (`transfer_folds` says which).
  std::string transfer_folds;
  double transfer_mean_mm_parametric = std::numeric_limits<double>::quiet_NaN();
  double transfer_mean_mm_curves = std::numeric_limits<double>::quiet_NaN();
  double transfer_mean_mm_with_map = std::numeric_limits<double>::quiet_NaN();
  // Per training pose (`cv_poses`: indices into the fit poses), its held-out error distance
  // with the map as chosen: on the random folds, and (when the transfer check ran) on the
  // transfer folds. Empty when the map could not be cross-validated.
  std::vector<int> cv_poses;
  std::vector<double> cv_distances_mm, transfer_distances_mm;
  ResidualMapData map;                     // empty centres when it could not be fitted
  std::vector<CrossValidationPoint> grid;  // every (ℓ, λ) evaluated, in order
};

// Fits the map to what `fit` (an Estimate on `poses`) leaves, choosing ℓ and λ by
// cross-validation on these poses only.
ResidualMapFit FitResidualMap(const RobotModel& model, const EstimationResult& fit,
                              const std::vector<MeasuredPose>& poses,
                              const ResidualMapOptions& options = {});

}  // namespace armsig::calibration
