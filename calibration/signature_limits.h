// What an arm signature may say about a robot. A fitted set whose parameters move a link by
// centimetres, tilt an axis by degrees or put an instrument's scale off by a tenth is not a
// calibration of that robot: it is another robot's data, another tool, or other units
// (radians read as degrees, metres as millimetres), fitted by a least-squares solver that
// will always find *some* numbers. Real robots deviate from their drawings by tenths of a
// millimetre to a few millimetres and by a few milliradians (the paper's PUMA 760: at most
// 0.9 mm and 15.2 mrad; the real UR10 within 1 mm and 1.5 mrad apart from its base and tool
// offsets, docs/explanation/never-worse.md); the limits
// below leave a wide margin above that and stay far below what a mix-up produces.
#pragma once

#include <Eigen/Core>
#include <string>
#include <vector>

#include "calibration/model.h"

namespace armsig::calibration {

struct SignatureLimits {
  // A link's length or offset (a, b, c of joints 2…n−1), mm.
  double link_mm = 10.0;
  // The first joint's offsets also carry what is left of the base alignment (base: auto),
  // and the last joint's offsets and the tool's carry a tool length a lab measured by hand:
  // wider bounds, mm. (The real UR10, series C: b1 +14.2 mm, c6 −15.9 mm — its T-Mac sits
  // that much closer to the flange than the nominal 109 mm — every other offset within 1 mm.)
  double base_link_mm = 30.0;
  double tool_mm = 30.0;
  // An axis tilt (α, β) or a joint's zero (γ), rad.
  double angle_rad = 0.05;  // 50 mrad, 2.9°
  // A non-geometric term's coefficient: the most its correction can turn its joint (rad,
  // over the basis's range: |coefficient| × max |basis|; a gravity torque's basis is in
  // unit-mass metres, bounded here by the arm's reach).
  double term_rad = 0.02;
  // An instrument's scale (a length change proportional to the distance), as a fraction.
  double scale = 1e-3;  // 1,000 ppm
  void Check() const;
};

struct ImplausibleValue {
  int parameter = -1;  // model index (−1: the scale)
  std::string name;    // "a3", "gamma2", "h1", "scale"
  std::string what;    // "link 3 offset a", "joint 2 zero", …
  double value = 0.0, limit = 0.0;  // in `unit`
  std::string unit;                 // mm | mrad | ppm
  // "joint 2 zero: +105,000 mrad (limit 50 mrad)"
  std::string Describe() const;
};

// The identified parameters of a set beyond the limits, largest excess first. `params` are
// the set's values (deviations from the nominal model); unidentified ones are ignored.
std::vector<ImplausibleValue> ImplausibleParameters(const RobotModel& model,
                                                    const Eigen::VectorXd& params,
                                                    const std::vector<int>& identified,
                                                    const SignatureLimits& limits = {});

// Whether a single-cause size is physically plausible: `angle` in rad, else mm, or (scale)
// a fraction. Used to keep drift explanations to what a robot can do.
bool PlausibleCauseSize(double size, bool angle, bool scale, const SignatureLimits& limits = {});

}  // namespace armsig::calibration
