#include "io/model_export.h"

#include <fmt/format.h>
#include <yaml-cpp/yaml.h>

#include <cmath>

#include "calibration/terms.h"
#include "core/units.h"
#include "io/yaml_reader.h"

namespace armsig::io {

namespace {
void EmitMatrix(YAML::Emitter& out, const Eigen::Isometry3d& t) {
  const Eigen::Matrix4d& m = t.matrix();
  out << YAML::Flow << YAML::BeginSeq;
  for (int r = 0; r < 4; ++r) {
    out << YAML::Flow << YAML::BeginSeq;
    for (int c = 0; c < 4; ++c) out << YamlNumber(m(r, c));
    out << YAML::EndSeq;
  }
  out << YAML::EndSeq;
}
}  // namespace

std::string FormatRobotModelYaml(const calibration::RobotModel& model, const std::string& comment) {
  YAML::Emitter out;
  if (!comment.empty()) out << YAML::Comment(comment);
  out << YAML::BeginMap;
  out << YAML::Key << "name" << YAML::Value << model.name;
  out << YAML::Key << "base" << YAML::Value;
  if (model.base) {
    EmitMatrix(out, *model.base);
  } else {
    out << "auto";
  }
  out << YAML::Key << "links" << YAML::Value << YAML::BeginSeq;
  for (const auto& l : model.links) EmitMatrix(out, l);
  out << YAML::EndSeq;
  out << YAML::Key << "tool_mm" << YAML::Value << YAML::Flow << YAML::BeginSeq
      << YamlNumber(model.tool_mm.x()) << YamlNumber(model.tool_mm.y())
      << YamlNumber(model.tool_mm.z()) << YAML::EndSeq;
  if (!model.nongeometric.empty()) {
    out << YAML::Key << "nongeometric" << YAML::Value << YAML::BeginSeq;
    for (const auto& t : model.nongeometric) {
      out << YAML::Flow << YAML::BeginMap;
      out << YAML::Key << "name" << YAML::Value << t.name;
      out << YAML::Key << "joint" << YAML::Value << t.joint + 1;
      using Basis = calibration::NongeometricTerm::Basis;
      static const char* kBasis[] = {"cos", "sign_cos", "sin", "gravity_torque"};
      out << YAML::Key << "basis" << YAML::Value << kBasis[static_cast<int>(t.basis)];
      if (t.basis == Basis::kGravityTorque) {
        out << YAML::Key << "mass_at" << YAML::Value << t.mass_at + 1;
      } else {
        out << YAML::Key << "of" << YAML::Value << YAML::Flow << YAML::BeginSeq;
        for (int j : t.of) out << j + 1;
        out << YAML::EndSeq;
      }
      if (t.order != 1) out << YAML::Key << "order" << YAML::Value << t.order;
      if (t.family != calibration::TermFamily::kModel) {
        out << YAML::Key << "family" << YAML::Value << calibration::TermFamilyName(t.family);
      }
      out << YAML::Key << "value_rad" << YAML::Value << YamlNumber(t.fixed_rad);
      out << YAML::EndMap;
    }
    out << YAML::EndSeq;
  }
  if (model.gravity_in_base != -Eigen::Vector3d::UnitZ()) {
    out << YAML::Key << "gravity" << YAML::Value << YAML::Flow << YAML::BeginSeq
        << YamlNumber(model.gravity_in_base.x()) << YamlNumber(model.gravity_in_base.y())
        << YamlNumber(model.gravity_in_base.z()) << YAML::EndSeq;
  }
  if (model.joint_min_rad.size() == static_cast<size_t>(model.num_joints())) {
    out << YAML::Key << "joint_limits_deg" << YAML::Value << YAML::Flow << YAML::BeginSeq;
    for (int i = 0; i < model.num_joints(); ++i) {
      out << YAML::Flow << YAML::BeginSeq
          << YamlNumber(FromRad(model.joint_min_rad[i], AngleUnit::kDeg))
          << YamlNumber(FromRad(model.joint_max_rad[i], AngleUnit::kDeg)) << YAML::EndSeq;
    }
    out << YAML::EndSeq;
  }
  out << YAML::EndMap;
  return std::string(out.c_str()) + "\n";
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
