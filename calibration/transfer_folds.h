// Folds that ask whether a model term carries beyond the data it was fitted on.
//
// Random K-fold cross-validation holds out poses mixed among the fit poses: a term that
// follows the fit data's own region (a harmonic fitted over a third of a joint's turn, a
// compliance fitted on one arm branch) scores well there and may be absurd a few degrees
// outside it. A signature is used on another day's set-up and on configurations the
// capture never visited, so whether a term is kept is judged on data the fit did not see
// *from another session or another region of joint space*:
//
//  - sessions: when at least two sessions (measurement frames) each hold a good share of
//    the poses, each of them is held out in turn (the small ones are spread over the
//    folds), so a term must hold on another day's set-up;
//  - joint-space blocks: otherwise the poses are cut into `folds` compact regions of the
//    joint space (k-means on the standardised sin/cos features of the joints that move the
//    target, seeded k-means++), and each region is held out in turn, so a term must hold
//    on configurations beside, not among, those it was fitted on.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <string>
#include <vector>

#include "calibration/model.h"
#include "core/types.h"

namespace armsig::calibration {

struct TransferFolds {
  enum class Kind { kSessions, kJointBlocks };
  Kind kind = Kind::kJointBlocks;
  int folds = 0;
  std::vector<int> fold_of_pose;  // per pose, in [0, folds)
  // "3 sessions held out in turn" / "5 joint-space blocks held out in turn"
  std::string Describe() const;
};

// Sessions are folds when at least two frames hold kMinSessionShare of the poses each.
inline constexpr double kMinSessionShare = 0.15;

// Joints whose motion moves the target over the poses (nominal lever above a micron per
// radian): a joint whose axis passes through the target carries no information. Ascending.
std::vector<int> JointsThatMoveTheTarget(const RobotModel& model,
                                         const std::vector<MeasuredPose>& poses);

// The folds of `poses` (see the header comment). `folds` ≥ 2 and at least two poses per
// fold, else std::invalid_argument. Deterministic for a seed.
TransferFolds AssignTransferFolds(const RobotModel& model, const std::vector<MeasuredPose>& poses,
                                  int folds, unsigned seed);

// The joint-space blocks alone: k-means (k-means++ start, Lloyd iterations) of the rows of
// `features` into `folds` clusters; a cluster left with fewer than two members is merged into
// the nearest other. Returns each row's cluster, renumbered 0 … (clusters − 1) by first
// appearance; `clusters` gets their number.
std::vector<int> JointSpaceBlocks(const Eigen::MatrixXd& features, int folds, unsigned seed,
                                  int* clusters);

}  // namespace armsig::calibration
