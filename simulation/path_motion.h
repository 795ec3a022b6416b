// A controller's linear TCP move as the controller computes it: the TCP's position along the
// straight line from where it stands to the target, on a trapezoidal speed profile
// (acceleration, cruise, braking; mm/s², mm/s), its orientation turned in proportion (slerp),
// and the joints by the controller's own inverse kinematics (programs/controller.h, ITS model)
// every `dt_s`, each the solution nearest the one before. The true robot, hidden errors and
// all, then puts its TCP wherever those joints take it: what ISO 9283's path characteristics
// measure. Pure: the joints for VirtualArm::MovePath.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <optional>
#include <string>
#include <vector>

#include "programs/controller.h"

namespace armsig::simulation {

struct LinearPathRequest {
  Eigen::VectorXd start_rad;  // where the arm stands
  Eigen::Isometry3d to_tcp = Eigen::Isometry3d::Identity();  // the target, controller's base
  // A circular move instead (URScript movec): the TCP on the arc from where it stands
  // through this point (its position only) to the target's; the speed along the arc.
  std::optional<Eigen::Vector3d> via_mm;
  Eigen::Isometry3d tool = Eigen::Isometry3d::Identity();    // flange → TCP
  double speed_mm_s = 250.0, acceleration_mm_s2 = 1200.0;
  double dt_s = 0.004;
  // The inverse at every `solve_every`-th sample (and the last), the joints between them
  // interpolated linearly: the TCP then leaves the line by about d² / (8 R) between solved
  // samples d apart (R the arm's lever, ~1 m: 3 µm at 20 ms of 250 mm/s), for a fifth of
  // the work at 5.
  int solve_every = 1;
};

// The joints every dt_s from the start (the first the start, the last at the target);
// nullopt with `why` when an intermediate pose has no solution near the one before, or a
// circular move's three points lie on one line.
std::optional<std::vector<Eigen::VectorXd>> LinearPath(const programs::ControllerModel& controller,
                                                       const LinearPathRequest& request,
                                                       std::string* why = nullptr);

}  // namespace armsig::simulation
