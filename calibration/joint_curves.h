// Joint curves: each joint's angle error as a smooth function of its own encoder angle,
// the first stage of the residual map (calibration/residual_map.h).
//
// Model. The true angle of joint j is its encoder angle plus δθ_j(θ̄_j), with
//   δθ_j(θ̄) = Σ_m v_jm B((θ̄ mod 2π)/Δ − m),   Δ = 2π / knots,
// B the centred cubic B-spline: a periodic cubic spline with `knots` evenly spaced knots per
// turn (4 of its bumps are non-zero at any angle). It is what an encoder's or a gear's
// periodic error is, whatever its orders: on the UR10 (series C) the residual of the
// geometric fit carries structure a few degrees long on every joint, which no low-order
// harmonic (calibration/terms.h) and no kernel over all joints together follows.
//
// A curve only knows the angles it was fitted on: `measured` marks, per joint, the knots
// with data under them at the fit (the spline's penalty bridges a gap between measured
// arcs by the smoothest curve, not by zero). A configuration with some joint at a knot that
// was not measured is outside the curves' support; the correction is still applied there
// (it is the smooth bridge) and the caller flags it.
#pragma once

#include <array>
#include <vector>

namespace armsig::calibration {

struct JointCurvesData {
  int knots = 0;                                // per turn; 0: no curves
  std::vector<int> joints;                      // 0-based joints with a curve, ascending
  std::vector<std::vector<double>> values_rad;  // per curve joint: one coefficient per knot
  std::vector<std::vector<int>> measured;       // per curve joint: 1 where the knot had data
  double smoothing = 0.0;  // the penalty chosen (relative to the data's mean weight)

  bool empty() const { return knots == 0; }
};

// The bumps that are non-zero at an angle: indices first … first+3 (mod knots) with their
// weights (summing to 1), and the knot nearest the angle.
struct CurveSpan {
  int first = 0;
  std::array<double, 4> weight{};
  int nearest = 0;
};
CurveSpan CurveSpanAt(int knots, double angle_rad);

// Throws std::invalid_argument naming what is inconsistent (sizes, a joint out of range,
// non-finite values).
void CheckJointCurves(const JointCurvesData& curves, int num_joints);

// corrected_rad = joints_rad + δθ(joints_rad) for all num_joints joints (joints without a
// curve copied). True when every curve joint's angle is at a measured knot.
bool ApplyJointCurves(const JointCurvesData& curves, int num_joints, const double* joints_rad,
                      double* corrected_rad);

}  // namespace armsig::calibration
