#include "calibration/joint_curves.h"

#include <cmath>
#include <stdexcept>
#include <string>

namespace armsig::calibration {

namespace {

constexpr double kTwoPi = 6.283185307179586476925286766559;

void Require(bool condition, const std::string& what) {
  if (!condition) throw std::invalid_argument("joint curves: " + what);
}

int Wrap(long index, int knots) {
  const long m = index % knots;
  return static_cast<int>(m < 0 ? m + knots : m);
}

}  // namespace

CurveSpan CurveSpanAt(int knots, double angle_rad) {
  const double u = angle_rad / (kTwoPi / knots);
  const double floor_u = std::floor(u);
  const double t = u - floor_u;
  const long i = static_cast<long>(floor_u);
  CurveSpan s;
  s.first = Wrap(i - 1, knots);
  const double t2 = t * t, t3 = t2 * t, s1 = 1.0 - t;
  s.weight = {s1 * s1 * s1 / 6.0, (3.0 * t3 - 6.0 * t2 + 4.0) / 6.0,
              (-3.0 * t3 + 3.0 * t2 + 3.0 * t + 1.0) / 6.0, t3 / 6.0};
  s.nearest = Wrap(static_cast<long>(std::lround(u)), knots);
  return s;
}

void CheckJointCurves(const JointCurvesData& c, int num_joints) {
  if (c.empty()) {
    Require(c.joints.empty() && c.values_rad.empty() && c.measured.empty(),
            "values without knots");
    return;
  }
  Require(c.knots >= 4, "at least 4 knots per turn");
  Require(!c.joints.empty(), "no curve joints");
  Require(c.values_rad.size() == c.joints.size() && c.measured.size() == c.joints.size(),
          "one curve and one measured list per joint");
  for (size_t k = 0; k < c.joints.size(); ++k) {
    Require(c.joints[k] >= 0 && c.joints[k] < num_joints, "curve joint out of range");
    Require(k == 0 || c.joints[k] > c.joints[k - 1], "curve joints ascending, each once");
    Require(static_cast<int>(c.values_rad[k].size()) == c.knots &&
                static_cast<int>(c.measured[k].size()) == c.knots,
            "one value and one measured flag per knot");
    for (double v : c.values_rad[k]) Require(std::isfinite(v), "values must be finite");
    for (int m : c.measured[k]) Require(m == 0 || m == 1, "measured flags are 0 or 1");
  }
  Require(std::isfinite(c.smoothing) && c.smoothing >= 0, "smoothing must be ≥ 0");
}

bool ApplyJointCurves(const JointCurvesData& c, int num_joints, const double* joints_rad,
                      double* corrected_rad) {
  for (int j = 0; j < num_joints; ++j) corrected_rad[j] = joints_rad[j];
  bool inside = true;
  for (size_t k = 0; k < c.joints.size(); ++k) {
    const int j = c.joints[k];
    const CurveSpan s = CurveSpanAt(c.knots, joints_rad[j]);
    double delta = 0.0;
    for (int b = 0; b < 4; ++b) delta += s.weight[b] * c.values_rad[k][(s.first + b) % c.knots];
    corrected_rad[j] += delta;
    inside = inside && c.measured[k][s.nearest] == 1;
  }
  return inside;
}

}  // namespace armsig::calibration
