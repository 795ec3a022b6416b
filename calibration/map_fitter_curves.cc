// The joint curves of the residual map's fitter (map_fitter.h): per-joint periodic
// splines fitted before the kernel map, kept only when they cross-validate better.
#include <Eigen/Cholesky>
#include <algorithm>
#include <cmath>
#include <vector>

#include "calibration/map_fitter.h"

namespace armsig::calibration::detail {

void MapFitter::AddCurveRows(int t, const Eigen::Vector3d& y, Eigen::MatrixXd* normal,
                             Eigen::VectorXd& rhs) const {
  // Four bumps per curve joint: at most 4 × joints columns of the design row are non-zero.
  thread_local std::vector<int> column;
  thread_local std::vector<Eigen::Vector3d> g;
  column.resize(4 * curve_joints_);
  g.resize(4 * curve_joints_);
  int used = 0;
  for (int k = 0; k < curve_joints_; ++k) {
    const CurveSpan& s = span_[t * curve_joints_ + k];
    for (int b = 0; b < 4; ++b) {
      column[used] = k * knots_ + (s.first + b) % knots_;
      g[used++] = lever_[t * curve_joints_ + k] * s.weight[b];
    }
  }
  for (int a = 0; a < used; ++a) {
    rhs(column[a]) += g[a].dot(y);
    if (!normal) continue;
    for (int b = 0; b < used; ++b) (*normal)(column[a], column[b]) += g[a].dot(g[b]);
  }
}

Eigen::Vector3d MapFitter::CurveCorrection(int t, const Eigen::VectorXd& x) const {
  Eigen::Vector3d c = Eigen::Vector3d::Zero();
  for (int k = 0; k < curve_joints_; ++k) {
    const CurveSpan& s = span_[t * curve_joints_ + k];
    double delta = 0.0;
    for (int b = 0; b < 4; ++b) delta += s.weight[b] * x(k * knots_ + (s.first + b) % knots_);
    c += lever_[t * curve_joints_ + k] * delta;
  }
  return c;
}

// Penalised least squares: the second differences of neighbouring coefficients weigh
// `smoothing` times the data's mean weight per coefficient. Where no pose was measured the
// curve is pulled to zero (as hard as the data's mean weight pulls a measured knot): an
// arc of a joint never measured gets no correction, not the bridge between its ends. A
// millionth keeps a constant the parametric model already took determined.
Eigen::VectorXd MapFitter::SolveCurves(const Eigen::MatrixXd& normal, const Eigen::VectorXd& rhs,
                                       double smoothing, const std::vector<int>& measured,
                                       Eigen::MatrixXd& system) const {
  Eigen::MatrixXd& a = system;
  a.noalias() = normal + (smoothing * penalty_scale_) * penalty_;
  a.diagonal().array() += 1e-6 * penalty_scale_;
  for (size_t c = 0; c < measured.size(); ++c) {
    if (!measured[c]) a(c, c) += penalty_scale_;
  }
  // Symmetric positive definite: the blocked Cholesky, in place (a holds the factor).
  const Eigen::LLT<Eigen::Ref<Eigen::MatrixXd>> llt(a);
  return llt.solve(rhs);
}

void MapFitter::SizeCurveBuffers(int workers) {
  const Eigen::Index p = static_cast<Eigen::Index>(curve_joints_) * knots_;
  if (static_cast<int>(curve_buffers_.size()) < workers) curve_buffers_.resize(workers);
  for (auto& b : curve_buffers_) {
    b.system.resize(p, p);
    b.normal.resize(p, p);
  }
}

// Stage 1: the joint curves, their smoothing chosen by the same folds as the kernel's
// hyperparameters (walked from the middle of the grid to the best neighbour). Each fold's
// refit residuals then become what that fold's curves leave, so the kernel's
// cross-validation below scores the two stages together.
void MapFitter::FitCurves() {
  if (options_.curve_knots == 0 || mt_ < options_.curve_min_poses) return;
  knots_ = options_.curve_knots;
  const std::vector<int>& joints = map().joints;
  curve_joints_ = static_cast<int>(joints.size());
  const int p = curve_joints_ * knots_;
  span_.resize(static_cast<size_t>(mt_) * curve_joints_);
  lever_.resize(span_.size());
  Kinematics kin(model_);
  for (int t = 0; t < mt_; ++t) {
    const MeasuredPose& pose = poses_[train_[t]];
    kin.Position(fit_.base_of(pose.frame), fit_.params, pose.joints_rad.data());
    const Eigen::Matrix<double, 3, Eigen::Dynamic> lever = kin.JointJacobian();
    for (int k = 0; k < curve_joints_; ++k) {
      span_[t * curve_joints_ + k] = CurveSpanAt(knots_, pose.joints_rad(joints[k]));
      lever_[t * curve_joints_ + k] = frame_[t].transpose() * lever.col(joints[k]);
    }
  }
  // A knot is measured when a training pose lies within kCurveReachRad of it: gaps between
  // sparse poses are bridged by the smoothing, not taken for arcs nobody measured.
  measured_.assign(p, 0);
  const double spacing = 2.0 * std::acos(-1.0) / knots_;
  const int reach = static_cast<int>(std::floor(kCurveReachRad / spacing));
  for (int t = 0; t < mt_; ++t) {
    for (int k = 0; k < curve_joints_; ++k) {
      const int nearest = span_[t * curve_joints_ + k].nearest;
      for (int d = -reach; d <= reach; ++d)
        measured_[k * knots_ + ((nearest + d) % knots_ + knots_) % knots_] = 1;
    }
  }
  // Normal matrices: all training poses, and each fold's share (its complement trains).
  Eigen::MatrixXd all = Eigen::MatrixXd::Zero(p, p);
  std::vector<Eigen::MatrixXd> train(folds_);
  std::vector<Eigen::VectorXd> rhs(folds_, Eigen::VectorXd::Zero(p));
  Eigen::VectorXd unused = Eigen::VectorXd::Zero(p);
  for (int t = 0; t < mt_; ++t) AddCurveRows(t, Eigen::Vector3d::Zero(), &all, unused);
  const int workers = std::max(1, std::min(options_.threads, folds_));
  SizeCurveBuffers(workers);
  Eigen::MatrixXd& in_fold = curve_buffers_[0].normal;
  for (int f = 0; f < folds_; ++f) {
    in_fold.setZero();
    for (int t : fold_rows_[f]) AddCurveRows(t, Eigen::Vector3d::Zero(), &in_fold, unused);
    train[f] = all - in_fold;
    for (int t : train_rows_[f]) AddCurveRows(t, -refit_[f].row(t).transpose(), nullptr, rhs[f]);
  }
  penalty_scale_ = all.diagonal().mean();
  if (!(penalty_scale_ > 0)) return;  // no joint moves the target at these poses
  penalty_ = Eigen::MatrixXd::Zero(p, p);
  for (int k = 0; k < curve_joints_; ++k) {
    for (int m = 0; m < knots_; ++m) {
      const int c[3] = {k * knots_ + m, k * knots_ + (m + 1) % knots_, k * knots_ + (m + 2) % knots_};
      const double w[3] = {1.0, -2.0, 1.0};
      for (int a = 0; a < 3; ++a)
        for (int b = 0; b < 3; ++b) penalty_(c[a], c[b]) += w[a] * w[b];
    }
  }
  const std::vector<double>& grid = options_.curve_smoothing;
  std::map<int, std::pair<double, std::vector<Eigen::VectorXd>>> scored;  // by grid index
  auto score = [&](int gi) -> double {
    if (auto it = scored.find(gi); it != scored.end()) return it->second.first;
    options_.stop.ThrowIfRequested();
    std::vector<Eigen::VectorXd> x(folds_);
    std::vector<double> sum(folds_, 0.0);
    ParallelForWorkers(folds_, workers, [&](int f, int worker) {
      x[f] = SolveCurves(train[f], rhs[f], grid[gi], measured_, curve_buffers_[worker].system);
      for (int t : fold_rows_[f])
        sum[f] += (refit_[f].row(t).transpose() + CurveCorrection(t, x[f])).norm();
    });
    double mean = 0.0;
    for (double v : sum) mean += v / mt_;
    if (!std::isfinite(mean)) mean = std::numeric_limits<double>::infinity();
    scored[gi] = {mean, std::move(x)};
    return mean;
  };
  int best = static_cast<int>(grid.size()) / 2;
  for (double best_mean = score(best);;) {
    int next = best;
    for (int step : {-1, 1}) {
      const int gi = best + step;
      if (gi < 0 || gi >= static_cast<int>(grid.size())) continue;
      if (const double m = score(gi); m < best_mean) {
        best_mean = m;
        next = gi;
      }
    }
    if (next == best) break;
    best = next;
  }
  const auto& [mean, x] = scored[best];
  if (!std::isfinite(mean)) return;
  result_.cv_mean_mm_curves = mean;
  // Curves that do not beat the parametric model on their own are left out: the error is
  // not of one joint's angle, and the kernel alone learns it (as a map without curves).
  if (!(mean < result_.cv_mean_mm_parametric)) return;
  for (int f = 0; f < folds_; ++f) {
    for (int t = 0; t < mt_; ++t) refit_[f].row(t) += CurveCorrection(t, x[f]).transpose();
  }
  JointCurvesData& curves = map().curves;
  curves.knots = knots_;
  curves.joints = joints;
  curves.smoothing = grid[best];
}

}  // namespace armsig::calibration::detail
