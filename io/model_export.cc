#include "io/model_export.h"

#include <fmt/format.h>
#include <yaml-cpp/yaml.h>

#include <cmath>
#include <initializer_list>
#include <string_view>
#include <utility>

#include "calibration/terms.h"
#include "core/text.h"
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
  if (model.known_mounting()) {
    out << YAML::Key << "tool_mounting" << YAML::Value
        << calibration::ToString(model.tool_mounting);
  }
  if (!model.flange.isApprox(Eigen::Isometry3d::Identity(), 1e-15)) {
    out << YAML::Key << "flange" << YAML::Value;
    EmitMatrix(out, model.flange);
  }
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

namespace {

// The URDF is written through this one writer: every attribute value and comment is escaped
// by construction, so a name holding `"><link name="injected"/><!-- ` stays text.
class XmlWriter {
 public:
  using Attributes = std::initializer_list<std::pair<std::string_view, std::string>>;

  XmlWriter() { out_ = "<?xml version=\"1.0\"?>\n"; }
  void Open(std::string_view tag, Attributes attributes = {}) {
    Start(tag, attributes);
    out_ += ">\n";
    ++depth_;
  }
  void Empty(std::string_view tag, Attributes attributes = {}) {
    Start(tag, attributes);
    out_ += "/>\n";
  }
  void Close(std::string_view tag) {
    --depth_;
    Indent();
    out_ += "</" + std::string(tag) + ">\n";
  }
  // XML comments may not hold "--" nor end in "-"; control characters are shown escaped.
  // Markup characters are escaped too: entities mean nothing inside a comment, but no
  // tool that scans the file for tags (a grep, a naive parser) finds an element in it.
  void Comment(std::string_view text) {
    std::string body = Escaped(text);
    for (size_t at; (at = body.find("--")) != std::string::npos;) body.replace(at, 2, "- -");
    if (!body.empty() && body.back() == '-') body += ' ';
    Indent();
    out_ += "<!-- " + body + " -->\n";
  }
  const std::string& str() const { return out_; }

 private:
  static std::string Escaped(std::string_view value) { return EscapeMarkup(Printable(value)); }
  void Start(std::string_view tag, Attributes attributes) {
    Indent();
    out_ += "<" + std::string(tag);
    for (const auto& [name, value] : attributes) {
      out_ += " " + std::string(name) + "=\"" + Escaped(value) + "\"";
    }
  }
  void Indent() { out_ += std::string(2 * depth_, ' '); }

  std::string out_;
  int depth_ = 0;
};

}  // namespace

std::string FormatUrdf(const calibration::RobotModel& model, std::string* warning) {
  XmlWriter xml;
  // URDF rpy: R = Rz(yaw)·Ry(pitch)·Rx(roll), fixed axes.
  auto origin = [&xml](const Eigen::Isometry3d& t) {
    const Eigen::Vector3d ypr = t.linear().eulerAngles(2, 1, 0);
    const Eigen::Vector3d xyz = t.translation() / 1000.0;
    xml.Empty("origin", {{"xyz", fmt::format("{:.9f} {:.9f} {:.9f}", xyz.x(), xyz.y(), xyz.z())},
                         {"rpy", fmt::format("{:.12f} {:.12f} {:.12f}", ypr(2), ypr(1), ypr(0))}});
  };
  xml.Comment("armsig: " + model.name);
  xml.Open("robot", {{"name", model.name}});
  bool h_terms = false;
  for (const auto& t : model.nongeometric) h_terms |= t.fixed_rad != 0.0;
  if (h_terms) {
    xml.Comment(
        "the model's non-geometric terms (joint angles corrected by functions of other joints) "
        "are not part of URDF");
    if (warning)
      *warning = "non-geometric terms (h) are left out of the URDF: apply them in the controller";
  }
  xml.Empty("link", {{"name", "base_link"}});
  const int n = model.num_joints();
  const bool limits = model.joint_min_rad.size() == static_cast<size_t>(n);
  for (int i = 0; i < n; ++i) {
    const Eigen::Isometry3d before =
        i == 0 ? model.base.value_or(Eigen::Isometry3d::Identity()) : model.links[i - 1];
    xml.Empty("link", {{"name", fmt::format("link{}", i + 1)}});
    xml.Open("joint", {{"name", fmt::format("joint{}", i + 1)}, {"type", "revolute"}});
    xml.Empty("parent", {{"link", i == 0 ? std::string("base_link") : fmt::format("link{}", i)}});
    xml.Empty("child", {{"link", fmt::format("link{}", i + 1)}});
    origin(before);
    xml.Empty("axis", {{"xyz", "0 0 1"}});
    xml.Empty("limit", {{"lower", fmt::format("{:.6f}", limits ? model.joint_min_rad[i] : -M_PI)},
                        {"upper", fmt::format("{:.6f}", limits ? model.joint_max_rad[i] : M_PI)},
                        {"effort", "0"},
                        {"velocity", "0"}});
    xml.Close("joint");
  }
  Eigen::Isometry3d tool = Eigen::Isometry3d::Identity();
  tool.translation() = model.tool_mm;
  xml.Empty("link", {{"name", "tool0"}});
  xml.Open("joint", {{"name", "tool_point"}, {"type", "fixed"}});
  xml.Empty("parent", {{"link", fmt::format("link{}", n)}});
  xml.Empty("child", {{"link", "tool0"}});
  origin(tool);
  xml.Close("joint");
  xml.Close("robot");
  return xml.str();
}

}  // namespace armsig::io
