// Arms for the virtual cells that check robot programs: six-axis industrial arms of the
// size of a KUKA KR 16 and an ABB IRB 4600, written as Denavit–Hartenberg rows with joint
// offsets in the controllers' own joint conventions as far as a program needs them (a wrist
// whose axes meet in a point; for the KUKA the arm stretched near A3 = 0 and lifted by a
// negative A2; for the ABB the lower arm upright and the upper arm level at all joints zero).
// Sizes from the makers' data sheets; not their calibrated kinematics.
#pragma once

#include <string>
#include <utility>
#include <vector>

#include "calibration/model.h"

namespace armsig::simulation {

struct DhRow {
  double theta_deg, d_mm, a_mm, alpha_deg;
};

// N(i+1) = Rz(θ_i)·Tz(d_i)·Tx(a_i)·Rx(α_i); the last row is the flange, where the model's
// calibration point sits; joint limits in degrees, one pair per joint.
calibration::RobotModel DhArm(const std::string& name, const std::vector<DhRow>& rows,
                              const std::vector<std::pair<double, double>>& limits_deg);

// 675 mm base, 260 mm shoulder offset, 680 mm lower arm, 35 mm elbow offset, 670 mm upper
// arm, 158 mm to the flange (KR 16-2 data sheet).
calibration::RobotModel KukaKr16Like();
// 495 mm base, 175 mm shoulder offset, 900 mm lower arm, 175 mm elbow offset, 960 mm upper
// arm, 135 mm to the flange (IRB 4600-40/2.55 data sheet).
calibration::RobotModel AbbIrb4600Like();

}  // namespace armsig::simulation
