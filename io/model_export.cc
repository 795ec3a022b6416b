#include "io/model_export.h"

#include <fmt/format.h>

#include <cmath>

namespace armsig::io {

namespace {
std::string Matrix(const Eigen::Isometry3d& t) {
  const Eigen::Matrix4d& m = t.matrix();
  std::string out = "[";
  for (int r = 0; r < 4; ++r) {
    out += fmt::format("{}[{:.12g}, {:.12g}, {:.12g}, {:.12g}]", r ? ", " : "", m(r, 0), m(r, 1),
                       m(r, 2), m(r, 3));
  }
  return out + "]";
}
}  // namespace

std::string FormatRobotModelYaml(const calibration::RobotModel& model, const std::string& comment) {
  std::string out;
  if (!comment.empty()) out += "# " + comment + "\n";
  out += "name: " + model.name + "\n";
  out += "base: " + (model.base ? Matrix(*model.base) : std::string("auto")) + "\n";
  out += "links:\n";
  for (const auto& l : model.links) out += "  - " + Matrix(l) + "\n";
  out += fmt::format("tool_mm: [{:.12g}, {:.12g}, {:.12g}]\n", model.tool_mm.x(), model.tool_mm.y(),
                     model.tool_mm.z());
  if (!model.nongeometric.empty()) {
    out += "nongeometric:\n";
    for (const auto& t : model.nongeometric) {
      std::string of;
      for (size_t k = 0; k < t.of.size(); ++k) of += (k ? ", " : "") + std::to_string(t.of[k] + 1);
      out += fmt::format("  - {{name: {}, joint: {}, basis: {}, of: [{}], value_rad: {:.12g}}}\n",
                         t.name, t.joint + 1,
                         t.basis == calibration::NongeometricTerm::Basis::kCos ? "cos" : "sign_cos",
                         of, t.fixed_rad);
    }
  }
  if (model.joint_min_rad.size() == static_cast<size_t>(model.num_joints())) {
    out += "joint_limits_deg: [";
    for (int i = 0; i < model.num_joints(); ++i) {
      out += fmt::format("{}[{:.6g}, {:.6g}]", i ? ", " : "", model.joint_min_rad[i] * 180 / M_PI,
                         model.joint_max_rad[i] * 180 / M_PI);
    }
    out += "]\n";
  }
  return out;
}

std::string FormatUrdf(const calibration::RobotModel& model, std::string* warning) {
  auto origin = [](const Eigen::Isometry3d& t) {
    // URDF rpy: R = Rz(yaw)·Ry(pitch)·Rx(roll), fixed axes.
    const Eigen::Vector3d ypr = t.linear().eulerAngles(2, 1, 0);
    const Eigen::Vector3d xyz = t.translation() / 1000.0;
    return fmt::format("<origin xyz=\"{:.9f} {:.9f} {:.9f}\" rpy=\"{:.12f} {:.12f} {:.12f}\"/>",
                       xyz.x(), xyz.y(), xyz.z(), ypr(2), ypr(1), ypr(0));
  };
  std::string out = "<?xml version=\"1.0\"?>\n<!-- armsig: " + model.name + " -->\n<robot name=\"" +
                    model.name + "\">\n";
  bool h_terms = false;
  for (const auto& t : model.nongeometric) h_terms |= t.fixed_rad != 0.0;
  if (h_terms) {
    out +=
        "  <!-- the model's non-geometric terms (joint angles corrected by functions of other "
        "joints) are not part of URDF -->\n";
    if (warning)
      *warning = "non-geometric terms (h) are left out of the URDF: apply them in the controller";
  }
  out += "  <link name=\"base_link\"/>\n";
  const int n = model.num_joints();
  for (int i = 0; i < n; ++i) {
    const Eigen::Isometry3d before =
        i == 0 ? model.base.value_or(Eigen::Isometry3d::Identity()) : model.links[i - 1];
    out += fmt::format("  <link name=\"link{}\"/>\n", i + 1);
    out += fmt::format(
        "  <joint name=\"joint{}\" type=\"revolute\">\n    <parent link=\"{}\"/>\n    <child "
        "link=\"link{}\"/>\n"
        "    {}\n    <axis xyz=\"0 0 1\"/>\n",
        i + 1, i == 0 ? "base_link" : "link" + std::to_string(i), i + 1, origin(before));
    const bool limits = model.joint_min_rad.size() == static_cast<size_t>(n);
    out += fmt::format(
        "    <limit lower=\"{:.6f}\" upper=\"{:.6f}\" effort=\"0\" velocity=\"0\"/>\n  </joint>\n",
        limits ? model.joint_min_rad[i] : -M_PI, limits ? model.joint_max_rad[i] : M_PI);
  }
  Eigen::Isometry3d tool = Eigen::Isometry3d::Identity();
  tool.translation() = model.tool_mm;
  out += "  <link name=\"tool0\"/>\n";
  out += fmt::format(
      "  <joint name=\"tool_point\" type=\"fixed\">\n    <parent link=\"link{}\"/>\n    <child "
      "link=\"tool0\"/>\n    {}\n  </joint>\n",
      n, origin(tool));
  return out + "</robot>\n";
}

}  // namespace armsig::io
