// Checks at the door: do measured poses belong to this robot, with this tool, in these
// units? The nominal model of any robot misses its real positions by millimetres (the
// PUMA 760: 6 mm, the UR10: 5 mm). Poses it misses by centimetres after the best rigid
// placement are another robot's, another tool's, or in other units — radians read as
// degrees, metres as millimetres — and a least-squares fit would happily turn them into
// absurd parameters. Each alternative reading is tried, so the message can say which.
#pragma once

#include <string>
#include <vector>

#include "calibration/model.h"
#include "core/types.h"

namespace armsig::calibration {

// Above this rms (mm, after the best rigid placement) the nominal model does not describe
// the poses: as capture's base-fit check (io::Tolerances::max_base_fit_rms_mm).
inline constexpr double kMaxNominalRmsMm = 25.0;

struct PoseModelCheck {
  bool checked = false;  // false: too few or degenerate poses to place the base
  bool fits = true;
  double rms_mm = 0.0;   // the nominal model's, as the poses are read
  // When it does not fit: the reading under which it does (empty if none), in words ("the
  // joint values are radians, not degrees"), and that reading's rms.
  std::string reading;
  double reading_rms_mm = 0.0;
};

// The nominal model (every parameter zero) rigidly placed on the poses.
PoseModelCheck CheckPosesAgainstModel(const RobotModel& model,
                                      const std::vector<MeasuredPose>& poses,
                                      double max_rms_mm = kMaxNominalRmsMm);

// The number of configurations that differ (any joint by more than a micro-radian).
int DistinctConfigurations(const std::vector<MeasuredPose>& poses);

}  // namespace armsig::calibration
