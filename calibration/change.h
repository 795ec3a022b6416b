// Has the robot changed since a parameter set was fitted, from which session on, and why?
//
// Sessions measured after a set are tested against it one by one: each session's own
// measuring frame is placed on its poses (a set-up moves between sessions; the robot's
// signature does not), and what is left is tested two ways — a linearised refit of the
// set's identified parameters on the session, compared with the set by the positions both
// predict over the work volume (calibration/drift.h), and, for sessions too small for
// that, the single physical causes below. A difference is then explained by those causes:
// each joint's zero, each axis's tilt, each link's length and offsets, the tool, the
// model's non-geometric terms and the instrument's scale, each fitted alone against the
// difference with the measuring frame free, ranked by how much of it each explains.
#pragma once

#include <Eigen/Core>
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
std::vector<Cause> CandidateCauses(const RobotModel& model);

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
  // Its effect at the tool over configurations spread over the work volume, a rigid
  // motion of the whole removed (mm).
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
};

// Each cause fitted alone to `difference` (at the parameters `params`), each group's rigid
// motion free. `spread`: configurations over the work volume for the effect in mm.
Explanation ExplainDifference(const RobotModel& model, const Eigen::VectorXd& params,
                              const Difference& difference,
                              const std::vector<Eigen::VectorXd>& spread, int best = 3);

// The difference of two fitted sets as ExplainDifference takes it: b's predicted positions
// less a's over `spread`, after the rigid alignment CompareModels makes, with the noise of
// both sets' covariances.
Difference SetDifference(const RobotModel& model, const FittedSet& a, const FittedSet& b,
                         const std::vector<Eigen::VectorXd>& spread);

struct ChangeTestOptions {
  double significance = 1e-3;  // of each session's test (both ways together)
  double tolerance_mm = 0.05;  // a change whose effect stays below this is no change
  void Check() const;
};

// One group of poses (a session, or several) against a set.
struct SessionTest {
  std::vector<int64_t> frames;
  int poses = 0;
  double mean_mm = 0.0, rms_mm = 0.0;  // the set's error distances on them (own frames)
  // The refit of the set's identified parameters: run when the poses hold enough
  // equations (3 per pose) for them and every frame with room to spare.
  bool refit = false;
  ModelComparison comparison;  // the refitted set against the set (when refit)
  bool refit_disagrees = false;
  Explanation explanation;  // the single causes, against the same residuals
  bool cause_disagrees = false;
  double p_value = 1.0;      // the smaller of the two tests' (each at half the level)
  double effect_max_mm = 0.0;  // the larger of the two tests' predicted effects
  bool disagrees = false;
};

// Residuals of the poses under the set (`residuals`: model, with the set's residual map
// where it applies, − measured; each frame's base from `bases`), tested. `set_sigma_mm`:
// the set's own error per coordinate out of sample (its validation rms / √3), the noise a
// session of the same robot shows; a session that shows more is judged by its own.
SessionTest TestAgainstSet(const RobotModel& model, const FittedSet& set, double set_sigma_mm,
                           const std::vector<MeasuredPose>& poses, const FrameBases& bases,
                           const std::vector<Eigen::Vector3d>& residuals,
                           const std::vector<Eigen::VectorXd>& spread,
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
