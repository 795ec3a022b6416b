// Human and machine output of a calibration: the paper's Table 1–3 layout and the
// calibrate JSON of docs/reference/file-formats.md.
#pragma once

#include <limits>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "calibration/estimation.h"
#include "calibration/residual_map.h"
#include "calibration/selection.h"
#include "calibration/validity.h"
#include "core/stop_token.h"
#include "core/types.h"
#include "db/store.h"

namespace armsig::workflows {

// One measurement frame of a run (a session): its base and how many of its poses were
// fitted and validated. `base_from_validation`: none of its poses was fitted, so its base
// was aligned on its validation poses with the fitted parameters (six of their degrees of
// freedom are then spent on it).
struct RunFrame {
  int64_t frame = 0;
  Eigen::Isometry3d world_from_base = Eigen::Isometry3d::Identity();
  int fit_poses = 0, validation_poses = 0;
  bool base_from_validation = false;
};

struct CalibrationRun {
  std::string params_spec;
  calibration::EstimationResult estimate;
  // Every measurement frame of the fit and validation poses, ascending (one when all
  // poses come from one set-up, as in a file).
  std::vector<RunFrame> frames;
  std::vector<std::string> fit_pose_ids;
  std::vector<std::string> validation_pose_ids;
  // Each validation pose in its own frame, with that frame's base.
  std::vector<Eigen::Vector3d> validation_residuals, validation_nominal_residuals;
  // With orientation equations in the fit: each validation pose's orientation residual
  // (rad, nullopt for one measured without orientation), with its frame's tool rotation
  // (a frame none of whose poses was fitted gets one aligned on its validation poses, as
  // its base).
  std::vector<std::optional<Eigen::Vector3d>> validation_orientation_residuals;
  calibration::ToolRotations tool_rotations;
  std::optional<calibration::SelectionResult> selection;
  int selection_candidates = 0;
  std::optional<calibration::AutoSelection> auto_terms;
  // The residual map (--residual-model auto), fitted and cross-validated on the fit poses
  // only; absent with --residual-model off. When it is used, `validation_residuals` have it
  // applied and `validation_parametric_residuals` are the parametric model's alone.
  std::optional<calibration::ResidualMapFit> residual_map;
  std::vector<Eigen::Vector3d> validation_parametric_residuals;
  // Per validation pose when the map is used: its predictive σ per coordinate (mm; the
  // latent σ of the correction and the map's noise σ, see residual_map.h), and whether the
  // pose was outside the map's support (then the parametric prediction, flagged).
  std::vector<double> validation_map_sigma_mm;
  std::vector<char> validation_map_extrapolated;
  bool map_used() const { return residual_map && residual_map->used; }
  // Where the set holds (its terms' joint arcs) and its predicted σ's calibration on held-out
  // data (calibration/validity.h); absent when the fit gave no usable estimate.
  std::optional<calibration::SetValidity> validity;
  // Over the validation poses when the map is used: how many were outside its support,
  // and the mean predictive σ (NaN without).
  struct MapValidation {
    int outside = 0, poses = 0;
    double mean_sigma_mm = std::numeric_limits<double>::quiet_NaN();
  };
  MapValidation map_validation() const;
};

// Runs the whole calibrate pipeline (selection, --params auto, estimation, validation).
// Poses from several measurement frames (MeasuredPose::frame) are fitted with one base per
// frame and validated in their own frame. Throws InputError for input problems (unknown
// parameter, too few poses, degenerate data, a --select too small to place every frame).
struct CalibrateSettings {
  std::string params = "all";
  int select = 0;
  double robust_threshold_mm = 0.0;
  int max_iterations = 50;  // Levenberg–Marquardt iterations before "not converged"
  double alpha = 0.01;
  double rank_tolerance = 1e-7;
  // Candidates narrowed to what the model identifies from configurations spread over its
  // joint limits (calibration::ModelIdentifiableSubset): every set of a robot then
  // estimates the same parameters in the same gauge, whatever poses a night brought.
  bool model_subset = false;
  // "auto": fit the residual map after the parametric model and use it when its
  // cross-validated error beats the parametric model's by a clear margin; "off": never.
  std::string residual_model = "auto";
  // "auto": the poses' measured orientations (6-DoF targets) join the fit when they have
  // them; "off": positions only. The weight of orientation against position, mm per rad
  // (0: variance components, calibration::EstimationOptions).
  std::string orientation = "auto";
  double orientation_weight_mm_per_rad = 0.0;
  // "per-session": every session's probe rotation on the flange is its own (it may have
  // been remounted); "shared": one for all (it stayed on).
  std::string tool_rotation = "per-session";
  // A stop request (Ctrl-C, SIGTERM) ends the run within a solver iteration, a selection
  // step or a cross-validation: core::Stopped is thrown, nothing is returned.
  core::StopToken stop;
};
// The --params spec's parameters of `model` ("auto": all of them, the candidates), as
// RunCalibration reads it; InputError naming --params (with the nearest valid word) for a
// spec the model cannot take. Called before any data is read.
std::vector<int> ParamsOf(const calibration::RobotModel& model, const std::string& spec);

CalibrationRun RunCalibration(const calibration::RobotModel& model,
                              const std::vector<MeasuredPose>& poses,
                              const std::vector<MeasuredPose>& holdout,
                              const CalibrateSettings& settings);

// FormatCalibrationReport, the run as text: workflows/calibration_text.h.

// Residuals (model − measured) of poses, each in its frame's base, with a residual map's
// correction where the pose is inside its support (`map` null: parametric). `outside`
// (when given) gets one flag per pose: the map was not applied there.
std::vector<Eigen::Vector3d> MappedResiduals(const calibration::RobotModel& model,
                                             const calibration::FrameBases& bases,
                                             const Eigen::VectorXd& params,
                                             const calibration::ResidualMap* map,
                                             const std::vector<MeasuredPose>& poses,
                                             std::vector<char>* outside = nullptr);

// Error statistics of a set of residual vectors.
calibration::ErrorStats StatsOf(const std::vector<Eigen::Vector3d>& residuals);

nlohmann::json CalibrationJson(const calibration::RobotModel& model, const CalibrationRun& run);

// The database record of a calibration run (parameters, statistics, residuals).
db::CalibrationRecord CalibrationRecordOf(const calibration::RobotModel& model,
                                          const CalibrationRun& run, int64_t robot_id,
                                          const nlohmann::json& inputs,
                                          const nlohmann::json& options, bool active);

}  // namespace armsig::workflows
