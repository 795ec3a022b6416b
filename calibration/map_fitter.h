// Internal to calibration/ (residual_map.cc, map_fitter_curves.cc): the residual map's
// fitter, whose joint-curve part lives in a file of its own, and the parallel loop both use.
#pragma once

#include <Eigen/Core>
#include <algorithm>
#include <limits>
#include <map>
#include <optional>
#include <thread>
#include <utility>
#include <vector>

#include "calibration/residual_map.h"

namespace armsig::calibration::detail {

// A joint curve's knot within this of a training pose's angle counts as measured (5°).
constexpr double kCurveReachRad = 5.0 * 3.14159265358979323846 / 180.0;

// Runs body(f, worker) for f = 0 … count−1 on up to `threads` threads; `worker` (0 … threads−1)
// names the thread, for buffers of its own.
template <typename Body>
void ParallelForWorkers(int count, int threads, const Body& body) {
  threads = std::min(threads, count);
  if (threads <= 1) {
    for (int f = 0; f < count; ++f) body(f, 0);
    return;
  }
  std::vector<std::thread> workers;
  for (int t = 0; t < threads; ++t) {
    workers.emplace_back([&, t] {
      for (int f = t; f < count; f += threads) body(f, t);
    });
  }
  for (auto& w : workers) w.join();
}

// Runs body(f) for f = 0 … count−1 on up to `threads` threads.
template <typename Body>
void ParallelFor(int count, int threads, const Body& body) {
  ParallelForWorkers(count, threads, [&](int f, int) { body(f); });
}

// Fits the residual map to what a parametric fit leaves and decides whether to use it. The
// steps share the fit poses' features, the training poses, their residuals under the
// parametric refit without each fold and the kernel's distances, so they are the methods
// of one object that is used once: Run() reads like the procedure (linearise the fit,
// choose the features and the training poses, cross-validate the parametric model, the
// support radius, walk the (ℓ, λ) grid, fit the map, decide).
class MapFitter {
 public:
  MapFitter(const RobotModel& model, const EstimationResult& fit,
            const std::vector<MeasuredPose>& poses, const ResidualMapOptions& options)
      : model_(model),
        fit_(fit),
        poses_(poses),
        options_(options),
        m_(static_cast<int>(poses.size())),
        folds_(options.folds) {}
  ResidualMapFit Run();

 private:
  // The cross-validated mean error distance of one (ℓ, λ) (infinite when a kernel matrix
  // was not positive definite), and the sum of squared errors.
  struct Score {
    double mean = std::numeric_limits<double>::infinity(), sum_sq = 0.0;
  };

  bool HasFitToLearnFrom();
  void LineariseParametricFit();
  bool ChooseFeatures();
  void CrossValidateParametricModel();
  void FitCurves();
  void SetSupportRadius();
  const Eigen::MatrixXf& Kernel(int li);
  // `distances` (when given): each training pose's held-out error distance (mt_).
  Score CrossValidate(int li, int ri, std::vector<double>* distances = nullptr);
  Score ScoreOf(int li, int ri);
  bool SearchGrid();
  void FitMap();
  void TransferCheck();
  void Decide();
  ResidualMapData& map() { return result_.map; }
  // Joint curves: training pose t's contribution to the normal equations of the curve
  // coefficients (P = joints × knots) for the target y (map frame), and its correction.
  void AddCurveRows(int t, const Eigen::Vector3d& y, Eigen::MatrixXd* normal,
                    Eigen::VectorXd& rhs) const;
  Eigen::Vector3d CurveCorrection(int t, const Eigen::VectorXd& x) const;
  // `system`: a P × P buffer the penalised normal matrix is formed and factorised in.
  Eigen::VectorXd SolveCurves(const Eigen::MatrixXd& normal, const Eigen::VectorXd& rhs,
                              double smoothing, const std::vector<int>& measured,
                              Eigen::MatrixXd& system) const;
  // At least `workers` P × P curve systems (and normal matrices), sized before the workers start.
  void SizeCurveBuffers(int workers);

  const RobotModel& model_;
  const EstimationResult& fit_;
  const std::vector<MeasuredPose>& poses_;
  const ResidualMapOptions& options_;
  const int m_;  // fit poses
  const int folds_;
  ResidualMapFit result_;

  std::optional<LinearisedCrossValidation> cv_;  // of the parametric model
  std::vector<int> train_;              // the training poses (indices into poses_), ascending
  int mt_ = 0;                          // how many
  Eigen::MatrixXd u_;                   // their scaled features, mt × 2 per feature joint
  std::vector<Eigen::Matrix3d> frame_;  // each one's map frame in the measuring frame
  std::vector<int> fold_of_;            // each one's fold
  std::vector<Eigen::MatrixXd> refit_;  // per fold: mt × 3 residuals, refit without it
  Eigen::MatrixXd half_d2_;             // half squared feature distances, mt × mt
  std::vector<std::vector<int>> fold_rows_, train_rows_;  // per fold: in it, and not
  std::map<int, Eigen::MatrixXf> kernels_;                // by ℓ index, the few most recent
  // Per cross-validation worker: the fold's kernel matrix (factorised in place) and its
  // cross-kernel, sized once for the largest fold and reused by every grid point: a fresh
  // matrix of a thousand poses each time was 4 MB of new pages to fault in and clear.
  struct FoldBuffers {
    Eigen::MatrixXf a, kft;
  };
  std::vector<FoldBuffers> fold_buffers_;
  std::map<std::pair<int, int>, Score> scored_;
  // Joint curves: per training pose and curve joint, the bumps under its angle and the
  // joint's lever ∂x/∂θ_j in the map frame (mt × curve joints, row-major).
  int knots_ = 0, curve_joints_ = 0;
  std::vector<CurveSpan> span_;
  std::vector<Eigen::Vector3d> lever_;
  Eigen::MatrixXd penalty_;  // P × P: the periodic second differences' DᵀD
  double penalty_scale_ = 0.0;
  std::vector<int> measured_;  // per coefficient: 1 when a training pose lies within 5° of it
  // Per worker: a curve solve's P × P system, formed and factorised in place, and a fold's
  // normal matrix. A fresh 9 MB matrix and the Cholesky's copy of it at every solve were
  // 4,600 new pages to fault in, at the sanitizers' cost of each page and its shadow.
  struct CurveBuffers {
    Eigen::MatrixXd system, normal;
  };
  std::vector<CurveBuffers> curve_buffers_;
};

}  // namespace armsig::calibration::detail
