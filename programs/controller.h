// The controller's own kinematics: what a robot controller does with a program's targets.
// A Cartesian target is turned into joints by the controller's inverse kinematics on ITS
// model — the nominal one (KUKA, ABB without absolute accuracy), or for a Universal Robots
// arm its factory calibration (the primary interface's KinematicsInfo, calibration.conf) —
// choosing among the solutions by the configuration the program states (KUKA Status and
// Turn, ABB confdata) or, for a UR, the one nearest the joints it starts from. A joint target
// is where that model puts the TCP at those joints.
//
// Joint angles are the controller's own (the model file is written in the controller's joint
// convention: UR's joint zero, KUKA's A1…A6, ABB's axes 1…6), in rad.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <array>
#include <optional>
#include <string>

#include "calibration/model.h"
#include "programs/program.h"

namespace armsig::programs {

enum class ControllerKind { kUniversalRobots, kKuka, kAbb, kGeneric };
const char* ToString(ControllerKind kind);

struct ControllerModel {
  ControllerKind kind = ControllerKind::kGeneric;
  // The controller's chain (links N2…Nn, base identity: the controller's base frame); its
  // parameters are all zero and its non-geometric terms unused: a controller knows none.
  calibration::RobotModel model;
  Eigen::Isometry3d flange = Eigen::Isometry3d::Identity();  // tool0 in the last link frame
  std::string description;  // "nominal model ur10", "UR factory calibration (KinematicsInfo)"
  // Joint 3's angle with the arm stretched (the wrist centre on the line from joint 2
  // through joint 3), rad: KUKA's φ of Status bit 1, the ABB lower-arm boundary of cfx.
  double stretched_q3_rad = 0.0;
  // The wrist centre's direction in the frame turning with joint 1 at the zero
  // configuration, across joint 1's axis: "in front" (KUKA basic area, ABB in front of axis 1).
  Eigen::Vector3d front = Eigen::Vector3d::UnitX();
  int num_joints() const { return model.num_joints(); }
};

// The controller's model from a robot model (its nominal links, its flange).
ControllerModel NominalController(const calibration::RobotModel& model, ControllerKind kind,
                                  std::string description);

// A Universal Robots arm's own kinematics as its controller reports them (primary
// interface KinematicsInfo; the values of calibration.conf added to the nominal DH):
// T_i = Rz(θ_i + q_i)·Tz(d_i)·Tx(a_i)·Rx(α_i), metres and radians, six of each.
struct UrKinematics {
  std::array<double, 6> theta{}, a{}, d{}, alpha{};
  std::string source;  // where they came from (a file, a session)
};
ControllerModel UrController(const UrKinematics& kinematics);

// Base → flange, and base → TCP for a tool (flange → TCP), at the joints.
Eigen::Isometry3d FlangePose(const ControllerModel& controller, const Eigen::VectorXd& joints_rad);
Eigen::Isometry3d TcpPose(const ControllerModel& controller, const Eigen::VectorXd& joints_rad,
                          const Eigen::Isometry3d& tool);

// The configuration of a joint vector in the controllers' own terms.
struct ArmConfiguration {
  bool overhead = false;  // the wrist centre behind joint 1's axis (KUKA Status bit 0)
  bool elbow = false;     // joint 3 at or past the stretched angle (KUKA Status bit 1)
  bool wrist = false;     // joint 5 at or below 0 (KUKA Status bit 2)
  int kuka_status = 0;    // bits 0–2 as above
  int kuka_turn = 0;      // bit i set when axis i+1 is below 0
  // ABB confdata: cf1, cf4, cf6 the quadrant of axes 1, 4, 6 (floor(θ / 90°)); cfx =
  // 4·(wrist centre behind axis 1) + 2·(on the other side of the lower arm than at the
  // zero configuration) + (axis 5 negative).
  std::array<int, 4> abb_cf{};
};
ArmConfiguration ConfigurationOf(const ControllerModel& controller, const Eigen::VectorXd& joints_rad);

// Whether joints agree with what a target states (only the parts it states).
bool Matches(const StatedConfiguration& stated, const ArmConfiguration& configuration);
// "S 6 T 50", "cf [0,-1,0,1]", or "" when nothing is stated.
std::string Describe(const StatedConfiguration& stated);

struct InverseRequest {
  Eigen::Isometry3d tcp = Eigen::Isometry3d::Identity();   // in the controller's base
  Eigen::Isometry3d tool = Eigen::Isometry3d::Identity();  // flange → TCP
  StatedConfiguration stated;                              // KUKA S/T, ABB cf (near_target unused)
  std::optional<Eigen::VectorXd> near_rad;  // choose the solution nearest these joints
};

struct InverseSolution {
  std::optional<Eigen::VectorXd> joints_rad;
  std::string why;  // when there is none: out of reach, or no solution in the stated configuration
  bool reachable = false;  // some solution exists, whatever its configuration
};

// The controller's inverse: the joints (within the model's limits) that put the TCP at the
// pose, in the stated configuration, nearest `near_rad` among them (turns of 2π included for
// joints whose range allows them). Numerical, from seeds spread over the configurations.
InverseSolution ControllerInverse(const ControllerModel& controller, const InverseRequest& request);

}  // namespace armsig::programs
