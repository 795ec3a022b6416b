// Capture plans: the joint configurations to measure, in order.
#pragma once

#include <Eigen/Core>
#include <optional>
#include <string>
#include <vector>

#include "calibration/model.h"
#include "db/stored_json.h"

namespace armsig::acquisition {

// The fastest linear move a plan may ask for: no industrial arm's TCP goes 10 m/s.
inline constexpr double kMostLinearSpeedMmS = 10000.0;

struct PlannedConfiguration {
  std::string label;
  Eigen::VectorXd joints_rad;
  // Where the plan means the target to be, in the robot frame (mm), when it says so (the
  // x_mm, y_mm, z_mm columns of an ISO 9283 plan): kept with the session, so its
  // evaluation knows the commanded positions. Capture does not use it.
  std::optional<Eigen::Vector3d> target_mm{};
  // How the robot gets there from the configuration before: a linear move (the TCP on a
  // straight line, the controller's own path) at this TCP speed, mm/s (the `speed_mm_s`
  // column of an ISO 9283 path plan, measured on the move); a joint move when absent.
  std::optional<double> linear_speed_mm_s{};
  // The via point of a circular move (URScript movec) to the next configuration: not stopped
  // at; the TCP passes through its position on the arc (the `motion` column's "via"; the row
  // after it, "circular", carries the speed).
  bool via = false;
};
using Plan = std::vector<PlannedConfiguration>;

// "pose,q1_deg,…,qn_deg" (any angle unit suffix), with the target x_mm, y_mm, z_mm when
// the file gives all three, speed_mm_s (a linear move to that row; empty: a joint move) and
// motion (linear, via or circular: a via row and the circular row after it make one circular
// move) when it has those columns. Throws InputError with line numbers.
Plan ReadPlanCsv(const std::string& path, int num_joints);
// The same, refusing a configuration outside the model's joint limits (when it has them):
// the plan is sent to the robot, and a limit is where it stops short or faults.
Plan ReadPlanCsv(const std::string& path, const calibration::RobotModel& model);
std::string FormatPlanCsv(const Plan& plan);

// `count` well-spread configurations within the joint limits: the D-optimal choice
// (calibration selection) among `candidates` random ones.
Plan WellSpreadPlan(const calibration::RobotModel& model, int count, int candidates, unsigned seed);

// The paper's single-joint rotation test: joint `joint` (0-based) swept in `steps`
// from the `start` posture over [lo, hi].
Plan SingleJointPlan(const Eigen::VectorXd& start, int joint, double lo_rad, double hi_rad,
                     int steps);

// "FILE.csv", "auto:N" or "single-joint:J:STEPS" (J 1-based; sweep ±150° or the limits).
// `seed` draws auto:N's candidates: the same seed, the same configurations (nights that
// compare alike); another seed, another well-spread set.
inline constexpr unsigned kDefaultPlanSeed = 7;
Plan MakePlan(const std::string& spec, const calibration::RobotModel& model,
              unsigned seed = kDefaultPlanSeed);

// Whether any configuration is reached by a linear move (an ISO 9283 path plan).
bool HasLinearMoves(const Plan& plan);

// JSON array of {label, joints_rad[, target_mm][, linear_speed_mm_s]} (stored with the session so it can be
// resumed).
std::string PlanToJson(const Plan& plan);
// A plan as stored with its session (sessions.plan_json): input like a file, refused with an
// InputError naming `where` when it is not such a list (db/stored_json.h).
Plan PlanFromJson(const std::string& json,
                  const db::JsonCell& where = {"the database", "sessions", 0, "plan_json"});

}  // namespace armsig::acquisition
