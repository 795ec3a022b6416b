// Where a fitted set holds, and how well it predicts there and beyond: stored with the set
// (io/validity_json.h) and used by every prediction made with it (predict, compensate, the
// program compensation, the report).
//
//  - The terms' support: the arc of each joint's encoder angles the fit poses covered. The
//    set's model evaluates its non-geometric terms clamped to these arcs
//    (RobotModel::term_support): no term follows its formula where no data checked it.
//  - The predicted σ: the parameters' own uncertainty (the covariance, J Σ Jᵀ) only says how
//    well the fit poses fixed the parameters, not how well the model fits the robot; the
//    error of a prediction also holds what the model cannot represent. That part is measured
//    on held-out data: per coordinate, on random held-out folds (configurations among the fit
//    poses: `inside`) and on whole held-out sessions or joint-space regions (configurations
//    beside them: `outside`, calibration/transfer_folds.h). A prediction's σ per coordinate
//    is √(σ_param² + s²), s the inside figure where the set's map and terms apply and the
//    outside one where they do not; s is the smallest value that puts 95 % of those held-out
//    poses within kCoverageRadius σ (the radius an isotropic 3-D σ gives 95 %: a model's
//    leftovers are seldom isotropic, so s is fitted to the quantile, not to the mean
//    square). The coverage is stated, not assumed: the share within, on those folds, and on
//    real data another day (docs/explanation/never-worse.md).
#pragma once

#include <Eigen/Core>
#include <limits>
#include <string>
#include <vector>

#include "calibration/estimation.h"
#include "calibration/model.h"
#include "calibration/residual_map.h"
#include "core/types.h"

namespace armsig::calibration {

// A 3-D error with σ per coordinate lies within 2.7955 σ of zero 95 % of the time (the
// χ distribution with three degrees of freedom).
inline constexpr double kCoverageRadius = 2.7955;

struct SetValidity {
  std::vector<JointArc> term_arcs;  // one per joint; empty: no support stored
  double sigma_inside_mm = std::numeric_limits<double>::quiet_NaN();
  double sigma_outside_mm = std::numeric_limits<double>::quiet_NaN();
  // The share of held-out poses within kCoverageRadius × their predicted σ, on each kind of
  // fold (NaN when not measured), and how the outside folds were made.
  double coverage_inside = std::numeric_limits<double>::quiet_NaN();
  double coverage_outside = std::numeric_limits<double>::quiet_NaN();
  std::string outside_folds;
  bool empty() const { return term_arcs.empty(); }
};

// The validity of a fit: its poses' arcs, and the held-out σ of the parametric model (with
// the map's cross-validated residuals when `map` is given and used: the map fit keeps them).
SetValidity EstimateValidity(const RobotModel& model, const EstimationResult& fit,
                             const std::vector<MeasuredPose>& fit_poses,
                             const ResidualMapFit* map, unsigned seed = 1);

// The parametric prediction's standard error per coordinate (mm, √(tr(J Σ Jᵀ)/3)) at the
// encoder angles; NaN without a covariance. `identified`: the covariance's parameters.
double ParametricSigmaMm(const RobotModel& model, const Eigen::VectorXd& params,
                         const std::vector<int>& identified, const Eigen::MatrixXd& covariance,
                         const Eigen::VectorXd& joints_rad);

// Whether a configuration is where the set was fitted: every joint inside its term arc (a
// set without stored arcs: true), and the map (when given) applied in full.
struct Support {
  bool inside = true;
  std::vector<int> joints_outside;  // 0-based, beyond their term arcs
  std::vector<std::string> held_terms;  // terms held at their arcs' edge there
  bool map_outside = false;         // the map gave nothing (or not all) there
  // "joint 1 at 152.3° outside 10.2°…120.4° (e1_s2, e1_c2 held); outside the residual map"
  std::string Describe(const Eigen::VectorXd& joints_rad, const SetValidity& validity) const;
};
// Terms whose coefficient in `params` is zero do not count (held or not, they add nothing).
Support SupportAt(const RobotModel& model, const Eigen::VectorXd& params,
                  const SetValidity& validity, const Eigen::VectorXd& joints_rad,
                  bool map_outside);

// σ per coordinate of a prediction: √(σ_param² + s²) with s inside or outside (outside
// without a held-out figure there: the inside one; NaN parts count as zero; NaN when neither
// is known).
double PredictionSigmaMm(double parametric_sigma_mm, const SetValidity& validity, bool inside);

}  // namespace armsig::calibration
