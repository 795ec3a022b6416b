#include "calibration/transfer_folds.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <random>
#include <stdexcept>

#include "calibration/cross_validation.h"

namespace armsig::calibration {

std::string TransferFolds::Describe() const {
  return std::to_string(folds) +
         (kind == Kind::kSessions ? " sessions held out in turn"
                                  : " joint-space blocks held out in turn");
}

std::vector<int> JointsThatMoveTheTarget(const RobotModel& model,
                                         const std::vector<MeasuredPose>& poses) {
  RobotModel bare = model;
  bare.nongeometric.clear();
  Kinematics kin(bare);
  const Eigen::VectorXd zero = Eigen::VectorXd::Zero(bare.num_parameters());
  Eigen::VectorXd lever = Eigen::VectorXd::Zero(model.num_joints());
  for (const auto& p : poses) {
    kin.Position(Eigen::Isometry3d::Identity(), zero, p.joints_rad.data());
    lever += kin.JointJacobian().colwise().squaredNorm().transpose();
  }
  lever = (lever / static_cast<double>(std::max<size_t>(poses.size(), 1))).cwiseSqrt();
  std::vector<int> joints;
  for (int i = 0; i < model.num_joints(); ++i) {
    if (lever(i) > 1e-3) joints.push_back(i);  // mm per rad
  }
  return joints;
}

namespace {

// A uniform draw in [0, 1) from mt19937's raw output (its sequence is fixed by the
// standard; the standard distributions are not).
double Uniform(std::mt19937& rng) { return static_cast<double>(rng()) / 4294967296.0; }

// k-means++: the first centre a seeded pick, each next one drawn with probability
// proportional to the squared distance to the nearest centre chosen.
Eigen::MatrixXd SeedCentres(const Eigen::MatrixXd& x, int k, std::mt19937& rng) {
  const Eigen::Index m = x.rows();
  Eigen::MatrixXd centres(k, x.cols());
  centres.row(0) = x.row(static_cast<Eigen::Index>(rng() % static_cast<unsigned>(m)));
  Eigen::VectorXd d2 = (x.rowwise() - centres.row(0)).rowwise().squaredNorm();
  for (int c = 1; c < k; ++c) {
    const double total = d2.sum();
    Eigen::Index pick = 0;
    if (total > 0.0) {
      double target = Uniform(rng) * total;
      for (pick = 0; pick < m - 1; ++pick) {
        target -= d2(pick);
        if (target < 0.0) break;
      }
    }
    centres.row(c) = x.row(pick);
    d2 = d2.cwiseMin((x.rowwise() - centres.row(c)).rowwise().squaredNorm());
  }
  return centres;
}

std::vector<int> Nearest(const Eigen::MatrixXd& x, const Eigen::MatrixXd& centres) {
  std::vector<int> label(x.rows());
  for (Eigen::Index i = 0; i < x.rows(); ++i) {
    (centres.rowwise() - x.row(i)).rowwise().squaredNorm().minCoeff(&label[i]);
  }
  return label;
}

}  // namespace

std::vector<int> JointSpaceBlocks(const Eigen::MatrixXd& features, int folds, unsigned seed,
                                  int* clusters) {
  const Eigen::Index m = features.rows();
  if (folds < 2 || m < 2 * folds) {
    throw std::invalid_argument("joint-space blocks need at least 2 blocks and two poses each (" +
                                std::to_string(m) + " poses, " + std::to_string(folds) +
                                " blocks)");
  }
  std::mt19937 rng(seed);
  Eigen::MatrixXd centres = SeedCentres(features, folds, rng);
  std::vector<int> label = Nearest(features, centres);
  for (int iteration = 0; iteration < 100; ++iteration) {
    Eigen::MatrixXd sum = Eigen::MatrixXd::Zero(folds, features.cols());
    Eigen::VectorXd count = Eigen::VectorXd::Zero(folds);
    for (Eigen::Index i = 0; i < m; ++i) {
      sum.row(label[i]) += features.row(i);
      count(label[i]) += 1.0;
    }
    for (int c = 0; c < folds; ++c) {
      if (count(c) > 0.0) centres.row(c) = sum.row(c) / count(c);
    }
    std::vector<int> next = Nearest(features, centres);
    if (next == label) break;
    label = std::move(next);
  }
  // A block of fewer than two poses cannot be a fold of its own: into its nearest neighbour.
  std::vector<int> count(folds, 0);
  for (int l : label) ++count[l];
  for (int c = 0; c < folds; ++c) {
    if (count[c] >= 2 || count[c] == 0) continue;
    double best = std::numeric_limits<double>::infinity();
    int into = -1;
    for (int o = 0; o < folds; ++o) {
      if (o == c || count[o] < 2) continue;
      const double d = (centres.row(o) - centres.row(c)).squaredNorm();
      if (d < best) best = d, into = o;
    }
    for (int& l : label) {
      if (l == c) l = into;
    }
    count[into] += count[c];
    count[c] = 0;
  }
  std::map<int, int> renumber;
  for (int& l : label) {
    const auto [it, inserted] = renumber.emplace(l, static_cast<int>(renumber.size()));
    l = it->second;
  }
  if (clusters) *clusters = static_cast<int>(renumber.size());
  return label;
}

TransferFolds AssignTransferFolds(const RobotModel& model, const std::vector<MeasuredPose>& poses,
                                  int folds, unsigned seed) {
  const int m = static_cast<int>(poses.size());
  if (folds < 2 || m < 2 * folds) {
    throw std::invalid_argument("transfer folds need at least 2 folds and two poses per fold (" +
                                std::to_string(m) + " poses, " + std::to_string(folds) +
                                " folds)");
  }
  TransferFolds out;
  out.fold_of_pose.assign(m, 0);
  // Sessions with a good share of the poses, largest first; at most `folds` of them.
  std::map<int64_t, int> per_frame;
  for (const auto& p : poses) ++per_frame[p.frame];
  std::vector<std::pair<int, int64_t>> large;
  for (const auto& [frame, count] : per_frame) {
    if (count >= kMinSessionShare * m) large.push_back({count, frame});
  }
  std::sort(large.rbegin(), large.rend());
  if (large.size() >= 2) {
    out.kind = TransferFolds::Kind::kSessions;
    out.folds = std::min<int>(folds, static_cast<int>(large.size()));
    std::map<int64_t, int> fold_of_frame;
    for (int f = 0; f < static_cast<int>(large.size()); ++f) {
      fold_of_frame[large[f].second] = f % out.folds;
    }
    // The small sessions' poses dealt over the folds (each fold keeps its own frame's base).
    const std::vector<int> dealt = AssignFolds(m, out.folds, seed);
    for (int i = 0; i < m; ++i) {
      const auto it = fold_of_frame.find(poses[i].frame);
      out.fold_of_pose[i] = it != fold_of_frame.end() ? it->second : dealt[i];
    }
    return out;
  }
  const std::vector<int> joints = JointsThatMoveTheTarget(model, poses);
  const int jf = static_cast<int>(joints.size());
  Eigen::MatrixXd u(m, 2 * std::max(jf, 1));
  u.setZero();
  for (int i = 0; i < m; ++i) {
    for (int k = 0; k < jf; ++k) {
      u(i, 2 * k) = std::sin(poses[i].joints_rad(joints[k]));
      u(i, 2 * k + 1) = std::cos(poses[i].joints_rad(joints[k]));
    }
  }
  // Standardised like the residual map's features (spread floor 0.05, ~3°): a joint that
  // hardly moved does not decide the blocks, one that moved a lot does not drown the rest.
  const Eigen::RowVectorXd mean = u.colwise().mean();
  for (Eigen::Index f = 0; f < u.cols(); ++f) {
    const double spread = std::sqrt((u.col(f).array() - mean(f)).square().mean());
    u.col(f) = (u.col(f).array() - mean(f)) / std::max(spread, 0.05);
  }
  out.kind = TransferFolds::Kind::kJointBlocks;
  out.fold_of_pose = JointSpaceBlocks(u, folds, seed, &out.folds);
  return out;
}

}  // namespace armsig::calibration
