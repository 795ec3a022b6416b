#include "io/model_yaml.h"

#include <fmt/format.h>

#include <algorithm>
#include <optional>
#include <set>

#include "calibration/terms.h"
#include "core/text.h"
#include "core/units.h"
#include "io/yaml_reader.h"

namespace armsig::io {

Eigen::Isometry3d ReadRigidTransform(const YamlValue& value, plausible::Quantity translation) {
  const Eigen::Matrix4d m = value.Matrix(4, 4);
  const std::vector<YamlValue> rows = value.List();
  for (int r = 0; r < 3; ++r) rows[r].List()[3].Plausible(translation);
  if ((m.row(3) - Eigen::RowVector4d(0, 0, 0, 1)).norm() > 1e-9) {
    value.Fail("expected a homogeneous transform (last row 0 0 0 1)");
  }
  const Eigen::Matrix3d r = m.topLeftCorner<3, 3>();
  if ((r.transpose() * r - Eigen::Matrix3d::Identity()).norm() > 1e-6 || r.determinant() < 0) {
    value.Fail("expected a rotation in the upper-left 3x3 (orthonormal, det +1)");
  }
  Eigen::Isometry3d t = Eigen::Isometry3d::Identity();
  t.matrix() = m;
  return t;
}

namespace {

using calibration::NongeometricTerm;
using calibration::RobotModel;

// One DH row {d_mm, a_mm, alpha_deg | alpha_gon | alpha_rad}.
Eigen::Isometry3d DhRow(const YamlValue& value) {
  const YamlMap row = value.Map({"d_mm", "a_mm", "alpha_deg", "alpha_gon", "alpha_rad"});
  using plausible::Quantity;
  const double d = row.Has("d_mm") ? row.Find("d_mm")->Plausible(Quantity::kLength) : 0.0;
  const double a = row.Has("a_mm") ? row.Find("a_mm")->Plausible(Quantity::kLength) : 0.0;
  std::optional<double> alpha;
  for (AngleUnit unit : {AngleUnit::kDeg, AngleUnit::kGon, AngleUnit::kRad}) {
    const std::string key = "alpha" + std::string(AngleUnitSuffix(unit));
    if (const auto given = row.Find(key)) {
      if (alpha) given->Fail("give one of alpha_deg, alpha_gon, alpha_rad");
      alpha = ToRad(given->Plausible(Quantity::kAngle, plausible::UnitOf(unit)), unit);
    }
  }
  if (!alpha) row.Fail("missing 'alpha_deg' (or alpha_gon, alpha_rad)");
  // docs/reference/conventions.md: N(i+1) = Tz(d_i)·Tx(a_i)·Rx(α_i).
  Eigen::Isometry3d t = Eigen::Isometry3d::Identity();
  t.translate(Eigen::Vector3d(0, 0, d));
  t.translate(Eigen::Vector3d(a, 0, 0));
  t.rotate(Eigen::AngleAxisd(*alpha, Eigen::Vector3d::UnitX()));
  return t;
}

NongeometricTerm Term(const YamlValue& value, int num_joints) {
  const YamlMap map =
      value.Map({"name", "joint", "basis", "of", "order", "mass_at", "family", "value_rad"});
  NongeometricTerm term;
  using Basis = NongeometricTerm::Basis;
  term.name = map.Required("name", "the term's parameter name").Name();
  term.joint = map.Required("joint", "the joint number it adds to").Integer(1, num_joints) - 1;
  const YamlValue basis = map.Required("basis", "cos, sign_cos, sin or gravity_torque");
  const std::string b = basis.Text();
  if (b == "cos") {
    term.basis = Basis::kCos;
  } else if (b == "sign_cos") {
    term.basis = Basis::kSignCos;
  } else if (b == "sin") {
    term.basis = Basis::kSin;
  } else if (b == "gravity_torque") {
    term.basis = Basis::kGravityTorque;
  } else {
    basis.Fail("expected basis 'cos', 'sign_cos', 'sin' or 'gravity_torque', got " + Quoted(b));
  }
  if (term.basis == Basis::kGravityTorque) {
    // The mass sits at the origin of a joint's frame after this joint, or (n+1) the target.
    if (const auto of = map.Find("of")) of->Fail("a gravity_torque term takes 'mass_at', not 'of'");
    term.mass_at = map.Required("mass_at",
                                "the joint number whose frame carries the unit mass "
                                "(n+1: the target point)")
                       .Integer(term.joint + 2, num_joints + 1) -
                   1;
  } else {
    if (const auto mass = map.Find("mass_at"))
      mass->Fail("only gravity_torque terms take 'mass_at'");
    for (const YamlValue& j : map.Required("of", "a list of joint numbers").List(1)) {
      const int joint = j.Integer(1, num_joints) - 1;
      // The angles summed are distinct joints': [2, 2, 2] would be the third harmonic of one
      // joint under another name, which 'order' says.
      if (std::find(term.of.begin(), term.of.end(), joint) != term.of.end()) {
        j.Fail(fmt::format("joint {} is listed twice in 'of' (expected distinct joints; a "
                           "harmonic of one joint is 'of: [{}]' with 'order: N')",
                           joint + 1, joint + 1));
      }
      term.of.push_back(joint);
    }
  }
  if (const auto order = map.Find("order")) {
    if (term.basis != Basis::kCos && term.basis != Basis::kSin) {
      order->Fail("only cos and sin terms take a harmonic 'order'");
    }
    term.order = order->Integer(1, 64);
  }
  if (const auto family = map.Find("family")) {
    const std::string f = family->Text();
    const auto parsed = calibration::TermFamilyFromName(f);
    if (!parsed) family->Fail("expected family 'compliance' or 'harmonics', got " + Quoted(f));
    term.family = *parsed;
  }
  if (const auto fixed = map.Find("value_rad")) {
    term.fixed_rad =
        fixed->Plausible(plausible::Quantity::kAngle, plausible::UnitOf(AngleUnit::kRad));
  }
  return term;
}

// `tool_mounting: known | fitted`. Known: the target sits exactly at tool_mm on the flange,
// which needs a lever for the flange's turn to show at it.
calibration::ToolMounting ReadToolMounting(const YamlValue& value, const RobotModel& model) {
  const std::string word = value.Text();
  if (word == "fitted") return calibration::ToolMounting::kFitted;
  if (word != "known")
    value.Fail("expected tool_mounting 'known' or 'fitted', got " + Quoted(word));
  if (!(model.tool_mm.norm() >= 1.0)) {
    value.Fail(
        fmt::format("'tool_mounting: known' needs the target at least 1 mm from the last "
                    "joint's frame (tool_mm puts it {:.3g} mm from it): a turn of the flange "
                    "does not move a target without a lever, so the fit could not find it",
                    model.tool_mm.norm()));
  }
  return calibration::ToolMounting::kKnown;
}

RobotModel Parse(const YamlValue& root_value) {
  const YamlMap root =
      root_value.Map({"name", "base", "links", "dh", "tool_mm", "tool_mounting", "flange",
                      "nongeometric", "generated_terms", "gravity", "joint_limits_deg"});
  RobotModel model;
  model.name = root.Has("name") ? root.Find("name")->Name() : "robot";

  if (const auto base = root.Find("base");
      base && !(base->IsScalar() && base->node().Scalar() == "auto")) {
    if (!base->IsList()) base->Fail("expected 'auto' or a 4x4 matrix, got " + base->Describe());
    model.base = ReadRigidTransform(*base, plausible::Quantity::kCoordinate);
  }

  Eigen::Isometry3d folded_tool = Eigen::Isometry3d::Identity();
  const auto links = root.Find("links");
  const auto dh = root.Find("dh");
  if (links && dh) dh->Fail("give either 'links' or 'dh', not both");
  if (links) {
    for (const YamlValue& link : links->List(1))
      model.links.push_back(ReadRigidTransform(link, plausible::Quantity::kLength));
  } else if (dh) {
    std::vector<Eigen::Isometry3d> rows;
    for (const YamlValue& row : dh->List(1)) rows.push_back(DhRow(row));
    for (size_t i = 0; i + 1 < rows.size(); ++i) model.links.push_back(rows[i]);
    folded_tool = rows.back();
  } else {
    root.Fail("missing 'links' (N2…Nn as 4x4 matrices) or 'dh' (one row per joint)");
  }

  const Eigen::Vector3d tool = root.Has("tool_mm")
                                   ? root.Find("tool_mm")->Vector3(plausible::Quantity::kLength)
                                   : Eigen::Vector3d::Zero();
  model.tool_mm = folded_tool * tool;
  model.flange = folded_tool;
  if (const auto flange = root.Find("flange"))
    model.flange = ReadRigidTransform(*flange, plausible::Quantity::kLength);
  if (const auto mounting = root.Find("tool_mounting"))
    model.tool_mounting = ReadToolMounting(*mounting, model);

  const int n = model.num_joints();
  std::set<std::string> names;
  for (const auto& name : model.ParameterNames()) names.insert(name);
  if (const auto terms = root.Find("nongeometric")) {
    for (const YamlValue& node : terms->List()) {
      NongeometricTerm term = Term(node, n);
      if (!names.insert(term.name).second) {
        node.Fail("duplicate parameter name " + Quoted(term.name));
      }
      model.nongeometric.push_back(std::move(term));
    }
  }

  if (const auto gravity = root.Find("gravity")) {
    // Direction only (in the robot's base frame); its length does not matter.
    const Eigen::Vector3d g = gravity->Vector3();
    if (!(g.norm() > 1e-9)) gravity->Fail("expected a non-zero direction [x, y, z]");
    model.gravity_in_base = g.normalized();
  }

  if (const auto limits = root.Find("joint_limits_deg")) {
    const std::vector<YamlValue> pairs = limits->List();
    if (static_cast<int>(pairs.size()) != n) {
      limits->Fail("expected " + std::to_string(n) + " [min, max] pairs (one per joint), got " +
                   limits->Describe());
    }
    for (const YamlValue& pair : pairs) {
      const std::vector<double> lo_hi = pair.Numbers(2);
      for (const YamlValue& limit : pair.List()) {
        limit.Plausible(plausible::Quantity::kJointAngle, plausible::UnitOf(AngleUnit::kDeg));
      }
      if (!(lo_hi[0] < lo_hi[1])) pair.Fail("expected [min, max] with min < max");
      model.joint_min_rad.push_back(ToRad(lo_hi[0], AngleUnit::kDeg));
      model.joint_max_rad.push_back(ToRad(lo_hi[1], AngleUnit::kDeg));
    }
  }
  // Generated last: which terms can move the target is decided over the joint limits.
  if (const auto generated = root.Find("generated_terms")) {
    std::vector<calibration::TermFamily> families;
    for (const YamlValue& node : generated->List()) {
      const std::string f = node.Text();
      const auto family = calibration::TermFamilyFromName(f);
      if (!family) node.Fail("expected 'compliance' or 'harmonics', got " + Quoted(f));
      families.push_back(*family);
    }
    try {
      model = calibration::WithGeneratedTerms(model, families);
    } catch (const std::invalid_argument& e) {
      generated->Fail(e.what());
    }
  }
  return model;
}

}  // namespace

calibration::RobotModel ParseRobotModel(const std::string& yaml_text, const std::string& source) {
  return YamlDocument::Parse(yaml_text, source).Read(Parse);
}

calibration::RobotModel LoadRobotModel(const std::string& path) {
  return YamlDocument::Load(path).Read(Parse);
}

}  // namespace armsig::io
