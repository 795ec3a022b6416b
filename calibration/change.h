// Has the robot changed since a parameter set was fitted, from which session on, and why?
//
// Sessions are tested against a reference: the active set refitted on every configuration of
// the sessions it was fitted on, so that what those sessions say the robot is (not the
// selection the fit used) is what a new session is held to. Each session's own measuring
// frame is placed on its poses (a set-up moves between sessions; the robot's signature does
// not), and its residuals are tested against the single physical causes below — each
// joint's zero, each axis's tilt, each link's length and offsets, the tool, the model's
// non-geometric terms, the instrument's scale — each fitted alone with the frame free, with
// the scatter the reference sessions themselves show between them (real robots leave
// systematic residuals that a white-noise model would take for a change).
#pragma once

#include <Eigen/Core>
#include <optional>
#include <string>
#include <vector>

#include "calibration/drift.h"
#include "calibration/estimation.h"
#include "calibration/model.h"
#include "core/types.h"

namespace armsig::calibration {

// One physical explanation of a change: a direction in parameter space of unit size (1 mm
// or 1 rad of the named quantity), or the instrument's scale (a length change proportional
// to the distance, `scale` true).
struct Cause {
  std::string name;       // "joint 2 zero", "link 2 length (joint 2 to joint 3, 650 mm)", …
  std::string parameter;  // the model parameter it is ("gamma2"), or "" for a combination
  bool angle = false;     // size in rad (shown in mrad), else mm (scale: a pure number, ppm)
  bool scale = false;
  Eigen::VectorXd direction;  // over every parameter (empty for the scale)
  // Of two causes the data cannot tell apart, the one a lab names first (lower): a joint's
  // zero, a link's length, the tool, a term, the scale (0), an axis tilt (1), a single
  // offset of a joint's frame (2).
  int priority = 0;
};

// Every cause a lab meets that the model can express: per joint its zero (γ), its axis
// tilts (α, β) and its position (a, b, c); per link with a nominal length (> 1 mm) that
// length; the tool's offsets and length; each non-geometric term; the instrument's scale.
// `terms`: the non-geometric terms (parameter indices) that may be causes — those the fitted
// sets estimate; nullopt: every term of the model.
std::vector<Cause> CandidateCauses(const RobotModel& model,
                                   const std::optional<std::vector<int>>& terms = std::nullopt);

// Differences to explain: at each configuration (encoder angles), an observed change of the
// target position (3 per configuration, in the frame of `positions`) with the rotation
// that takes robot-base vectors into that frame, and a group: one rigid motion per group
// is free (a session's measuring frame, or the alignment of two sets), so no cause is
// blamed for what a moved frame does.
struct Difference {
  std::vector<Eigen::VectorXd> configurations;
  std::vector<Eigen::Isometry3d> world_from_base;  // per configuration
  std::vector<int> group;                          // per configuration, 0-based
  Eigen::VectorXd change;                          // 3m: observed − reference, mm
  // The noise of `change`: sigma_mm² per coordinate (independent: the measurements) plus
  // noise_factor · noise_factorᵀ (3m × r; correlated: the uncertainty of a fitted set's
  // predictions) when given.
  double sigma_mm = 0.0;
  Eigen::MatrixXd noise_factor;
};

struct ExplainedCause {
  Cause cause;
  double size = 0.0;   // mm, rad, or (scale) a fraction
  double sigma = 0.0;  // its standard deviation (same unit)
  // The share of the difference that the causes can explain at all which this one
  // explains alone (1: all of it), on the data given.
  double explained = 0.0;
  double chi2 = 0.0;  // (size / sigma)², one degree of freedom
  // Its effect at the tool over the difference's configurations, each group's rigid motion
  // removed (mm).
  double effect_max_mm = 0.0, effect_mean_mm = 0.0;
  // Other causes with the same effect on these data (indistinguishable from this one).
  std::vector<std::string> equivalent;
};

struct Explanation {
  std::vector<ExplainedCause> causes;  // best first (most explained), at most `best`
  // Causes whose effect a moved measuring frame makes entirely (joint 1 zero, the base):
  // these data cannot tell them from a set-up that moved.
  std::vector<std::string> indistinguishable_from_frame;
  double sum_squares = 0.0;             // |change|² with each group's rigid motion removed
  double explainable_sum_squares = 0.0;  // the part all causes together explain
  int candidates = 0;                    // causes tested (distinguishable ones)
  // Causes whose fitted size no robot shows (calibration/signature_limits.h): left out of
  // `causes`, by name.
  std::vector<std::string> implausible;
};

// Each cause fitted alone to `difference` (at the parameters `params`), each group's rigid
// motion free; its effect in mm over the difference's own configurations. `best` causes are
// kept (every cause with `best` < 0).
Explanation ExplainDifference(const RobotModel& model, const Eigen::VectorXd& params,
                              const Difference& difference, int best = 3,
                              const std::optional<std::vector<int>>& terms = std::nullopt);

// The difference of two fitted sets as ExplainDifference takes it: b's predicted positions
// less a's over `spread`, after the rigid alignment CompareModels makes, with the noise of
// both sets' covariances.
Difference SetDifference(const RobotModel& model, const FittedSet& a, const FittedSet& b,
                         const std::vector<Eigen::VectorXd>& spread);

struct ChangeTestOptions {
  double significance = 1e-3;  // of each session's test (Bonferroni over the causes)
  double tolerance_mm = 0.05;  // a change whose effect stays below this is no change
  void Check() const;
};

// What sessions are held to: a set, the measurement noise per coordinate a session of the
// same robot shows at least, and how much more the single-cause estimates scatter between
// the reference's own sessions than that noise says (≥ 1).
struct ChangeReference {
  FittedSet set;
  double sigma_mm = 0.0;
  double overdispersion = 1.0;
  int sessions = 0;  // reference sessions it was made from (0: the set as given)
  std::optional<std::vector<int>> terms;  // the non-geometric terms that may be causes
};

// The set refitted by one linearised least-squares step on every pose of `poses` (the
// sessions it was fitted on; each frame free), with the overdispersion of single causes
// between those sessions. With no poses, the set as given (overdispersion 1).
ChangeReference MakeChangeReference(const RobotModel& model, const FittedSet& set,
                                    double sigma_mm, const std::vector<MeasuredPose>& poses,
                                    const std::optional<std::vector<int>>& terms = std::nullopt);

// One group of poses (a session, or several) against the reference.
struct SessionTest {
  std::vector<int64_t> frames;
  int poses = 0;
  double mean_mm = 0.0, rms_mm = 0.0;  // the reference's error distances (own frames placed)
  Explanation explanation;   // the single causes, best first (every cause)
  double chi2 = 0.0;         // of the most significant cause, over the overdispersion
  double p_value = 1.0;      // Bonferroni over the causes
  double effect_max_mm = 0.0;  // that cause's effect at the tool on these configurations
  bool disagrees = false;
};

SessionTest TestAgainstReference(const RobotModel& model, const ChangeReference& reference,
                                 const std::vector<MeasuredPose>& poses,
                                 const ChangeTestOptions& options = {});

// Where a run of sessions changed: `disagrees` per session in time order. The change point
// is the first session of the last unbroken run of disagreeing sessions that reaches the
// newest one; an earlier session that disagrees while a later one agrees is an outlier
// (a set-up fault, not the robot), not a change.
struct ChangePoint {
  int first_changed = -1;    // index of the first changed session; -1: no change
  std::vector<int> outliers;  // indices of disagreeing sessions before an agreeing one
};
ChangePoint LocateChange(const std::vector<bool>& disagrees);

}  // namespace armsig::calibration
