// Program filtering: every target of a robot program rewritten so that the robot as its
// signature describes it lands where the program says, the rest of the program untouched.
//
// For each target, in the order the motions use them:
//   intent      the TCP pose the program means: a pose target's pose (in its base frame,
//               turned into the robot's base), a joint target's pose as the controller's model
//               puts the TCP at those joints;
//   nominal     the joints the controller reaches it with: its inverse on its own model, in
//               the configuration the target states (KUKA S/T, ABB cf) or nearest the joints
//               it starts from (a UR's qnear, else the previous target's);
//   compensated the joints at which the signed robot — the parameter set's geometry up to the
//               flange, its non-geometric terms, its residual map — puts the TCP on the intent
//               (the orientation too: the set's own where it was fitted to measured
//               orientations, its model's otherwise, said per target), solved from the
//               nominal joints;
//   written     a joint target: the compensated joints; a pose target: the pose the
//               controller's model gives the compensated joints — what makes its inverse
//               return them — in the target's own frame, the configuration kept.
//
// Refused (named with the line and why; nothing written unless allow_outside): compensated
// joints outside the arcs the set was fitted on (its terms are held there, and its error
// there is the larger held-out one), a calibration point outside the measured volume, a target out of reach, one whose compensated joints need another
// configuration than the program's, one whose taught joints (a UR waypoint's q, a robtarget's
// confdata) miss its own pose. A target whose tool or base the program does not define, or
// that motions with different tools share, is named and left as written.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <optional>
#include <string>
#include <vector>

#include "calibration/compensation.h"
#include "calibration/model.h"
#include "calibration/validity.h"
#include "programs/controller.h"
#include "programs/program.h"
#include "programs/volume.h"

namespace armsig::calibration {
class ResidualMap;
}

namespace armsig::programs {

// The robot as its signature describes it. `params` and `map` in the model's order and frame
// (the robot frame: base identity); the calibration point is the model's own tool.
struct SignedRobot {
  const calibration::RobotModel* model = nullptr;
  Eigen::VectorXd params;
  const calibration::ResidualMap* map = nullptr;  // may be null
  bool orientation_measured = false;  // fitted to measured orientations (6-DoF data)
  // Where the set was fitted and the error it showed on held-out data (null: not stored),
  // and its identified parameters' covariance (empty: not stored): each target's support
  // and predicted σ.
  const calibration::SetValidity* validity = nullptr;
  std::vector<int> identified;
  Eigen::MatrixXd covariance;
};

// Where the signed robot puts the TCP of `tool` (flange → TCP) at the joints: the chain with
// the set's parameters, the flange shifted by the calibration point's fitted offset (a, b, c
// of the tool parameters: the probe sits where the model file says, so that offset is the
// flange's), the map's joint curves on the angles and its kernel correction on the position.
// The flange's turn after the last joint is the model's: no data can tell it from the
// probe's own.
struct SignedPose {
  Eigen::Isometry3d tcp = Eigen::Isometry3d::Identity();
  bool map_extrapolated = false;  // a part of the map had no data there
};
SignedPose SignedTcp(const SignedRobot& robot, const Eigen::Isometry3d& tool,
                     const Eigen::VectorXd& joints_rad);
// The calibration point itself (the set's measured point) at the joints, robot frame.
Eigen::Vector3d SignedCalibrationPoint(const SignedRobot& robot, const Eigen::VectorXd& joints_rad);

// Joints at which the signed robot puts the TCP at `pose` (position and orientation, each
// radian weighing calibration::kPoseLeverMm mm), from `seed`.
calibration::JointSolution SolveSigned(const SignedRobot& robot, const Eigen::Isometry3d& tool,
                                       const Eigen::Isometry3d& pose, const Eigen::VectorXd& seed_rad,
                                       const calibration::JointSolveOptions& options = {});

enum class TargetStatus {
  kOk,
  kOutsideJointRange,       // refused: a compensated joint outside the set's validated range
  kOutsideMeasuredVolume,   // refused: the calibration point outside the measured volume
  kOutOfReach,              // refused: no joints reach it (controller or signed robot)
  kConfigurationChange,     // refused: the compensated joints need another configuration
  kTaughtJointsMissPose,    // refused: its taught joints / configuration data miss its pose
  kFrameUnknown,            // named: the tool or base in use is not defined by the program
  kConflictingUse,          // named: motions with different tools or bases share it
};
const char* ToString(TargetStatus status);  // ok, outside_joint_range, …
bool IsRefusal(TargetStatus status);

struct TargetReport {
  int target = -1;  // index into Program::targets
  TargetStatus status = TargetStatus::kOk;
  std::string why;             // when not ok
  std::string note;            // an assumption made for it (ok or not)
  std::vector<int> motions;    // the lines of the motions that use it
  // What the rewrite changes in the controller's terms: the TCP moves by correction_mm and
  // turns by correction_deg (NaN when nothing could be computed).
  double correction_mm = NAN, correction_deg = NAN;
  // The signed robot at the compensated joints against the intent (the solve's residual).
  double residual_mm = NAN;
  Eigen::VectorXd nominal_joints_rad, compensated_joints_rad;
  bool orientation_measured = false;
  bool map_extrapolated = false;
  // What the set promises for it. Inside its support: every joint inside the arc the set
  // was fitted on, the calibration point inside the volume measured, the map applied in
  // full (calibration::SupportAt); `support` says "inside" or where not. `sigma_mm`: the
  // predicted σ per coordinate of where the TCP lands (calibration::PredictionSigmaMm, the
  // held-out figure of inside or outside; NaN when the set stores neither a covariance nor a
  // held-out σ): within calibration::kCoverageRadius σ of the intent 95 % of the time.
  bool inside_support = false;
  std::string support;
  double sigma_mm = NAN;
  // With a fitted tool mounting (calibration::ToolMounting): the lever from the calibration
  // point to the TCP (mm). The flange's turn after the last joint is not known to such a set
  // (the fit put it into the offset at the target), and each mrad of it moves the TCP by
  // lever_mm / 1000 mm. NaN with a known mounting (the turn is the set's).
  double lever_mm = NAN;
  bool written = false;
};

struct CompensationOptions {
  bool allow_outside = false;  // write refused targets that have compensated joints anyway
  // A pose and its taught joints (a UR waypoint's p and q) agree within these.
  double taught_tolerance_mm = 0.05;
  double taught_tolerance_deg = 0.01;
  // Solved to 1e-9 mm: the numbers written are the solution's to their last digit (1 nm,
  // 0.1 µm), and a signature of zero changes no byte.
  calibration::JointSolveOptions solve{1e-9, 200};
};

struct ProgramCompensation {
  std::vector<TargetReport> targets;  // in the order the motions use them
  std::vector<Edit> edits;            // the rewrite (empty when refused)
  int refused = 0;                    // targets refused (IsRefusal)
  bool written() const { return refused == 0 || allow_outside; }
  bool allow_outside = false;
};

// `volume` may be null (nothing checked against it). Throws std::invalid_argument when the
// controller, the signed robot and the program disagree on the joint count.
ProgramCompensation CompensateProgram(const Program& program, const ControllerModel& controller,
                                      const SignedRobot& robot, const ValidatedVolume* volume,
                                      const CompensationOptions& options = {});

}  // namespace armsig::programs
