#include "calibration/signature_limits.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace armsig::calibration {

void SignatureLimits::Check() const {
  for (double v : {link_mm, base_link_mm, tool_mm, angle_rad, term_rad, scale}) {
    if (!(v > 0.0) || !std::isfinite(v)) {
      throw std::invalid_argument("signature limits must be positive and finite");
    }
  }
}

std::string ImplausibleValue::Describe() const {
  return fmt::format("{} ({}): {:+.4g} {} (limit {:.4g} {})", what, name, value, unit, limit,
                     unit);
}

namespace {

// The arm's reach from the base (mm): the nominal links' and the tool's lengths summed, an
// upper bound of any mass's lever.
double ReachMm(const RobotModel& model) {
  double reach = model.tool_mm.norm();
  for (const auto& link : model.links) reach += link.translation().norm();
  return reach;
}

// The largest |basis| a term reaches.
double BasisBound(const RobotModel& model, const NongeometricTerm& term) {
  return term.basis == NongeometricTerm::Basis::kGravityTorque ? ReachMm(model) / 1000.0 : 1.0;
}

}  // namespace

std::vector<ImplausibleValue> ImplausibleParameters(const RobotModel& model,
                                                    const Eigen::VectorXd& params,
                                                    const std::vector<int>& identified,
                                                    const SignatureLimits& limits) {
  limits.Check();
  const auto names = model.ParameterNames();
  const int n = model.num_joints();
  std::vector<ImplausibleValue> out;
  static const char* kAxis[] = {"x", "y", "z"};
  for (int k : identified) {
    if (k < 0 || k >= model.num_parameters()) continue;
    const double v = params(k);
    ImplausibleValue bad;
    bad.parameter = k;
    bad.name = names[k];
    if (k < 6 * n) {
      const int joint = k / 6 + 1, p = k % 6;
      if (p < 3) {
        bad.what = fmt::format("joint {} frame offset along {}", joint, kAxis[p]);
        bad.value = v;
        bad.limit = joint == 1   ? limits.base_link_mm
                    : joint == n ? limits.tool_mm
                                 : limits.link_mm;
        bad.unit = "mm";
      } else {
        bad.what = p == 5 ? fmt::format("joint {} zero", joint)
                          : fmt::format("joint {} axis tilt about {}", joint, kAxis[p - 3]);
        bad.value = v * 1e3;
        bad.limit = limits.angle_rad * 1e3;
        bad.unit = "mrad";
      }
    } else if (k < model.tool_index() + 3) {
      bad.what = fmt::format("tool offset along {}", kAxis[k - model.tool_index()]);
      bad.value = v;
      bad.limit = limits.tool_mm;
      bad.unit = "mm";
    } else if (k < model.num_geometric()) {
      bad.what = fmt::format("flange turn about axis u{} across the lever",
                             k - model.flange_turn_index() + 1);
      bad.value = v * 1e3;
      bad.limit = limits.angle_rad * 1e3;
      bad.unit = "mrad";
    } else {
      const auto& term = model.nongeometric[k - model.num_geometric()];
      bad.what = fmt::format("term {}'s largest turn of joint {}", term.name, term.joint + 1);
      bad.value = v * BasisBound(model, term) * 1e3;
      bad.limit = limits.term_rad * 1e3;
      bad.unit = "mrad";
    }
    if (!(std::abs(bad.value) <= bad.limit)) out.push_back(bad);  // NaN is implausible too
  }
  std::sort(out.begin(), out.end(), [](const ImplausibleValue& a, const ImplausibleValue& b) {
    return std::abs(a.value) / a.limit > std::abs(b.value) / b.limit;
  });
  return out;
}

bool PlausibleCauseSize(double size, bool angle, bool scale, const SignatureLimits& limits) {
  if (!std::isfinite(size)) return false;
  if (scale) return std::abs(size) <= limits.scale;
  return std::abs(size) <= (angle ? limits.angle_rad : std::max(limits.link_mm, limits.tool_mm));
}

}  // namespace armsig::calibration
