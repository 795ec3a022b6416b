// Term selection (estimation.h): nested models compared by the F-test, terms added by
// forward selection on the linearised cross-validation at the fit.
#include <Eigen/Cholesky>
#include <Eigen/SVD>
#include <algorithm>
#include <cmath>
#include <limits>
#include <set>
#include <stdexcept>
#include <string>
#include <vector>

#include "calibration/cross_validation.h"
#include "calibration/estimation.h"
#include "calibration/orientation.h"
#include "calibration/statistics.h"
#include "calibration/terms.h"
#include "calibration/transfer_folds.h"

namespace armsig::calibration {

FTest CompareNested(const EstimationResult& reduced, const EstimationResult& full,
                    const std::string& added, double alpha) {
  FTest t;
  t.added = added;
  t.rss_reduced = reduced.cost;
  t.rss_full = full.cost;
  t.df_added = static_cast<int>(full.identifiability.identified.size()) -
               static_cast<int>(reduced.identifiability.identified.size());
  t.df_residual = full.redundancy;
  if (t.df_added <= 0 || t.df_residual <= 0 || !(t.rss_full > 0.0)) {
    t.f = 0.0;
    t.p_value = 1.0;
    t.significant = false;
    return t;
  }
  t.f = ((t.rss_reduced - t.rss_full) / t.df_added) / (t.rss_full / t.df_residual);
  t.p_value = FisherFSurvival(t.f, t.df_added, t.df_residual);
  t.significant = t.p_value < alpha;
  return t;
}

void TermSelectionOptions::Check() const {
  if (!(alpha > 0 && alpha < 1)) throw std::invalid_argument("F-test alpha must be in (0, 1)");
  if (folds < 2) throw std::invalid_argument("cross-validation needs at least 2 folds");
  if (!(min_cv_gain >= 0 && min_cv_gain < 1)) {
    throw std::invalid_argument("minimum cross-validation gain must be in [0, 1)");
  }
}

LinearisedCrossValidation CrossValidationAtFit(const RobotModel& model, const EstimationResult& fit,
                                               const std::vector<MeasuredPose>& poses,
                                               const std::vector<int>& leading,
                                               const std::vector<int>& trailing,
                                               const std::vector<int>& fold_of_pose, int folds) {
  const int m = static_cast<int>(poses.size());
  const int k = static_cast<int>(leading.size()), c = static_cast<int>(trailing.size());
  const double w = fit.orientation_weight_mm_per_rad;
  // Orientation equations for the poses that have one in a frame with a tool rotation, and
  // a tool rotation's columns for each frame that has such poses.
  std::vector<int> oriented;  // in row order
  std::map<int64_t, int> tool_column;
  for (int i = 0; i < m; ++i) {
    if (!(w > 0.0 && poses[i].orientation && fit.tool_rotations.count(poses[i].frame))) continue;
    oriented.push_back(i);
    tool_column.emplace(poses[i].frame, 0);
  }
  int next_tool = k;
  for (auto& [frame, column] : tool_column) {
    column = next_tool;
    if (!fit.tool_rotation_shared || next_tool == k) next_tool += 3;
    if (fit.tool_rotation_shared) column = k;
  }
  const int t = next_tool - k;
  const int mo = static_cast<int>(oriented.size());
  Eigen::MatrixXd jacobian = Eigen::MatrixXd::Zero(3 * m + 3 * mo, k + t + c);
  Eigen::VectorXd residual(3 * m + 3 * mo);
  Kinematics kin(model);
  Eigen::Matrix<double, 6, Eigen::Dynamic> block(6, model.num_parameters());
  for (int i = 0, o = 0; i < m; ++i) {
    // Each pose in its own measurement frame's base (held at the fit's value).
    const Eigen::Vector3d x = kin.PoseAndJacobian(fit.base_of(poses[i].frame), fit.params,
                                                  poses[i].joints_rad.data(), block);
    residual.segment<3>(3 * i) = x - poses[i].target_in_world;
    for (int a = 0; a < k; ++a) jacobian.block<3, 1>(3 * i, a) = block.col(leading[a]).head<3>();
    for (int a = 0; a < c; ++a)
      jacobian.block<3, 1>(3 * i, k + t + a) = block.col(trailing[a]).head<3>();
    if (o >= mo || oriented[o] != i) continue;
    const int row = 3 * m + 3 * o++;
    const OrientationLinearisation l =
        LineariseOrientation(poses[i].orientation->world_from_target, kin.LastRotation(),
                             fit.tool_rotations.at(poses[i].frame));
    residual.segment<3>(row) = w * l.residual;
    for (int a = 0; a < k; ++a)
      jacobian.block<3, 1>(row, a) = w * l.by_world_turn * block.col(leading[a]).tail<3>();
    jacobian.block<3, 3>(row, tool_column.at(poses[i].frame)) = w * l.by_tool_turn;
    for (int a = 0; a < c; ++a)
      jacobian.block<3, 1>(row, k + t + a) = w * l.by_world_turn * block.col(trailing[a]).tail<3>();
  }
  return LinearisedCrossValidation(std::move(jacobian), std::move(residual), fold_of_pose, folds,
                                   std::move(oriented));
}

AutoSelection SelectTerms(const RobotModel& model, const std::vector<MeasuredPose>& poses,
                          const EstimationOptions& options,
                          const TermSelectionOptions& selection_options) {
  selection_options.Check();
  AutoSelection selection;
  EstimationOptions opts = options;
  for (int i = 0; i < model.num_geometric(); ++i) {
    if (!model.IsHeld(i)) selection.parameters.push_back(i);
  }
  opts.parameters = selection.parameters;
  EstimationResult current = Estimate(model, poses, opts);
  // With orientation equations every later fit keeps the weight the geometric fit found, so
  // that all the F-tests compare sums of squares in one metric.
  if (current.orientation_weight_mm_per_rad > 0.0) {
    opts.orientation_weight_mm_per_rad = current.orientation_weight_mm_per_rad;
  }
  std::vector<int> remaining;
  for (int i = model.num_geometric(); i < model.num_parameters(); ++i) {
    if (options.parameters.empty() ||
        std::find(options.parameters.begin(), options.parameters.end(), i) !=
            options.parameters.end()) {
      remaining.push_back(i);
    }
  }
  const auto names = model.ParameterNames();
  const int m = static_cast<int>(poses.size());
  const bool cross_validate = selection_options.cross_validate && m >= 2 * selection_options.folds;
  std::vector<int> folds(m, 0);
  int fold_count = 1;
  if (cross_validate) {
    std::optional<TransferFolds> transfer;
    if (selection_options.transfer_folds) {
      transfer = AssignTransferFolds(model, poses, selection_options.folds, selection_options.seed);
    }
    if (transfer && transfer->folds >= 2) {
      folds = transfer->fold_of_pose;
      fold_count = transfer->folds;
      selection.folds = transfer->Describe();
    } else {
      folds = AssignFolds(m, selection_options.folds, selection_options.seed);
      fold_count = selection_options.folds;
      selection.folds = std::to_string(fold_count) + " random folds";
    }
  }
  // A candidate is identifiable next to the current set when its unit-scaled column keeps
  // a part orthogonal to theirs above the rank tolerance (the QR's criterion).
  const double tolerance = std::max(options.identifiability.relative_tolerance, 1e-6);
  bool first = true;
  // One round per added term; the first also measures the geometric model's CV error, even
  // when there is nothing to add.
  while (current.usable() && (first || !remaining.empty())) {
    // Linearise at the current fit: columns of the identified subset, the frames' tool
    // rotations (always kept), then the candidates.
    const std::vector<int>& kept = current.identifiability.identified;
    const int k = static_cast<int>(kept.size());
    const int c = static_cast<int>(remaining.size());
    const LinearisedCrossValidation cv =
        CrossValidationAtFit(model, current, poses, kept, remaining, folds, fold_count);
    const int t = static_cast<int>(cv.jacobian().cols()) - k - c;  // tool-rotation columns
    const Eigen::MatrixXd& jacobian = cv.jacobian();
    std::vector<int> base(k + t);
    for (int a = 0; a < k + t; ++a) base[a] = a;
    if (first) {
      if (cross_validate)
        selection.cv_mean_mm_geometric = selection.cv_mean_mm = cv.HeldOutMeanMm(base);
      first = false;
    }
    if (remaining.empty()) break;
    const double rss_base = cv.ResidualSumOfSquares(base);
    // Projections onto the kept columns, for the identifiability check and the RSS drop.
    Eigen::MatrixXd normal = jacobian.transpose() * jacobian;
    const Eigen::LDLT<Eigen::MatrixXd> kept_normal(normal.topLeftCorner(k + t, k + t));
    int best = -1, best_record = -1;
    double best_cv = std::numeric_limits<double>::infinity(), best_f = 0.0;
    for (int a = 0; a < c; ++a) {
      const int col = k + t + a;
      const Eigen::VectorXd cross = normal.block(0, col, k + t, 1);
      const double schur = normal(col, col) - cross.dot(kept_normal.solve(cross));
      if (!(normal(col, col) > 0) || !(schur > tolerance * tolerance * normal(col, col))) continue;
      std::vector<int> with = base;
      with.push_back(col);
      FTest test;
      test.added = names[remaining[a]];
      test.rss_reduced = rss_base;
      test.rss_full = cv.ResidualSumOfSquares(with);
      test.df_added = 1;
      test.df_residual = current.redundancy - 1;  // 3m − rank − 6 per extra frame − 1
      if (test.df_residual > 0 && test.rss_full > 0) {
        test.f =
            std::max(0.0, (test.rss_reduced - test.rss_full) / (test.rss_full / test.df_residual));
        test.p_value = FisherFSurvival(test.f, 1, test.df_residual);
        test.significant = test.p_value < selection_options.alpha;
      }
      if (test.significant && cross_validate) test.cv_mean_mm = cv.HeldOutMeanMm(with);
      const bool better = cross_validate ? test.significant && test.cv_mean_mm < best_cv
                                         : test.significant && test.f > best_f;
      if (better) {
        best = a;
        best_record = static_cast<int>(selection.tests.size());
        best_cv = test.cv_mean_mm;
        best_f = test.f;
      }
      selection.tests.push_back(test);
    }
    if (best < 0) break;
    if (cross_validate && best_cv > (1.0 - selection_options.min_cv_gain) * selection.cv_mean_mm) {
      break;
    }
    // Add it: refit both ways and redo its F-test on the fitted models.
    std::vector<int> trial_parameters = selection.parameters;
    trial_parameters.push_back(remaining[best]);
    std::sort(trial_parameters.begin(), trial_parameters.end());
    opts.parameters = trial_parameters;
    EstimationResult trial = Estimate(model, poses, opts);
    if (!trial.usable()) break;
    FTest exact = CompareNested(current, trial, names[remaining[best]], selection_options.alpha);
    if (!exact.significant) break;
    exact.cv_mean_mm = selection.tests[best_record].cv_mean_mm;
    exact.accepted = true;
    selection.tests[best_record] = exact;  // the fitted models' test replaces the linearised one
    selection.parameters = trial_parameters;
    if (cross_validate) selection.cv_mean_mm = best_cv;
    remaining.erase(remaining.begin() + best);
    current = std::move(trial);
  }
  return selection;
}

AutoSelection SelectTermsByFTest(const RobotModel& model, const std::vector<MeasuredPose>& poses,
                                 const EstimationOptions& options, double alpha) {
  TermSelectionOptions selection;
  selection.alpha = alpha;
  return SelectTerms(model, poses, options, selection);
}

}  // namespace armsig::calibration
