#include "calibration/residual_map.h"

#include <Eigen/Cholesky>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <map>
#include <optional>
#include <stdexcept>
#include <thread>
#include <utility>

#if defined(__SSE2__)
#include <xmmintrin.h>
#endif

#include "calibration/map_fitter.h"
#include "calibration/transfer_folds.h"

namespace armsig::calibration {

using detail::ParallelFor;
using detail::ParallelForWorkers;

namespace {

// Configurations per block in batch prediction (bounds the M × B distance matrix).
constexpr int kBatchBlock = 64;
// Kernel values below e^−34.5 ≈ 1e-15 are left out of sums (their weights are mm-sized).
constexpr double kNegligibleExponent = 34.5;
// Centres the local GP variance is conditioned on.
constexpr int kVarianceNeighbours = 32;

Eigen::Matrix3d TurnAboutZ(double angle) {
  return Eigen::AngleAxisd(angle, Eigen::Vector3d::UnitZ()).toRotationMatrix();
}

void Require(bool condition, const std::string& what) {
  if (!condition) throw std::invalid_argument("residual map: " + what);
}

// Denormal numbers (below 1e-38 in single precision) make the factorisations of kernel
// matrices a hundred times slower and change nothing that matters: while one of these is
// alive, this thread's SSE unit flushes them to zero (restored on destruction).
class FlushDenormals {
 public:
#if defined(__SSE2__)
  FlushDenormals() : saved_(_mm_getcsr()) { _mm_setcsr(saved_ | 0x8040); }  // FTZ | DAZ
  ~FlushDenormals() { _mm_setcsr(saved_); }

 private:
  unsigned saved_;
#endif
};

}  // namespace

ResidualMap::ResidualMap(ResidualMapData data) : data_(std::move(data)) {
  Require(data_.version >= 1 && data_.version <= ResidualMapData::kVersion,
          "version " + std::to_string(data_.version) + " is not known (expected 1 to " +
              std::to_string(ResidualMapData::kVersion) + ")");
  Require(data_.version >= 2 || data_.curves.empty(), "a version-1 map has no joint curves");
  Require(data_.kind == ResidualMapData::kKind, "unknown kind '" + data_.kind + "'");
  Require(data_.output_frame == "base" || data_.output_frame == "joint1",
          "output frame must be 'base' or 'joint1', got '" + data_.output_frame + "'");
  Require(data_.num_joints > 0, "the model's joint count must be positive");
  try {
    CheckJointCurves(data_.curves, data_.num_joints);
  } catch (const std::invalid_argument& e) {
    Require(false, e.what());
  }
  const int j = static_cast<int>(data_.joints.size());
  Require(j > 0, "no feature joints");
  Require(data_.feature_scale.size() == 2 * data_.joints.size(),
          "two feature scales (sin, cos) per feature joint");
  for (int k = 0; k < j; ++k) {
    Require(data_.joints[k] >= 0 && data_.joints[k] < data_.num_joints,
            "feature joint out of range");
  }
  for (double a : data_.feature_scale) {
    Require(std::isfinite(a) && a > 0, "feature scales must be positive");
  }
  Require(std::isfinite(data_.length_scale) && data_.length_scale > 0, "length scale must be > 0");
  Require(std::isfinite(data_.regularisation) && data_.regularisation > 0,
          "regularisation must be > 0");
  Require(std::isfinite(data_.noise_sigma_mm) && data_.noise_sigma_mm >= 0,
          "noise sigma must be ≥ 0");
  Require(std::isfinite(data_.support_radius) && data_.support_radius >= 0,
          "support radius must be ≥ 0");
  const int m = static_cast<int>(data_.centres_rad.size());
  Require(m > 0, "no centres");
  Require(data_.weights_mm.size() == data_.centres_rad.size(), "one weight vector per centre");
  centre_features_.resize(m, 2 * j);
  weights_.resize(m, 3);
  for (int c = 0; c < m; ++c) {
    Require(data_.centres_rad[c].size() == data_.joints.size(),
            "every centre has one angle per feature joint");
    for (int k = 0; k < j; ++k)
      Require(std::isfinite(data_.centres_rad[c][k]), "centre angles must be finite");
    Eigen::VectorXd u(2 * j);
    Features(data_.centres_rad[c].data(), u.data());
    centre_features_.row(c) = u.transpose();
    for (int r = 0; r < 3; ++r) {
      Require(std::isfinite(data_.weights_mm[c][r]), "weights must be finite");
      weights_(c, r) = data_.weights_mm[c][r];
    }
  }
  centre_half_norm2_ = 0.5 * centre_features_.rowwise().squaredNorm();
  feature_mean_ = centre_features_.colwise().mean().transpose();
  const Eigen::MatrixXd centred = centre_features_.rowwise() - feature_mean_.transpose();
  centred_features_f_ = centred.cast<float>();
  centred_half_norm2_f_ = (0.5 * centred.rowwise().squaredNorm()).cast<float>();
  weights_f_ = weights_.cast<float>();
  // Every configuration within the support radius keeps its nearest centre.
  cutoff_half_d2_ = std::max(kNegligibleExponent * data_.length_scale * data_.length_scale,
                             0.51 * data_.support_radius * data_.support_radius);
}

// `angles`: one per feature joint (a centre's, or FeatureAngles of a joint vector).
void ResidualMap::Features(const double* angles, double* u) const {
  const int j = static_cast<int>(data_.joints.size());
  for (int k = 0; k < j; ++k) {
    const double a = angles[k];
    u[2 * k] = data_.feature_scale[2 * k] * std::sin(a);
    u[2 * k + 1] = data_.feature_scale[2 * k + 1] * std::cos(a);
  }
}

void ResidualMap::HalfDistances(const double* u, Eigen::Ref<Eigen::VectorXd> half_d2) const {
  const Eigen::Map<const Eigen::VectorXd> uu(u, centre_features_.cols());
  half_d2 = (0.5 * uu.squaredNorm() + centre_half_norm2_.array() - (centre_features_ * uu).array())
                .max(0.0)
                .matrix();
}

namespace {

// The feature joints' angles of a full joint vector.
std::vector<double> FeatureAngles(const ResidualMapData& data, const double* joints_rad) {
  std::vector<double> a(data.joints.size());
  for (size_t k = 0; k < a.size(); ++k) a[k] = joints_rad[data.joints[k]];
  return a;
}

}  // namespace

MapPrediction ResidualMap::Evaluate(
    const double* joints_rad,
    Eigen::Matrix<double, 3, Eigen::Dynamic>* d_correction_d_joints) const {
  const int j = static_cast<int>(data_.joints.size());
  const std::vector<double> angles = FeatureAngles(data_, joints_rad);
  Eigen::VectorXd u(2 * j), half_d2(centres());
  Features(angles.data(), u.data());
  HalfDistances(u.data(), half_d2);
  MapPrediction p;
  p.support_distance = std::sqrt(2.0 * half_d2.minCoeff());
  p.supported = p.support_distance <= data_.support_radius;
  if (d_correction_d_joints) d_correction_d_joints->setZero(3, data_.num_joints);
  if (!p.supported) return p;
  const double inv_l2 = 1.0 / (data_.length_scale * data_.length_scale);
  Eigen::Vector3d correction = Eigen::Vector3d::Zero();
  Eigen::Matrix<double, 3, Eigen::Dynamic> d = Eigen::Matrix<double, 3, Eigen::Dynamic>::Zero(3, j);
  // ∂(−|u − c|²/2)/∂θ = (c − u)·∂u/∂θ, ∂u/∂θ = (a cos θ, −b sin θ) in the joint's columns.
  Eigen::VectorXd du(2 * j);
  for (int f = 0; f < j; ++f) {
    du(2 * f) = data_.feature_scale[2 * f] * std::cos(angles[f]);
    du(2 * f + 1) = -data_.feature_scale[2 * f + 1] * std::sin(angles[f]);
  }
  for (int c = 0; c < centres(); ++c) {
    if (half_d2(c) > cutoff_half_d2_) continue;
    const double k = std::exp(-half_d2(c) * inv_l2);
    const Eigen::Vector3d wk = weights_.row(c).transpose() * k;
    correction += wk;
    if (d_correction_d_joints) {
      for (int f = 0; f < j; ++f) {
        const double ds = (centre_features_(c, 2 * f) - u(2 * f)) * du(2 * f) +
                          (centre_features_(c, 2 * f + 1) - u(2 * f + 1)) * du(2 * f + 1);
        d.col(f) += wk * (ds * inv_l2);
      }
    }
  }
  if (data_.output_frame == "joint1") {
    const Eigen::Matrix3d turn = TurnAboutZ(joints_rad[0]);
    if (d_correction_d_joints) {
      d = turn * d;
      Eigen::Matrix3d d_turn;  // ∂Rz(q)/∂q
      const double s = std::sin(joints_rad[0]), co = std::cos(joints_rad[0]);
      d_turn << -s, -co, 0, co, -s, 0, 0, 0, 0;
      d_correction_d_joints->col(0) += d_turn * correction;
    }
    correction = turn * correction;
  }
  if (d_correction_d_joints) {
    for (int f = 0; f < j; ++f) d_correction_d_joints->col(data_.joints[f]) += d.col(f);
  }
  p.correction_in_base_mm = correction;
  return p;
}

bool ResidualMap::CorrectJoints(const double* joints_rad, double* corrected_rad) const {
  return ApplyJointCurves(data_.curves, data_.num_joints, joints_rad, corrected_rad);
}

MapPrediction ResidualMap::Predict(const double* joints_rad) const {
  return Evaluate(joints_rad, nullptr);
}

MapPrediction ResidualMap::PredictWithJacobian(
    const double* joints_rad,
    Eigen::Ref<Eigen::Matrix<double, 3, Eigen::Dynamic>> d_correction_d_joints) const {
  Eigen::Matrix<double, 3, Eigen::Dynamic> d(3, data_.num_joints);
  const MapPrediction p = Evaluate(joints_rad, &d);
  d_correction_d_joints = d;
  return p;
}

void ResidualMap::PredictBatch(const Eigen::MatrixXd& joints_rad,
                               Eigen::Matrix3Xd& corrections_in_base_mm,
                               std::vector<char>& supported, int threads) const {
  Require(joints_rad.rows() == data_.num_joints, "batch rows must be the model's joints");
  const Eigen::Index b = joints_rad.cols();
  corrections_in_base_mm.setZero(3, b);
  supported.assign(b, 0);
  const int blocks = static_cast<int>((b + kBatchBlock - 1) / kBatchBlock);
  const int workers = std::max(1, std::min(threads, blocks));
  ParallelFor(workers, workers, [&](int w) {
    const Eigen::Index begin = static_cast<Eigen::Index>(blocks * w / workers) * kBatchBlock;
    const Eigen::Index end = std::min<Eigen::Index>(
        b, static_cast<Eigen::Index>(blocks * (w + 1) / workers) * kBatchBlock);
    PredictRange(joints_rad, begin, end, corrections_in_base_mm, supported);
  });
}

void ResidualMap::PredictRange(const Eigen::MatrixXd& joints_rad, Eigen::Index begin,
                               Eigen::Index end, Eigen::Matrix3Xd& corrections_in_base_mm,
                               std::vector<char>& supported) const {
  const FlushDenormals flush;
  const int j = static_cast<int>(data_.joints.size());
  const float inv_l2 = static_cast<float>(1.0 / (data_.length_scale * data_.length_scale));
  const float radius2 = static_cast<float>(data_.support_radius * data_.support_radius);
  Eigen::MatrixXd u(2 * j, kBatchBlock);
  Eigen::MatrixXf kernel;
  Eigen::ArrayXf column(centres());
  Eigen::Matrix3Xf block;
  Eigen::VectorXf nearest(kBatchBlock);
  std::vector<double> angles(j);
  for (Eigen::Index start = begin; start < end; start += kBatchBlock) {
    const Eigen::Index count = std::min<Eigen::Index>(kBatchBlock, end - start);
    for (Eigen::Index i = 0; i < count; ++i) {
      for (int k = 0; k < j; ++k) angles[k] = joints_rad(data_.joints[k], start + i);
      Features(angles.data(), u.col(i).data());
    }
    // Single precision on features centred on the centres' mean (small norms, so the
    // distances from |u|² + |c|² − 2u·c keep ~1e-6 of their size): matches Predict to
    // ~1e-6 of the correction.
    const Eigen::MatrixXf uf = (u.leftCols(count).colwise() - feature_mean_).cast<float>();
    kernel.noalias() = centred_features_f_ * uf;  // M × count: u·c
    for (Eigen::Index i = 0; i < count; ++i) {
      column =
          (centred_half_norm2_f_.array() + 0.5f * uf.col(i).squaredNorm() - kernel.col(i).array())
              .max(0.0f);  // |u − c|²/2
      nearest(i) = column.minCoeff();
      // Exponents capped at 80: e^−80 is still a normal float and weighs nothing.
      kernel.col(i) = (-(column * inv_l2).min(80.0f)).exp().matrix();
    }
    block.noalias() = weights_f_.transpose() * kernel;
    for (Eigen::Index i = 0; i < count; ++i) {
      const bool ok = 2.0f * nearest(i) <= radius2;
      supported[start + i] = ok;
      if (!ok) continue;
      Eigen::Vector3d correction = block.col(i).cast<double>();
      if (data_.output_frame == "joint1") {
        correction = TurnAboutZ(joints_rad(0, start + i)) * correction;
      }
      corrections_in_base_mm.col(start + i) = correction;
    }
  }
}

double ResidualMap::CorrectionSigmaMm(const double* joints_rad) const {
  const int j = static_cast<int>(data_.joints.size());
  const std::vector<double> angles = FeatureAngles(data_, joints_rad);
  Eigen::VectorXd u(2 * j), half_d2(centres());
  Features(angles.data(), u.data());
  HalfDistances(u.data(), half_d2);
  const int count = std::min(kVarianceNeighbours, centres());
  std::vector<int> order(centres());
  for (int c = 0; c < centres(); ++c) order[c] = c;
  std::partial_sort(order.begin(), order.begin() + count, order.end(),
                    [&](int a, int b) { return half_d2(a) < half_d2(b); });
  const double inv_l2 = 1.0 / (data_.length_scale * data_.length_scale);
  Eigen::MatrixXd k(count, count);
  Eigen::VectorXd kx(count);
  for (int a = 0; a < count; ++a) {
    kx(a) = std::exp(-half_d2(order[a]) * inv_l2);
    for (int b = 0; b <= a; ++b) {
      const double h =
          0.5 * (centre_features_.row(order[a]) - centre_features_.row(order[b])).squaredNorm();
      k(a, b) = k(b, a) = std::exp(-h * inv_l2);
    }
  }
  k.diagonal().array() += data_.regularisation;
  const double prior = data_.noise_sigma_mm * data_.noise_sigma_mm / data_.regularisation;
  const double reduction = kx.dot(k.llt().solve(kx));
  return std::sqrt(std::max(0.0, prior * (1.0 - reduction)));
}

std::vector<MappedPosition> PredictPositions(const RobotModel& model,
                                             const Eigen::Isometry3d& world_from_base,
                                             const Eigen::VectorXd& params, const ResidualMap* map,
                                             const std::vector<Eigen::VectorXd>& joints_rad,
                                             bool with_sigma, int threads) {
  const int count = static_cast<int>(joints_rad.size());
  std::vector<MappedPosition> out(count);
  const int workers = std::max(1, std::min(threads, count / 1024 + 1));
  std::vector<char> curves_inside(count, 1);
  ParallelFor(workers, workers, [&](int w) {
    Kinematics kin(model);
    Eigen::VectorXd corrected(model.num_joints());
    for (int i = count * w / workers; i < count * (w + 1) / workers; ++i) {
      out[i].parametric_mm = kin.Position(world_from_base, params, joints_rad[i].data());
      out[i].position_mm = out[i].parametric_mm;
      if (map && map->has_curves()) {
        curves_inside[i] = map->CorrectJoints(joints_rad[i].data(), corrected.data());
        out[i].position_mm = kin.Position(world_from_base, params, corrected.data());
      }
      out[i].sigma_mm = map && with_sigma ? map->CorrectionSigmaMm(joints_rad[i].data())
                                          : std::numeric_limits<double>::quiet_NaN();
    }
  });
  if (!map || joints_rad.empty()) return out;
  Eigen::MatrixXd q(model.num_joints(), count);
  for (int i = 0; i < count; ++i) q.col(i) = joints_rad[i];
  Eigen::Matrix3Xd corrections;
  std::vector<char> supported;
  map->PredictBatch(q, corrections, supported, threads);
  for (int i = 0; i < count; ++i) {
    out[i].map_applied = supported[i] && curves_inside[i];
    out[i].extrapolated = !out[i].map_applied;
    if (supported[i]) out[i].position_mm += world_from_base.linear() * corrections.col(i);
  }
  return out;
}

void ResidualMapOptions::Check() const {
  auto fail = [](const std::string& what) { throw std::invalid_argument("residual map: " + what); };
  if (folds < 2) fail("at least 2 folds");
  if (length_scales.empty() || regularisations.empty()) fail("empty hyperparameter grid");
  if (!std::is_sorted(length_scales.begin(), length_scales.end()) ||
      !std::is_sorted(regularisations.begin(), regularisations.end())) {
    fail("the grids must be ascending");
  }
  for (double l : length_scales) {
    if (!(l > 0)) fail("length scales must be > 0");
  }
  for (double r : regularisations) {
    if (!(r > 0)) fail("regularisations must be > 0");
  }
  if (max_training_poses < 2 * folds) fail("max_training_poses too small for the folds");
  if (!(required_gain >= 0 && required_gain < 1)) fail("required gain in [0, 1)");
  if (output_frame != "base" && output_frame != "joint1") fail("output frame 'base' or 'joint1'");
  if (!(support_quantile > 0 && support_quantile <= 1) || !(support_margin >= 1)) {
    fail("support quantile in (0, 1], margin ≥ 1");
  }
  if (threads < 1) fail("at least one thread");
  if (curve_knots != 0 && (curve_knots < 4 || curve_knots > 3600)) {
    fail("joint curves: 0 (none) or 4 to 3600 knots per turn");
  }
  if (curve_knots != 0 && curve_smoothing.empty()) fail("joint curves: empty smoothing grid");
  if (!std::is_sorted(curve_smoothing.begin(), curve_smoothing.end())) {
    fail("the grids must be ascending");
  }
  for (double r : curve_smoothing) {
    if (!(r > 0)) fail("joint curves: smoothing weights must be > 0");
  }
}

namespace {

// Farthest-point sampling in feature space: a deterministic cover of the fit poses,
// starting from the pose nearest the centroid. Ascending indices.
std::vector<int> FarthestPoints(const Eigen::MatrixXd& u, int count) {
  const int m = static_cast<int>(u.rows());
  std::vector<int> chosen;
  if (count >= m) {
    for (int i = 0; i < m; ++i) chosen.push_back(i);
    return chosen;
  }
  const Eigen::RowVectorXd centroid = u.colwise().mean();
  Eigen::Index first = 0;
  (u.rowwise() - centroid).rowwise().squaredNorm().minCoeff(&first);
  Eigen::VectorXd nearest = (u.rowwise() - u.row(first)).rowwise().squaredNorm();
  chosen.push_back(static_cast<int>(first));
  while (static_cast<int>(chosen.size()) < count) {
    Eigen::Index next = 0;
    nearest.maxCoeff(&next);
    chosen.push_back(static_cast<int>(next));
    nearest = nearest.cwiseMin((u.rowwise() - u.row(next)).rowwise().squaredNorm());
  }
  std::sort(chosen.begin(), chosen.end());
  return chosen;
}

double Quantile(std::vector<double> v, double q) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  const double pos = q * static_cast<double>(v.size() - 1);
  const size_t lo = static_cast<size_t>(std::floor(pos));
  const size_t hi = std::min(lo + 1, v.size() - 1);
  return v[lo] + (pos - static_cast<double>(lo)) * (v[hi] - v[lo]);
}

}  // namespace

namespace detail {

ResidualMapFit MapFitter::Run() {
  if (!HasFitToLearnFrom()) return std::move(result_);
  LineariseParametricFit();
  if (!ChooseFeatures()) return std::move(result_);
  CrossValidateParametricModel();
  FitCurves();
  SetSupportRadius();
  if (!SearchGrid()) return std::move(result_);
  FitMap();
  TransferCheck();
  Decide();
  return std::move(result_);
}

// A map learns what a converged parametric fit of these very poses leaves, and needs
// enough of them for the folds.
bool MapFitter::HasFitToLearnFrom() {
  if (!fit_.status.ok() || static_cast<int>(fit_.fit_residuals.size()) != m_) {
    result_.decision = "no parametric fit on these poses to learn from";
    return false;
  }
  if (m_ < 4 * options_.folds) {
    result_.decision =
        "too few poses for " + std::to_string(options_.folds) + "-fold cross-validation";
    return false;
  }
  return true;
}

// The parametric model and its linearised K-fold refits (one Gauss–Newton step each), with
// the orientation equations the fit had (each frame's tool rotation refitted too).
void MapFitter::LineariseParametricFit() {
  cv_.emplace(CrossValidationAtFit(model_, fit_, poses_, fit_.identifiability.identified, {},
                                   AssignFolds(m_, folds_, options_.seed), folds_));
}

// Features of every fit pose (sin and cos of each joint that moves the target), scaled;
// the poses that train the map, a farthest-point cover of them.
bool MapFitter::ChooseFeatures() {
  ResidualMapData& data = map();
  data.output_frame = options_.output_frame;
  data.num_joints = model_.num_joints();
  data.joints = JointsThatMoveTheTarget(model_, poses_);
  if (data.joints.empty()) {
    result_.decision = "no joint moves the target";
    return false;
  }
  const int jf = static_cast<int>(data.joints.size());
  Eigen::MatrixXd u_all(m_, 2 * jf);
  for (int i = 0; i < m_; ++i) {
    for (int k = 0; k < jf; ++k) {
      const double a = poses_[i].joints_rad(data.joints[k]);
      u_all(i, 2 * k) = std::sin(a);
      u_all(i, 2 * k + 1) = std::cos(a);
    }
  }
  data.feature_scale.assign(2 * jf, 1.0);
  if (options_.scaling == FeatureScaling::kStandardised) {
    // Spread floor 0.05 (a joint that hardly moved, ~3°): moving it later is far from the
    // data, not nothing.
    const Eigen::RowVectorXd mean = u_all.colwise().mean();
    for (int f = 0; f < 2 * jf; ++f) {
      const double spread = std::sqrt((u_all.col(f).array() - mean(f)).square().mean());
      data.feature_scale[f] = 1.0 / std::max(spread, 0.05);
    }
  }
  for (int f = 0; f < 2 * jf; ++f) u_all.col(f) *= data.feature_scale[f];
  train_ = FarthestPoints(u_all, options_.max_training_poses);
  mt_ = static_cast<int>(train_.size());
  u_.resize(mt_, 2 * jf);
  for (int t = 0; t < mt_; ++t) u_.row(t) = u_all.row(train_[t]);
  return true;
}

// Everything in the map's output frame: residuals (model − measured) turned by Qᵀ, Q the
// map frame in the measuring frame (distances do not change). Per fold, the training
// poses' residuals under the parametric refit without that fold; their held-out mean is
// the figure the map must beat.
void MapFitter::CrossValidateParametricModel() {
  frame_.resize(mt_);
  for (int t = 0; t < mt_; ++t) {
    frame_[t] = fit_.base_of(poses_[train_[t]].frame).linear();
    if (options_.output_frame == "joint1") {
      frame_[t] = frame_[t] * TurnAboutZ(poses_[train_[t]].joints_rad(0));
    }
  }
  fold_of_.resize(mt_);
  for (int t = 0; t < mt_; ++t) fold_of_[t] = cv_->fold_of_pose()[train_[t]];
  std::vector<int> all(cv_->jacobian().cols());
  for (size_t c = 0; c < all.size(); ++c) all[c] = static_cast<int>(c);
  refit_.resize(folds_);
  double parametric_sum = 0.0;
  for (int f = 0; f < folds_; ++f) {
    const Eigen::VectorXd r = cv_->RefitWithout(f, all);
    refit_[f].resize(mt_, 3);
    for (int t = 0; t < mt_; ++t) {
      refit_[f].row(t) = (frame_[t].transpose() * r.segment<3>(3 * train_[t])).transpose();
      if (fold_of_[t] == f) parametric_sum += refit_[f].row(t).norm();
    }
  }
  result_.cv_mean_mm_parametric = parametric_sum / mt_;
  fold_rows_.resize(folds_);
  train_rows_.resize(folds_);
  for (int t = 0; t < mt_; ++t) {
    for (int f = 0; f < folds_; ++f) {
      (fold_of_[t] == f ? fold_rows_ : train_rows_)[f].push_back(t);
    }
  }
}

// Half squared distances between the training poses, and the support radius from their
// leave-one-out nearest neighbours.
void MapFitter::SetSupportRadius() {
  half_d2_ = -u_ * u_.transpose();
  half_d2_.colwise() += 0.5 * u_.rowwise().squaredNorm();
  half_d2_.rowwise() += 0.5 * u_.rowwise().squaredNorm().transpose();
  half_d2_ = half_d2_.cwiseMax(0.0);
  std::vector<double> loo(mt_);
  for (int t = 0; t < mt_; ++t) {
    double best = std::numeric_limits<double>::infinity();
    for (int c = 0; c < mt_; ++c) {
      if (c != t) best = std::min(best, half_d2_(t, c));
    }
    loo[t] = std::sqrt(2.0 * best);
  }
  map().support_radius = options_.support_margin * Quantile(loo, options_.support_quantile);
}

// The kernel matrix of the training poses for the li-th length scale, single precision;
// the three most recently used are kept.
const Eigen::MatrixXf& MapFitter::Kernel(int li) {
  if (auto it = kernels_.find(li); it != kernels_.end()) return it->second;
  if (kernels_.size() >= 3) kernels_.erase(kernels_.begin());
  const double l = options_.length_scales[li];
  // Entries below e^−60 are zero: in single precision they would be denormal numbers,
  // which slow the factorisation a hundredfold and weigh nothing.
  return kernels_[li] = (half_d2_.array() / (l * l) > 60.0)
                            .select(0.0, (-half_d2_.array() / (l * l)).exp())
                            .matrix()
                            .cast<float>();
}

// Cross-validation of one (ℓ, λ): per fold, kernel ridge on the other folds (single
// precision: K + λI with λ ≥ 0.01 is well conditioned, and the figures compared differ in
// the third digit), predicting the fold.
MapFitter::Score MapFitter::CrossValidate(int li, int ri, std::vector<double>* distances) {
  options_.stop.ThrowIfRequested();
  if (distances) distances->assign(mt_, 0.0);
  const Eigen::MatrixXf& k = Kernel(li);
  const float lambda = static_cast<float>(options_.regularisations[ri]);
  std::vector<double> sum(folds_, 0.0), sum_sq(folds_, 0.0);
  std::vector<char> failed(folds_, 0);
  const int workers = std::max(1, std::min(options_.threads, folds_));
  if (static_cast<int>(fold_buffers_.size()) != workers) {
    size_t most_train = 0, most_test = 0;
    for (int f = 0; f < folds_; ++f) {
      most_train = std::max(most_train, train_rows_[f].size());
      most_test = std::max(most_test, fold_rows_[f].size());
    }
    fold_buffers_.resize(workers);
    for (auto& b : fold_buffers_) {
      b.a.resize(most_train, most_train);
      b.kft.resize(most_test, most_train);
    }
  }
  ParallelForWorkers(folds_, workers, [&](int f, int worker) {
    const FlushDenormals flush;
    const std::vector<int>& tr = train_rows_[f];
    const std::vector<int>& te = fold_rows_[f];
    const Eigen::Index n = static_cast<Eigen::Index>(tr.size());
    Eigen::Ref<Eigen::MatrixXf> a = fold_buffers_[worker].a.topLeftCorner(n, n);
    auto kft = fold_buffers_[worker].kft.topLeftCorner(static_cast<Eigen::Index>(te.size()), n);
    Eigen::MatrixXf y(tr.size(), 3);
    for (size_t c = 0; c < tr.size(); ++c) {
      for (size_t r = 0; r < tr.size(); ++r) a(r, c) = k(tr[r], tr[c]);
      for (size_t r = 0; r < te.size(); ++r) kft(r, c) = k(te[r], tr[c]);
      y.row(c) = (-refit_[f].row(tr[c])).cast<float>();
    }
    a.diagonal().array() += lambda;
    const Eigen::LLT<Eigen::Ref<Eigen::MatrixXf>> llt(a);  // in place: a holds the factor
    if (llt.info() != Eigen::Success) {
      failed[f] = 1;
      return;
    }
    const Eigen::MatrixXf predicted = kft * llt.solve(y);
    for (size_t r = 0; r < te.size(); ++r) {
      const Eigen::RowVector3d e = refit_[f].row(te[r]) + predicted.row(r).cast<double>();
      if (distances) (*distances)[te[r]] = e.norm();
      sum[f] += e.norm();
      sum_sq[f] += e.squaredNorm();
    }
  });
  Score s;
  if (std::count(failed.begin(), failed.end(), 1) > 0) return s;
  s.mean = 0.0;
  for (int f = 0; f < folds_; ++f) {
    s.mean += sum[f] / mt_;
    s.sum_sq += sum_sq[f];
  }
  return s;
}

// CrossValidate once per grid point, each recorded in the result's grid in the order met.
MapFitter::Score MapFitter::ScoreOf(int li, int ri) {
  const auto key = std::make_pair(li, ri);
  if (auto it = scored_.find(key); it != scored_.end()) return it->second;
  const Score s = CrossValidate(li, ri);
  result_.grid.push_back({options_.length_scales[li], options_.regularisations[ri], s.mean});
  return scored_[key] = s;
}

// Walks the (ℓ, λ) grid from its middle to the best neighbour until none is better, and
// keeps that point. False when no kernel matrix could be factorised.
bool MapFitter::SearchGrid() {
  const int nl = static_cast<int>(options_.length_scales.size());
  const int nr = static_cast<int>(options_.regularisations.size());
  int li = nl / 2, ri = nr / 2;
  Score best = ScoreOf(li, ri);
  for (;;) {
    int next_l = li, next_r = ri;
    static constexpr std::pair<int, int> kSteps[] = {{-1, 0}, {1, 0}, {0, -1}, {0, 1}};
    for (const auto& [dl, dr] : kSteps) {
      const int l = li + dl, r = ri + dr;
      if (l < 0 || l >= nl || r < 0 || r >= nr) continue;
      const Score s = ScoreOf(l, r);
      if (s.mean < best.mean) {
        best = s;
        next_l = l;
        next_r = r;
      }
    }
    if (next_l == li && next_r == ri) break;
    li = next_l;
    ri = next_r;
  }
  if (!std::isfinite(best.mean)) {
    result_.decision = "the map's cross-validation failed (kernel matrices not positive definite)";
    return false;
  }
  map().length_scale = options_.length_scales[li];
  map().regularisation = options_.regularisations[ri];
  result_.cv_mean_mm_with_map = best.mean;
  CrossValidate(li, ri, &result_.cv_distances_mm);
  kernels_.clear();
  fold_buffers_.clear();
  result_.cv_poses = train_;
  return true;
}

// The map on all training poses with the chosen hyperparameters (double precision): its
// centres, weights and noise σ.
void MapFitter::FitMap() {
  ResidualMapData& data = map();
  const FlushDenormals flush;
  Eigen::MatrixXd k = (-half_d2_.array() / (data.length_scale * data.length_scale)).exp().matrix();
  k.diagonal().array() += data.regularisation;
  Eigen::MatrixXd y(mt_, 3);
  for (int t = 0; t < mt_; ++t) {
    y.row(t) = -(frame_[t].transpose() * fit_.fit_residuals[train_[t]]).transpose();
  }
  data.version = data.curves.empty() ? 1 : ResidualMapData::kVersion;  // as before, without
  if (!data.curves.empty()) {
    // The curves on every training pose; the kernel learns what they leave.
    const int p = curve_joints_ * knots_;
    Eigen::MatrixXd normal = Eigen::MatrixXd::Zero(p, p);
    Eigen::VectorXd rhs = Eigen::VectorXd::Zero(p);
    for (int t = 0; t < mt_; ++t) AddCurveRows(t, y.row(t).transpose(), &normal, rhs);
    SizeCurveBuffers(1);
    const Eigen::VectorXd x = SolveCurves(normal, rhs, data.curves.smoothing, measured_, curve_buffers_[0].system);
    for (int t = 0; t < mt_; ++t) y.row(t) -= CurveCorrection(t, x).transpose();
    data.curves.values_rad.assign(curve_joints_, std::vector<double>(knots_));
    data.curves.measured.assign(curve_joints_, std::vector<int>(knots_));
    for (int k = 0; k < curve_joints_; ++k) {
      for (int m = 0; m < knots_; ++m) {
        data.curves.values_rad[k][m] = x(k * knots_ + m);
        data.curves.measured[k][m] = measured_[k * knots_ + m];
      }
    }
  }
  const Eigen::MatrixXd w = k.llt().solve(y);
  data.centres_rad.resize(mt_);
  data.weights_mm.resize(mt_);
  for (int t = 0; t < mt_; ++t) {
    for (int j : data.joints) data.centres_rad[t].push_back(poses_[train_[t]].joints_rad(j));
    data.weights_mm[t] = {w(t, 0), w(t, 1), w(t, 2)};
  }
  // GP reading: with the kernel's shape (ℓ) and the noise-to-signal ratio (λ) fixed by the
  // cross-validation, the maximum-likelihood prior amplitude is s² = tr(Yᵀ (K + λI)⁻¹ Y) / 3n
  // and the noise σ² = λ s² (Rasmussen & Williams 2006, §5.4.1 with the scale profiled out).
  const double s2 = std::max(0.0, (y.array() * w.array()).sum() / (3.0 * mt_));
  data.noise_sigma_mm = std::sqrt(data.regularisation * s2);
}

// The transfer check: the parametric model refitted without each held-out session or
// joint-space region (one Gauss–Newton step), the curves (at the chosen smoothing, measured
// knots from the other regions only) and the kernel (at the chosen ℓ, λ, with its support
// cut) trained on the other regions' residuals, each region predicted.
void MapFitter::TransferCheck() {
  if (!options_.transfer_check) return;
  options_.stop.ThrowIfRequested();
  const TransferFolds folds = AssignTransferFolds(model_, poses_, options_.folds, options_.seed);
  if (folds.folds < 2) return;
  const int nf = folds.folds;
  const LinearisedCrossValidation cv =
      CrossValidationAtFit(model_, fit_, poses_, fit_.identifiability.identified, {},
                           folds.fold_of_pose, nf);
  std::vector<int> all(cv.jacobian().cols());
  for (size_t c = 0; c < all.size(); ++c) all[c] = static_cast<int>(c);
  std::vector<std::vector<int>> held(nf), kept(nf);
  for (int t = 0; t < mt_; ++t) {
    const int f = folds.fold_of_pose[train_[t]];
    for (int g = 0; g < nf; ++g) (g == f ? held : kept)[g].push_back(t);
  }
  const bool curves = !map().curves.empty();
  const int p = curve_joints_ * knots_;
  const double l2 = map().length_scale * map().length_scale;
  const float lambda = static_cast<float>(map().regularisation);
  const double support_half_d2 = 0.5 * map().support_radius * map().support_radius;
  const double spacing = 2.0 * std::acos(-1.0) / std::max(knots_, 1);
  const int reach = static_cast<int>(std::floor(kCurveReachRad / spacing));
  std::vector<double> sum_p(nf, 0.0), sum_c(nf, 0.0), sum_m(nf, 0.0), distances(mt_, 0.0);
  const int workers = std::max(1, std::min(options_.threads, nf));
  if (curves) SizeCurveBuffers(workers);
  size_t most_kept = 0, most_held = 0;
  for (int f = 0; f < nf; ++f) {
    most_kept = std::max(most_kept, kept[f].size());
    most_held = std::max(most_held, held[f].size());
  }
  fold_buffers_.resize(workers);
  for (auto& b : fold_buffers_) {
    b.a.resize(most_kept, most_kept);
    b.kft.resize(most_held, most_kept);
  }
  ParallelForWorkers(nf, workers, [&](int f, int worker) {
    const FlushDenormals flush;
    const Eigen::VectorXd r = cv.RefitWithout(f, all);
    Eigen::MatrixXd y(mt_, 3);  // model − measured, map frame
    for (int t = 0; t < mt_; ++t) y.row(t) = (frame_[t].transpose() * r.segment<3>(3 * train_[t])).transpose();
    for (int t : held[f]) sum_p[f] += y.row(t).norm();
    if (curves) {
      std::vector<int> measured(p, 0);
      for (int t : kept[f]) {
        for (int k = 0; k < curve_joints_; ++k) {
          const int nearest = span_[t * curve_joints_ + k].nearest;
          for (int d = -reach; d <= reach; ++d)
            measured[k * knots_ + ((nearest + d) % knots_ + knots_) % knots_] = 1;
        }
      }
      Eigen::MatrixXd& normal = curve_buffers_[worker].normal;
      normal.setZero();
      Eigen::VectorXd rhs = Eigen::VectorXd::Zero(p);
      for (int t : kept[f]) AddCurveRows(t, -y.row(t).transpose(), &normal, rhs);
      const Eigen::VectorXd x =
          SolveCurves(normal, rhs, map().curves.smoothing, measured, curve_buffers_[worker].system);
      for (int t = 0; t < mt_; ++t) y.row(t) += CurveCorrection(t, x).transpose();
    }
    for (int t : held[f]) sum_c[f] += y.row(t).norm();
    const auto& tr = kept[f];
    const auto& te = held[f];
    const Eigen::Index n = static_cast<Eigen::Index>(tr.size());
    Eigen::Ref<Eigen::MatrixXf> a = fold_buffers_[worker].a.topLeftCorner(n, n);
    auto kft = fold_buffers_[worker].kft.topLeftCorner(static_cast<Eigen::Index>(te.size()), n);
    Eigen::MatrixXf target(tr.size(), 3);
    std::vector<char> supported(te.size(), 0);
    for (size_t c = 0; c < tr.size(); ++c) {
      for (size_t q = 0; q < tr.size(); ++q) {
        const double h = half_d2_(tr[q], tr[c]) / l2;
        a(q, c) = h > 60.0 ? 0.0f : static_cast<float>(std::exp(-h));
      }
      for (size_t q = 0; q < te.size(); ++q) {
        const double h2 = half_d2_(te[q], tr[c]);
        if (h2 <= support_half_d2) supported[q] = 1;
        kft(q, c) = h2 / l2 > 60.0 ? 0.0f : static_cast<float>(std::exp(-h2 / l2));
      }
      target.row(c) = (-y.row(tr[c])).cast<float>();
    }
    a.diagonal().array() += lambda;
    const Eigen::LLT<Eigen::Ref<Eigen::MatrixXf>> llt(a);  // in place: a holds the factor
    const Eigen::MatrixXf predicted =
        llt.info() == Eigen::Success ? Eigen::MatrixXf(kft * llt.solve(target))
                                     : Eigen::MatrixXf::Zero(te.size(), 3);
    for (size_t q = 0; q < te.size(); ++q) {
      Eigen::RowVector3d e = y.row(te[q]);
      if (supported[q]) e += predicted.row(q).cast<double>();
      sum_m[f] += e.norm();
      distances[te[q]] = e.norm();
    }
  });
  double mp = 0.0, mc = 0.0, mm = 0.0;
  for (int f = 0; f < nf; ++f) mp += sum_p[f], mc += sum_c[f], mm += sum_m[f];
  result_.transfer_folds = folds.Describe();
  result_.transfer_mean_mm_parametric = mp / mt_;
  result_.transfer_mean_mm_curves = curves ? mc / mt_ : std::numeric_limits<double>::quiet_NaN();
  result_.transfer_mean_mm_with_map = mm / mt_;
  result_.transfer_distances_mm = std::move(distances);
  fold_buffers_.clear();
}

// The map is used when its cross-validated error beats the parametric model's by the
// required gain; the decision says in plain words the comparison that decided (the caller
// says "used" or "not used").
void MapFitter::Decide() {
  result_.used =
      result_.cv_mean_mm_with_map <= (1.0 - options_.required_gain) * result_.cv_mean_mm_parametric;
  const double change = 100.0 * (result_.cv_mean_mm_with_map / result_.cv_mean_mm_parametric - 1.0);
  char verdict[96];
  if (result_.used) {
    std::snprintf(verdict, sizeof verdict, "%.1f %% better (the map is used from %.0f %% on)",
                  -change, 100.0 * options_.required_gain);
  } else if (change < 0.0) {
    std::snprintf(verdict, sizeof verdict, "only %.1f %% better, less than the %.0f %% needed",
                  -change, 100.0 * options_.required_gain);
  } else {
    std::snprintf(verdict, sizeof verdict, "%.1f %% worse with the map", change);
  }
  char curves[96] = "";
  if (std::isfinite(result_.cv_mean_mm_curves)) {
    std::snprintf(curves, sizeof curves, " (joint curves alone: %.4f mm%s)",
                  result_.cv_mean_mm_curves, map().curves.empty() ? ", not used" : "");
  }
  char text[384];
  std::snprintf(text, sizeof text,
                "%d-fold cross-validation on %d fit poses: %.4f mm with the map, %.4f mm "
                "without it: %s%s",
                folds_, mt_, result_.cv_mean_mm_with_map, result_.cv_mean_mm_parametric, verdict,
                curves);
  result_.decision = text;
}

}  // namespace detail

ResidualMapFit FitResidualMap(const RobotModel& model, const EstimationResult& fit,
                              const std::vector<MeasuredPose>& poses,
                              const ResidualMapOptions& options) {
  options.Check();
  return detail::MapFitter(model, fit, poses, options).Run();
}

}  // namespace armsig::calibration
