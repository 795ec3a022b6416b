#include "calibration/estimation.h"

#include "core/text.h"

#include <Eigen/Cholesky>
#include <Eigen/Geometry>
#include <Eigen/SVD>
#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <set>
#include <sstream>
#include <stdexcept>

#include "calibration/compensation.h"
#include "calibration/cross_validation.h"
#include "calibration/orientation.h"
#include "calibration/statistics.h"
#include "calibration/terms.h"
#include "calibration/transfer_folds.h"

namespace armsig::calibration {

ErrorStats Summarise(const std::vector<double>& distances_mm) {
  ErrorStats s;
  s.poses = static_cast<int>(distances_mm.size());
  if (distances_mm.empty()) return s;
  double sum = 0.0, sum_sq = 0.0;
  for (double d : distances_mm) {
    sum += d;
    sum_sq += d * d;
    s.max_mm = std::max(s.max_mm, d);
  }
  s.mean_mm = sum / s.poses;
  s.rms_mm = std::sqrt(sum_sq / s.poses);
  return s;
}

AngleStats SummariseAngles(const std::vector<double>& angles_rad) {
  const ErrorStats s = Summarise(angles_rad);
  return {s.poses, s.mean_mm, s.max_mm, s.rms_mm};
}

std::optional<Eigen::Isometry3d> AlignBase(const RobotModel& model,
                                           const std::vector<MeasuredPose>& poses) {
  return AlignBaseWithParams(model, Eigen::VectorXd::Zero(model.num_parameters()), poses);
}

std::vector<Eigen::Vector3d> Residuals(const RobotModel& model,
                                       const Eigen::Isometry3d& world_from_base,
                                       const Eigen::VectorXd& params,
                                       const std::vector<MeasuredPose>& poses) {
  // One base for every pose, whatever frame it names.
  FrameBases one;
  for (int64_t frame : FramesOf(poses)) one.emplace(frame, world_from_base);
  return Residuals(model, one, params, poses);
}

std::vector<double> Distances(const std::vector<Eigen::Vector3d>& residuals) {
  std::vector<double> d;
  d.reserve(residuals.size());
  for (const auto& r : residuals) d.push_back(r.norm());
  return d;
}

namespace {
// Joint motion (rad, over all joints) below which a set of poses is one configuration.
constexpr double kNoMotionRad = 1e-9;
// Re-estimations of the orientation weight (variance components) at most; it settles to
// 0.1 % in three or four on the UR10.
constexpr int kMaxWeightRounds = 10;
}  // namespace

std::vector<int64_t> FramesOf(const std::vector<MeasuredPose>& poses) {
  std::set<int64_t> frames;
  for (const auto& p : poses) frames.insert(p.frame);
  return {frames.begin(), frames.end()};
}

std::vector<Eigen::Vector3d> Residuals(const RobotModel& model, const FrameBases& bases,
                                       const Eigen::VectorXd& params,
                                       const std::vector<MeasuredPose>& poses) {
  Kinematics kin(model);
  std::vector<Eigen::Vector3d> out;
  out.reserve(poses.size());
  for (const auto& pose : poses) {
    const auto base = bases.find(pose.frame);
    if (base == bases.end()) {
      throw std::invalid_argument("Residuals: no base for measurement frame " +
                                  std::to_string(pose.frame) + " (pose " + pose.id + ")");
    }
    out.push_back(kin.Position(base->second, params, pose.joints_rad.data()) -
                  pose.target_in_world);
  }
  return out;
}

std::vector<std::optional<Eigen::Vector3d>> OrientationResiduals(
    const RobotModel& model, const FrameBases& bases, const ToolRotations& tools,
    const Eigen::VectorXd& params, const std::vector<MeasuredPose>& poses) {
  Kinematics kin(model);
  std::vector<std::optional<Eigen::Vector3d>> out(poses.size());
  for (size_t i = 0; i < poses.size(); ++i) {
    const MeasuredPose& pose = poses[i];
    const auto tool = tools.find(pose.frame);
    if (!pose.orientation || tool == tools.end()) continue;
    const auto base = bases.find(pose.frame);
    if (base == bases.end()) {
      throw std::invalid_argument("OrientationResiduals: no base for measurement frame " +
                                  std::to_string(pose.frame) + " (pose " + pose.id + ")");
    }
    kin.Position(base->second, params, pose.joints_rad.data());
    out[i] = OrientationResidual(pose.orientation->world_from_target,
                                 kin.LastRotation() * tool->second);
  }
  return out;
}

std::vector<double> Angles(const std::vector<std::optional<Eigen::Vector3d>>& residuals) {
  std::vector<double> out;
  for (const auto& r : residuals) {
    if (r) out.push_back(r->norm());
  }
  return out;
}

FrameBases AlignFrameBases(const RobotModel& model, const Eigen::VectorXd& params,
                           const std::vector<MeasuredPose>& poses) {
  std::map<int64_t, std::vector<MeasuredPose>> by_frame;
  for (const auto& p : poses) by_frame[p.frame].push_back(p);
  FrameBases bases;
  for (const auto& [frame, frame_poses] : by_frame) {
    if (const auto base = AlignBaseWithParams(model, params, frame_poses)) bases[frame] = *base;
  }
  return bases;
}

void EstimationOptions::Check() const {
  identifiability.Check();
  if (max_iterations < 1) throw std::invalid_argument("max_iterations must be ≥ 1");
  if (!(robust_threshold_mm >= 0.0)) throw std::invalid_argument("robust threshold must be ≥ 0");
  if (!(orientation_weight_mm_per_rad >= 0.0) || !std::isfinite(orientation_weight_mm_per_rad)) {
    throw std::invalid_argument("orientation weight must be ≥ 0 mm per rad (0: estimated)");
  }
}

namespace {

// Per-pose weights of the Huber loss on the error distance (1 inside the threshold), from
// the stacked residual vector (3 per pose).
void HuberWeights(const Eigen::VectorXd& residual, double threshold, std::vector<double>& weights) {
  const int m = static_cast<int>(residual.size() / 3);
  weights.assign(m, 1.0);
  if (threshold <= 0.0) return;
  for (int i = 0; i < m; ++i) {
    const double d = residual.segment<3>(3 * i).norm();
    if (d > threshold) weights[i] = threshold / d;
  }
}

// Huber cost: ρ(d) = d² inside, 2kd − k² outside.
double RobustCost(const Eigen::VectorXd& residual, double threshold) {
  if (threshold <= 0.0) return residual.squaredNorm();
  double cost = 0.0;
  for (Eigen::Index i = 0; i + 2 < residual.size(); i += 3) {
    const double d2 = residual.segment<3>(i).squaredNorm();
    cost +=
        d2 > threshold * threshold ? 2.0 * threshold * std::sqrt(d2) - threshold * threshold : d2;
  }
  return cost;
}

// One Levenberg–Marquardt adjustment of the model's identifiable parameters, and of the
// bases of any further measurement frames, to the poses: paper eq. (8)–(15) iterated to
// convergence. Its steps share the stacked Jacobian, the normal equations and the frames'
// bases, so they are the methods of one object that is used once: Run() reads like the
// procedure (refuse what cannot be fitted, place the frames, choose the unknowns, iterate,
// then σ0, the covariance and the checks).
//
// Poses with a measured orientation add three equations each after all the position
// equations (calibration/orientation.h): the rotation vector of R_measᵀ·R_last·R_tool,
// weighted by w (mm per rad), R_tool each frame's target rotation on the last link, three
// unknowns per frame with orientations (a small turn in the target frame). Without them the
// adjustment is exactly the position-only one.
class Adjustment {
 public:
  Adjustment(const RobotModel& model, const std::vector<MeasuredPose>& poses,
             const EstimationOptions& options);
  EstimationResult Run();

 private:
  // The model at one point of the iteration.
  struct Evaluation {
    Eigen::MatrixXd jacobian;  // rows × unknowns: the identified subset, bases, tool rotations
    Eigen::VectorXd residual;  // 3m positions (model − measured), then 3m_o orientations (×w)
    double cost = 0.0;
  };
  using Bases = std::vector<Eigen::Isometry3d>;  // of the further frames
  using Tools = std::vector<Eigen::Matrix3d>;    // per frame (index in frames_)
  enum class StepOutcome { kRejected, kAccepted, kConverged };

  bool RobotMoves();
  bool PlaceFrames();
  void PlaceTools();
  bool Degenerate(int64_t frame, size_t count);
  bool ChooseUnknowns();
  const std::vector<int>& subset() const { return result_.identifiability.identified; }
  const Eigen::Isometry3d& BaseOf(int i, const Bases& bases) const {
    return extra_[i] < 0 ? result_.world_from_base : bases[extra_[i]];
  }
  void Evaluate(const Eigen::VectorXd& params, const Bases& bases, const Tools& tools,
                Evaluation& e);
  Bases MovedBases(const Bases& bases, const Eigen::VectorXd& step) const;
  Tools TurnedTools(const Tools& tools, const Eigen::VectorXd& step) const;
  std::vector<Eigen::Vector3d> ResidualVectors(const Evaluation& e) const;
  std::vector<std::optional<Eigen::Vector3d>> OrientationVectors(const Evaluation& e) const;
  void BuildNormalEquations(const Evaluation& e);
  void Solve();
  int Iterations(int budget);
  bool ReweightOrientation();
  bool Iterate();
  StepOutcome DampedStep(const Eigen::VectorXd& diagonal);
  bool Converged(double trial_cost, const Eigen::VectorXd& step) const;
  void FitStatistics();
  void Covariance();
  Eigen::MatrixXd TwoStageCovariance(const Eigen::MatrixXd& normal_inverse) const;
  void Check();

  const RobotModel& model_;
  const std::vector<MeasuredPose>& poses_;
  const EstimationOptions& options_;
  const int m_;  // poses
  EstimationResult result_;

  // Measurement frames: the reference (the latest) is the datum; every other one gets a
  // base of its own among the unknowns. `extra_[i]`: the index of pose i's frame among the
  // others, −1 for the reference frame.
  std::vector<int64_t> frames_;
  int extra_frames_ = 0;
  std::vector<int> extra_;
  std::vector<int> frame_index_;  // pose → index in frames_
  std::vector<std::vector<MeasuredPose>> poses_of_;  // per further frame
  std::vector<MeasuredPose> reference_poses_;
  Bases extra_bases_;
  std::vector<Eigen::Vector3d> extra_centres_;  // each further frame's centroid of targets

  // Orientation equations: pose → first row (−1: none); per frame, the first unknown of its
  // tool rotation (−1: no orientations in it) and the rotation itself.
  int oriented_ = 0;  // poses with orientation equations (m_o)
  std::vector<int> orientation_row_;
  std::vector<int> tool_unknown_;
  Tools tools_;
  double weight_ = 0.0;  // w, mm per rad

  int k_ = 0;         // identified parameters
  int unknowns_ = 0;  // k, six per further base, three per frame with orientations
  int rows_ = 0;      // 3m + 3m_o

  Kinematics kin_;
  Eigen::Matrix<double, 6, Eigen::Dynamic> block_;  // one pose's Jacobian, all parameters
  Evaluation current_, trial_;
  Eigen::MatrixXd normal_, weighted_;  // Jᵀ W J, and √W J
  Eigen::VectorXd gradient_;           // Jᵀ W r
  std::vector<double> weights_;        // per pose (the Huber loss; 1 without it)
  double lambda_ = 1e-6;               // Marquardt's damping
};

Adjustment::Adjustment(const RobotModel& model, const std::vector<MeasuredPose>& poses,
                       const EstimationOptions& options)
    : model_(model),
      poses_(poses),
      options_(options),
      m_(static_cast<int>(poses.size())),
      kin_(model),
      block_(6, model.num_parameters()) {
  const int np = model.num_parameters();
  result_.params = Eigen::VectorXd::Zero(np);
  result_.sigmas = Eigen::VectorXd::Constant(np, std::numeric_limits<double>::quiet_NaN());
  orientation_row_.assign(m_, -1);
  if (options.use_orientation) {
    for (int i = 0; i < m_; ++i) {
      if (poses[i].orientation) orientation_row_[i] = 3 * m_ + 3 * oriented_++;
    }
  }
  rows_ = 3 * m_ + 3 * oriented_;
  // The start of the weight when it is estimated: a metre's lever (a rad of wrist rotation
  // moves a target a metre out by a metre); the variance components move it from there.
  weight_ = options.orientation_weight_mm_per_rad > 0 ? options.orientation_weight_mm_per_rad
                                                      : 1000.0;
}

EstimationResult Adjustment::Run() {
  if (!RobotMoves() || !PlaceFrames() || !ChooseUnknowns()) return std::move(result_);
  Solve();
  FitStatistics();
  Covariance();
  Check();
  return std::move(result_);
}

// Poses that do not move the robot determine nothing about its joints: refused, whatever
// the targets (a fit would "converge" with σ0 of the targets' scatter and mean nothing).
bool Adjustment::RobotMoves() {
  if (m_ < 2) return true;
  double motion = 0.0;
  for (const auto& p : poses_)
    motion = std::max(motion, (p.joints_rad - poses_[0].joints_rad).norm());
  if (motion > kNoMotionRad) return true;
  result_.status.code = SolveCode::kDegenerate;
  result_.status.message = "all " + std::to_string(m_) +
                           " poses have the same joint angles: the robot never moved, so the "
                           "poses cannot determine its parameters (measure configurations "
                           "that move every joint)";
  return false;
}

// Sorts the poses by measurement frame and places every frame's base: the reference
// frame's (N1) given by the model or aligned on its poses and then held, the others'
// starting from the nominal model's best fit to theirs. Then the tool rotations.
bool Adjustment::PlaceFrames() {
  frames_ = FramesOf(poses_);
  result_.reference_frame = frames_.empty() ? 0 : frames_.back();
  std::map<int64_t, int> extra_index;
  for (size_t f = 0; f + 1 < frames_.size(); ++f) extra_index[frames_[f]] = static_cast<int>(f);
  extra_frames_ = static_cast<int>(extra_index.size());
  extra_.assign(m_, -1);
  frame_index_.assign(m_, extra_frames_);  // the reference frame is the last
  poses_of_.resize(extra_frames_);
  for (int i = 0; i < m_; ++i) {
    const auto it = extra_index.find(poses_[i].frame);
    if (it == extra_index.end()) {
      reference_poses_.push_back(poses_[i]);
    } else {
      extra_[i] = it->second;
      frame_index_[i] = it->second;
      poses_of_[it->second].push_back(poses_[i]);
    }
  }

  // N1: given, or the rigid best fit of the nominal model (paper: "N1 has to be
  // established before the estimation process begins").
  if (model_.base) {
    result_.world_from_base = *model_.base;
  } else if (auto base = AlignBase(model_, reference_poses_)) {
    result_.world_from_base = *base;
  } else {
    return Degenerate(result_.reference_frame, reference_poses_.size());
  }
  extra_bases_.resize(extra_frames_);
  extra_centres_.assign(extra_frames_, Eigen::Vector3d::Zero());
  for (int e = 0; e < extra_frames_; ++e) {
    const auto base = AlignBase(model_, poses_of_[e]);
    if (!base) return Degenerate(frames_[e], poses_of_[e].size());
    extra_bases_[e] = *base;
    for (const auto& p : poses_of_[e]) extra_centres_[e] += p.target_in_world / poses_of_[e].size();
  }
  PlaceTools();
  return true;
}

// Each frame's tool rotation starts from the nominal model's answer: the mean of
// R_lastᵀ·R_meas over its oriented poses, in its base.
void Adjustment::PlaceTools() {
  tools_.assign(frames_.size(), Eigen::Matrix3d::Identity());
  tool_unknown_.assign(frames_.size(), -1);
  if (oriented_ == 0) return;
  std::vector<std::vector<Eigen::Matrix3d>> relative(frames_.size());
  for (int i = 0; i < m_; ++i) {
    if (orientation_row_[i] < 0) continue;
    kin_.Position(BaseOf(i, extra_bases_), result_.params, poses_[i].joints_rad.data());
    relative[frame_index_[i]].push_back(kin_.LastRotation().transpose() *
                                        poses_[i].orientation->world_from_target);
  }
  if (options_.shared_tool_rotation) {
    // One rotation for every frame: the mean over all of them.
    std::vector<Eigen::Matrix3d> all;
    for (const auto& r : relative) all.insert(all.end(), r.begin(), r.end());
    tools_.assign(frames_.size(), MeanRotation(all));
  } else {
    for (size_t f = 0; f < frames_.size(); ++f) {
      if (!relative[f].empty()) tools_[f] = MeanRotation(relative[f]);
    }
  }
  // tool_unknown_ is numbered in ChooseUnknowns, once the subset's size is known.
  for (size_t f = 0; f < frames_.size(); ++f) tool_unknown_[f] = relative[f].empty() ? -1 : 0;
}

// A frame whose `count` poses cannot place its base: the result says so. Returns false.
bool Adjustment::Degenerate(int64_t frame, size_t count) {
  result_.status.code = SolveCode::kDegenerate;
  result_.status.message =
      (frames_.size() > 1 ? "measurement frame " + std::to_string(frame) + ": " : std::string()) +
      "base: auto needs at least 3 poses whose nominal target positions are not on "
      "one line (got " +
      std::to_string(count) + ")";
  return false;
}

// The unknowns: the candidates the poses identify, then six per further base and three per
// frame with orientations. Refuses poses that identify far too little, and fewer
// equations than unknowns.
bool Adjustment::ChooseUnknowns() {
  std::vector<int> candidates = options_.parameters;
  if (candidates.empty()) {
    for (int i = 0; i < model_.num_parameters(); ++i) candidates.push_back(i);
  }
  std::vector<Eigen::VectorXd> joints;
  joints.reserve(m_);
  for (const auto& p : poses_) joints.push_back(p.joints_rad);
  OrientationRows orientation;
  if (oriented_ > 0) {
    for (int i = 0; i < m_; ++i) {
      const int setup = options_.shared_tool_rotation ? 0 : frame_index_[i];
      orientation.setup.push_back(orientation_row_[i] < 0 ? -1 : setup);
    }
  }

  // The identifiable subset is chosen once, at the nominal model, and kept: re-deciding
  // it at every iteration makes Gauss–Newton wander on real data. It is decided in the
  // robot's own frame: the base rotation multiplies every pose's rows by one orthogonal
  // matrix, which leaves JᵀJ — hence the subset — unchanged in exact arithmetic, while the
  // base aligned on noisy data would let rounding pick between exactly dependent
  // parameters differently from one data set of the same poses to the next. The bases of
  // further frames do not change it: each absorbs the same six rigid motions the
  // reference frame's alignment does, in its own poses only. The tool rotations are taken
  // out of the orientation equations (StackedJacobian), as the fit estimates them.
  result_.identifiability =
      AnalyseIdentifiability(model_, Eigen::Isometry3d::Identity(), joints, candidates,
                             options_.identifiability, oriented_ > 0 ? &orientation : nullptr);
  // Poses that identify far fewer parameters than configurations spread over the joint
  // limits do (the model's structural rank) cannot determine the signature: a joint barely
  // moved, every pose on one path. Refused, naming the joints that never moved.
  if (const int structural = result_.identifiability.structural_rank;
      structural > 0 && 2 * result_.identifiability.rank < structural) {
    std::string frozen;
    for (const auto& f : result_.identifiability.frozen_joints) {
      frozen += (frozen.empty() ? "" : ", ") + std::to_string(f.joint + 1);
    }
    result_.status.code = SolveCode::kDegenerate;
    result_.status.message =
        "the poses determine only " + std::to_string(result_.identifiability.rank) + " of the " +
        std::to_string(structural) +
        " parameters that configurations spread over the joint limits determine" +
        (frozen.empty() ? std::string(": the robot barely moves between them")
                        : "; joints that never move: " + frozen) +
        " (measure configurations that move every joint)";
    return false;
  }
  k_ = static_cast<int>(subset().size());
  unknowns_ = k_ + 6 * extra_frames_;
  int tool_frames = 0;
  for (int& first : tool_unknown_) {
    if (first < 0) continue;
    if (options_.shared_tool_rotation && tool_frames > 0) {
      first = unknowns_ - 3;  // the one shared rotation
      continue;
    }
    first = unknowns_;
    unknowns_ += 3;
    ++tool_frames;
  }
  const int setup_unknowns = 6 * extra_frames_ + 3 * tool_frames;
  const int needed = std::max(k_, result_.identifiability.structural_rank) + setup_unknowns;
  if (rows_ <= needed) {
    result_.status.code = SolveCode::kTooFewObservations;
    const int per_pose = oriented_ > 0 ? 6 : 3;
    result_.status.message =
        std::to_string(m_) + " poses give " + std::to_string(rows_) +
        " equations; the model has " + std::to_string(needed - setup_unknowns) +
        " identifiable parameters" +
        (extra_frames_ > 0
             ? " and " + std::to_string(extra_frames_) + " further measurement frames add " +
                   std::to_string(6 * extra_frames_) + " base unknowns"
             : std::string()) +
        (tool_frames > 0 ? " and " + std::to_string(3 * tool_frames) + " tool-rotation unknowns"
                         : std::string()) +
        " and needs more equations than that: at least " +
        std::to_string(needed / per_pose + 1) + " poses";
    return false;
  }
  return true;
}

// Residuals, their stacked Jacobian by the unknowns and the (robust) cost at `params` with
// the further frames' bases `bases` and the frames' tool rotations `tools`.
void Adjustment::Evaluate(const Eigen::VectorXd& params, const Bases& bases, const Tools& tools,
                          Evaluation& e) {
  e.jacobian.setZero(rows_, unknowns_);
  e.residual.resize(rows_);
  auto position_block = block_.topRows<3>();
  for (int i = 0; i < m_; ++i) {
    const int o = orientation_row_[i];
    const Eigen::Vector3d x =
        o < 0 ? kin_.PositionAndJacobian(BaseOf(i, bases), params, poses_[i].joints_rad.data(),
                                         position_block)
              : kin_.PoseAndJacobian(BaseOf(i, bases), params, poses_[i].joints_rad.data(),
                                     block_);
    e.residual.segment<3>(3 * i) = x - poses_[i].target_in_world;
    for (int c = 0; c < k_; ++c) e.jacobian.block<3, 1>(3 * i, c) = block_.col(subset()[c]).head<3>();
    if (extra_[i] >= 0) {
      // A small motion of the frame's base, world-side: rotation ω about the frame's
      // centre c, then translation t, moves the target by ω × (x − c) + t.
      const Eigen::Vector3d v = x - extra_centres_[extra_[i]];
      auto b = e.jacobian.block<3, 6>(3 * i, k_ + 6 * extra_[i]);
      b.leftCols<3>() << 0, v.z(), -v.y(), -v.z(), 0, v.x(), v.y(), -v.x(), 0;
      b.rightCols<3>().setIdentity();
    }
    // A pose's own weight (a point paired on the move) scales its position rows by √w, so
    // the cost, the normal equations and σ0 all see it; ResidualVectors undoes it.
    if (poses_[i].weight != 1.0) {
      const double root = std::sqrt(poses_[i].weight);
      e.residual.segment<3>(3 * i) *= root;
      e.jacobian.middleRows<3>(3 * i) *= root;
    }
    if (o < 0) continue;
    // The orientation residual ε = log(R_measᵀ·R), R = R_last·R_tool: a world-side turn ω
    // (a parameter, a base) moves it by J_r⁻¹(ε)·Rᵀ·ω, a turn δ of the tool in the target
    // frame by J_r⁻¹(ε)·δ.
    const OrientationLinearisation l = LineariseOrientation(
        poses_[i].orientation->world_from_target, kin_.LastRotation(), tools[frame_index_[i]]);
    e.residual.segment<3>(o) = weight_ * l.residual;
    const Eigen::Matrix3d world_turn = weight_ * l.by_world_turn;
    for (int c = 0; c < k_; ++c) {
      e.jacobian.block<3, 1>(o, c) = world_turn * block_.col(subset()[c]).tail<3>();
    }
    if (extra_[i] >= 0) e.jacobian.block<3, 3>(o, k_ + 6 * extra_[i]) = world_turn;
    e.jacobian.block<3, 3>(o, tool_unknown_[frame_index_[i]]) = weight_ * l.by_tool_turn;
  }
  e.cost = RobustCost(e.residual.head(3 * m_), options_.robust_threshold_mm) +
           e.residual.tail(3 * oriented_).squaredNorm();
}

// The further frames' bases moved by a step's six base unknowns each (ω, t as in Evaluate).
Adjustment::Bases Adjustment::MovedBases(const Bases& bases, const Eigen::VectorXd& step) const {
  Bases out = bases;
  for (int f = 0; f < extra_frames_; ++f) {
    const Eigen::Vector3d w = step.segment<3>(k_ + 6 * f), t = step.segment<3>(k_ + 6 * f + 3);
    const Eigen::Vector3d& c = extra_centres_[f];
    Eigen::Isometry3d motion = Eigen::Isometry3d::Identity();
    motion.translate(c + t);
    if (w.norm() > 0) motion.rotate(Eigen::AngleAxisd(w.norm(), w.normalized()));
    motion.translate(-c);
    out[f] = motion * bases[f];
  }
  return out;
}

// The frames' tool rotations turned by a step's three unknowns each (δ in the target frame).
Adjustment::Tools Adjustment::TurnedTools(const Tools& tools, const Eigen::VectorXd& step) const {
  Tools out = tools;
  for (size_t f = 0; f < tools.size(); ++f) {
    if (tool_unknown_[f] >= 0) out[f] = tools[f] * RotationFromVector(step.segment<3>(tool_unknown_[f]));
  }
  if (options_.shared_tool_rotation) {
    // Frames without orientations follow the shared one too (it is theirs if they had any).
    for (size_t f = 0; f < tools.size(); ++f) {
      if (tool_unknown_[f] >= 0) {
        for (auto& t : out) t = out[f];
        break;
      }
    }
  }
  return out;
}

std::vector<Eigen::Vector3d> Adjustment::ResidualVectors(const Evaluation& e) const {
  std::vector<Eigen::Vector3d> r(m_);
  for (int i = 0; i < m_; ++i) r[i] = e.residual.segment<3>(3 * i) / std::sqrt(poses_[i].weight);
  return r;
}

// The orientation residuals (rad) of the poses that have them.
std::vector<std::optional<Eigen::Vector3d>> Adjustment::OrientationVectors(
    const Evaluation& e) const {
  std::vector<std::optional<Eigen::Vector3d>> r(m_);
  for (int i = 0; i < m_; ++i) {
    if (orientation_row_[i] >= 0) r[i] = e.residual.segment<3>(orientation_row_[i]) / weight_;
  }
  return r;
}

// Jᵀ W J and Jᵀ W r at `e`, W the Huber weights of its position residuals (orientation
// equations keep weight one: w is in their rows already).
void Adjustment::BuildNormalEquations(const Evaluation& e) {
  HuberWeights(e.residual.head(3 * m_), options_.robust_threshold_mm, weights_);
  weighted_ = e.jacobian;
  for (int i = 0; i < m_; ++i) weighted_.middleRows<3>(3 * i) *= std::sqrt(weights_[i]);
  normal_.setZero();
  normal_.selfadjointView<Eigen::Lower>().rankUpdate(weighted_.transpose());
  normal_.triangularView<Eigen::Upper>() = normal_.transpose();
  Eigen::VectorXd wr = e.residual;
  for (int i = 0; i < m_; ++i) wr.segment<3>(3 * i) *= weights_[i];
  gradient_.noalias() = e.jacobian.transpose() * wr;
}

// Levenberg–Marquardt on the subset (and the further frames' bases and the tool rotations)
// with Marquardt's diagonal scaling, from the nominal model. One stacked Jacobian per
// evaluation; the trial point's Jacobian is reused when it is accepted. With an estimated
// orientation weight, each converged solution re-estimates it and the iteration goes on
// from there until it settles.
void Adjustment::Solve() {
  normal_.resize(unknowns_, unknowns_);
  weighted_.resize(rows_, unknowns_);
  gradient_.resize(unknowns_);
  Evaluate(result_.params, extra_bases_, tools_, current_);
  result_.nominal_residuals = ResidualVectors(current_);
  result_.nominal = Summarise(Distances(result_.nominal_residuals));
  result_.nominal_orientation_residuals = OrientationVectors(current_);
  result_.nominal_angle = SummariseAngles(Angles(result_.nominal_orientation_residuals));

  int iterations = 0;
  bool converged = false;
  for (int round = 0; round < kMaxWeightRounds; ++round) {
    const int used = Iterations(options_.max_iterations - iterations);
    iterations += std::abs(used);
    converged = used > 0;
    if (!converged || options_.orientation_weight_mm_per_rad > 0 || oriented_ == 0) break;
    if (!ReweightOrientation()) break;
  }
  result_.iterations = iterations;
  result_.status.code = converged ? SolveCode::kOk : SolveCode::kNotConverged;
  if (!converged) {
    result_.status.message = "no convergence after " + std::to_string(iterations) + " iterations";
  }
  result_.bases[result_.reference_frame] = result_.world_from_base;
  for (int f = 0; f < extra_frames_; ++f) result_.bases[frames_[f]] = extra_bases_[f];
  for (size_t f = 0; f < frames_.size(); ++f) {
    if (tool_unknown_[f] >= 0 || (options_.shared_tool_rotation && oriented_ > 0))
      result_.tool_rotations[frames_[f]] = tools_[f];
  }
  result_.tool_rotation_shared = options_.shared_tool_rotation && oriented_ > 0;
  result_.orientation_weight_mm_per_rad = oriented_ > 0 ? weight_ : 0.0;
  result_.orientation_poses = oriented_;
}

// Iterates at most `budget` times: the iterations used, negative when it did not converge.
int Adjustment::Iterations(int budget) {
  for (int iteration = 1; iteration <= budget; ++iteration) {
    options_.stop.ThrowIfRequested();
    if (Iterate()) return iteration;
  }
  return -std::max(budget, 0);
}

// Variance components (Helmert, Förstner): each group's a-posteriori σ² is its weighted
// sum of squares over its redundancy — its equations less their share of the unknowns,
// the trace of the hat matrix over them. The new weight makes the two groups' σ agree;
// true when it moved by more than 0.1 % (then the fit goes on at the current point).
bool Adjustment::ReweightOrientation() {
  BuildNormalEquations(current_);
  const Eigen::MatrixXd solved = normal_.ldlt().solve(weighted_.transpose());  // N⁻¹ Aᵀ √W
  double hat_position = 0.0, hat_orientation = 0.0;
  for (int r = 0; r < rows_; ++r) {
    const double h = weighted_.row(r).dot(solved.col(r));
    (r < 3 * m_ ? hat_position : hat_orientation) += h;
  }
  double position_squares = 0.0;
  for (int i = 0; i < m_; ++i)
    position_squares += weights_[i] * current_.residual.segment<3>(3 * i).squaredNorm();
  const double orientation_squares =
      current_.residual.tail(3 * oriented_).squaredNorm() / (weight_ * weight_);
  const double position_variance = position_squares / std::max(3.0 * m_ - hat_position, 1.0);
  const double orientation_variance =
      orientation_squares / std::max(3.0 * oriented_ - hat_orientation, 1.0);
  if (!(position_variance > 0.0 && orientation_variance > 0.0)) return false;
  const double weight = std::sqrt(position_variance / orientation_variance);
  const bool moved = std::abs(weight - weight_) > 1e-3 * weight_;
  weight_ = weight;
  Evaluate(result_.params, extra_bases_, tools_, current_);
  lambda_ = 1e-6;
  return moved;
}

// One iteration: the normal equations at the current point, then damped steps with a
// growing λ until one lowers the cost. True when the adjustment has converged.
bool Adjustment::Iterate() {
  BuildNormalEquations(current_);
  const Eigen::VectorXd diagonal = normal_.diagonal().cwiseMax(1e-30);
  for (int attempt = 0; attempt < 30; ++attempt) {
    const StepOutcome outcome = DampedStep(diagonal);
    if (outcome != StepOutcome::kRejected) return outcome == StepOutcome::kConverged;
  }
  return true;  // no step lowers the cost: at the minimum to working precision
}

// Solves the normal equations damped by λ times their diagonal and tries the step: taken
// (λ shrinks) when it does not raise the cost, refused (λ grows) otherwise.
Adjustment::StepOutcome Adjustment::DampedStep(const Eigen::VectorXd& diagonal) {
  Eigen::MatrixXd damped = normal_;
  damped.diagonal() += lambda_ * diagonal;
  const Eigen::VectorXd step = -damped.llt().solve(gradient_);
  Eigen::VectorXd trial_params = result_.params;
  for (int c = 0; c < k_; ++c) trial_params(subset()[c]) += step(c);
  Bases trial_bases = MovedBases(extra_bases_, step);
  Tools trial_tools = TurnedTools(tools_, step);
  Evaluate(trial_params, trial_bases, trial_tools, trial_);
  if (!(std::isfinite(trial_.cost) && trial_.cost <= current_.cost)) {
    lambda_ *= 10.0;
    return StepOutcome::kRejected;
  }
  const bool converged = Converged(trial_.cost, step);
  result_.params = trial_params;
  extra_bases_ = std::move(trial_bases);
  tools_ = std::move(trial_tools);
  std::swap(current_, trial_);
  lambda_ = std::max(lambda_ / 10.0, 1e-12);
  return converged ? StepOutcome::kConverged : StepOutcome::kAccepted;
}

// The convergence test of a step about to be taken: the cost hardly falls, the step is
// tiny against the parameters, or the model meets the measurements exactly.
bool Adjustment::Converged(double trial_cost, const Eigen::VectorXd& step) const {
  const double relative_decrease = (current_.cost - trial_cost) / std::max(current_.cost, 1e-300);
  const double relative_step = step.norm() / (result_.params.norm() + options_.parameter_tolerance);
  return relative_decrease < options_.function_tolerance ||
         relative_step < options_.parameter_tolerance || trial_cost == 0.0;
}

// Cost, redundancy, residuals and σ0 at the solution (the normal equations rebuilt there for
// the covariance). σ0 is that of the whole weighted adjustment, in mm: with the weight
// estimated it is the position σ; σ0 of the orientations is the same in rad.
void Adjustment::FitStatistics() {
  BuildNormalEquations(current_);
  result_.cost = current_.cost;
  result_.redundancy = rows_ - unknowns_;
  result_.fit_residuals = ResidualVectors(current_);
  result_.fit_orientation_residuals = OrientationVectors(current_);
  double weighted_sq = current_.residual.tail(3 * oriented_).squaredNorm();
  for (int i = 0; i < m_; ++i) weighted_sq += weights_[i] * result_.fit_residuals[i].squaredNorm();
  result_.sigma0_mm = std::sqrt(weighted_sq / result_.redundancy);
  if (oriented_ > 0) result_.sigma0_rad = result_.sigma0_mm / weight_;
  result_.fit = Summarise(Distances(result_.fit_residuals));
  result_.fit_angle = SummariseAngles(Angles(result_.fit_orientation_residuals));
  if (options_.robust_threshold_mm > 0.0) {
    for (int i = 0; i < m_; ++i) {
      if (result_.fit_residuals[i].norm() > options_.robust_threshold_mm)
        result_.downweighted.push_back(i);
    }
  }
}

// Covariance of the identified parameters: σ0² (Jᵀ W J)⁻¹ at the solution (the further
// frames' bases and the tool rotations are unknowns of the same adjustment: their block is
// marginalised), and their sigmas.
void Adjustment::Covariance() {
  if (k_ == 0) return;
  const Eigen::MatrixXd normal_inverse =
      normal_.ldlt().solve(Eigen::MatrixXd::Identity(unknowns_, unknowns_));
  Eigen::MatrixXd covariance;
  if (model_.base) {
    covariance = result_.sigma0_mm * result_.sigma0_mm * normal_inverse;
  } else {
    covariance = TwoStageCovariance(normal_inverse);
  }
  result_.covariance = covariance.topLeftCorner(k_, k_);
  for (int c = 0; c < k_; ++c) result_.sigmas(subset()[c]) = std::sqrt(result_.covariance(c, c));
}

// The reference base was aligned on its frame's measured positions, then held: a two-stage
// estimate. To first order the alignment moves the base by db = (BᵀB)⁻¹Bᵀ dy, with B the
// rows × 6 derivative of the world positions by a small rotation and translation of the
// base (zero in the rows of other frames and in the orientation equations, which the
// alignment does not use), and the unknowns answer the rest:
// du = N⁻¹JᵀW (I − B(BᵀB)⁻¹Bᵀ) dy. Hence Cov(u) = σ0² N⁻¹ Cᵀ W⁻¹ C N⁻¹ with
// C = (I − P_B) W J. Without this, the parameters the base alignment already explains (the
// first joint's) would be reported two to three times less certain than repeated fits show
// them to be.
Eigen::MatrixXd Adjustment::TwoStageCovariance(const Eigen::MatrixXd& normal_inverse) const {
  Eigen::MatrixXd base_jacobian = Eigen::MatrixXd::Zero(rows_, 6);
  const Eigen::Vector3d origin = result_.world_from_base.translation();
  for (int i = 0; i < m_; ++i) {
    if (extra_[i] >= 0) continue;
    const Eigen::Vector3d x = poses_[i].target_in_world + result_.fit_residuals[i] - origin;
    base_jacobian.block<3, 3>(3 * i, 0) << 0, x.z(), -x.y(), -x.z(), 0, x.x(), x.y(), -x.x(), 0;
    base_jacobian.block<3, 3>(3 * i, 3).setIdentity();
    base_jacobian.middleRows<3>(3 * i) *= std::sqrt(poses_[i].weight);
  }
  Eigen::MatrixXd c = current_.jacobian;
  for (int i = 0; i < m_; ++i) c.middleRows<3>(3 * i) *= weights_[i];
  const Eigen::Matrix<double, 6, 6> base_normal = base_jacobian.transpose() * base_jacobian;
  c -= base_jacobian * base_normal.ldlt().solve(base_jacobian.transpose() * c);
  for (int i = 0; i < m_; ++i) c.middleRows<3>(3 * i) /= std::sqrt(std::max(weights_[i], 1e-12));
  return result_.sigma0_mm * result_.sigma0_mm * normal_inverse * (c.transpose() * c) *
         normal_inverse;
}

// A fit whose numbers are not numbers is no result, whatever the iterations said.
void Adjustment::Check() {
  bool finite = std::isfinite(result_.sigma0_mm) && std::isfinite(result_.cost) &&
                result_.params.allFinite() && result_.covariance.allFinite();
  for (const auto& [frame, base] : result_.bases) finite = finite && base.matrix().allFinite();
  for (const auto& [frame, tool] : result_.tool_rotations) finite = finite && tool.allFinite();
  for (int c = 0; c < k_; ++c) finite = finite && std::isfinite(result_.sigmas(subset()[c]));
  for (const auto& r : result_.nominal_residuals) finite = finite && r.allFinite();
  for (const auto& r : result_.fit_residuals) finite = finite && r.allFinite();
  for (const auto& r : result_.fit_orientation_residuals) finite = finite && (!r || r->allFinite());
  if (oriented_ > 0) finite = finite && std::isfinite(result_.sigma0_rad);
  if (!finite) {
    result_.status.code = SolveCode::kNonFinite;
    result_.status.message =
        "the fit produced values that are not finite numbers (inf or NaN): check the poses' "
        "coordinates and the model's lengths";
  }
}

}  // namespace

EstimationResult Estimate(const RobotModel& model, const std::vector<MeasuredPose>& poses,
                          const EstimationOptions& options) {
  options.Check();
  for (const auto& p : poses) {
    if (!(p.weight > 0.0) || !std::isfinite(p.weight))
      throw std::invalid_argument("pose " + p.id + ": a weight must be a positive number");
  }
  return Adjustment(model, poses, options).Run();
}

}  // namespace armsig::calibration
