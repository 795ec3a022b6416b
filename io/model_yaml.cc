#include "io/model_yaml.h"

#include <yaml-cpp/yaml.h>

#include <cmath>
#include <set>

#include "core/error.h"
#include "core/units.h"
#include "io/atomic_file.h"

namespace armsig::io {

namespace {

using calibration::NongeometricTerm;
using calibration::RobotModel;

class Parser {
 public:
  explicit Parser(std::string source) : source_(std::move(source)) {}

  SourceLocation Where(const YAML::Node& node, const std::string& key = "") const {
    const YAML::Mark mark = node.Mark();
    return {source_, mark.line >= 0 ? mark.line + 1 : 0, mark.column >= 0 ? mark.column + 1 : 0,
            key};
  }

  [[noreturn]] void Fail(const YAML::Node& node, const std::string& key,
                         const std::string& message) const {
    throw InputError(Where(node, key), message);
  }

  double Number(const YAML::Node& node, const std::string& key) const {
    if (!node || !node.IsScalar()) Fail(node, key, "expected a number");
    double value = 0.0;
    if (!YAML::convert<double>::decode(node, value) || !std::isfinite(value)) {
      Fail(node, key, "expected a finite number, got '" + node.Scalar() + "'");
    }
    return value;
  }

  int Integer(const YAML::Node& node, const std::string& key) const {
    int value = 0;
    if (!node || !node.IsScalar() || !YAML::convert<int>::decode(node, value)) {
      Fail(node, key, "expected an integer");
    }
    return value;
  }

  Eigen::Isometry3d Matrix4(const YAML::Node& node, const std::string& key) const {
    if (!node.IsSequence() || node.size() != 4) Fail(node, key, "expected a 4x4 matrix (4 rows)");
    Eigen::Matrix4d m;
    for (int r = 0; r < 4; ++r) {
      const YAML::Node row = node[r];
      if (!row.IsSequence() || row.size() != 4) Fail(row, key, "expected a row of 4 numbers");
      for (int c = 0; c < 4; ++c) m(r, c) = Number(row[c], key);
    }
    if ((m.row(3) - Eigen::RowVector4d(0, 0, 0, 1)).norm() > 1e-9) {
      Fail(node, key, "expected a homogeneous transform (last row 0 0 0 1)");
    }
    const Eigen::Matrix3d r = m.topLeftCorner<3, 3>();
    if ((r.transpose() * r - Eigen::Matrix3d::Identity()).norm() > 1e-6 || r.determinant() < 0) {
      Fail(node, key, "expected a rotation in the upper-left 3x3 (orthonormal, det +1)");
    }
    Eigen::Isometry3d t = Eigen::Isometry3d::Identity();
    t.matrix() = m;
    return t;
  }

  // An angle given under key_deg / key_gon / key_rad.
  double Angle(const YAML::Node& map, const std::string& base) const {
    for (AngleUnit unit : {AngleUnit::kDeg, AngleUnit::kGon, AngleUnit::kRad}) {
      const std::string key = base + std::string(AngleUnitSuffix(unit));
      if (map[key]) return ToRad(Number(map[key], key), unit);
    }
    Fail(map, base, "expected '" + base + "_deg', '" + base + "_gon' or '" + base + "_rad'");
  }

  RobotModel Parse(const YAML::Node& root) const {
    if (!root.IsMap()) Fail(root, "", "expected a mapping with name, base, links, tool_mm");
    RobotModel model;
    model.name = root["name"] && root["name"].IsScalar() ? root["name"].Scalar() : "robot";

    const YAML::Node base = root["base"];
    if (!base || (base.IsScalar() && base.Scalar() == "auto")) {
      model.base.reset();
    } else {
      model.base = Matrix4(base, "base");
    }

    Eigen::Isometry3d folded_tool = Eigen::Isometry3d::Identity();
    if (root["links"] && root["dh"]) Fail(root, "dh", "give either 'links' or 'dh', not both");
    if (const YAML::Node links = root["links"]) {
      if (!links.IsSequence()) Fail(links, "links", "expected a list of 4x4 matrices (N2…Nn)");
      for (const YAML::Node& link : links) model.links.push_back(Matrix4(link, "links"));
    } else if (const YAML::Node dh = root["dh"]) {
      if (!dh.IsSequence() || dh.size() < 1) Fail(dh, "dh", "expected a list of DH rows");
      std::vector<Eigen::Isometry3d> rows;
      for (const YAML::Node& row : dh) {
        if (!row.IsMap()) Fail(row, "dh", "expected {d_mm, a_mm, alpha_deg}");
        const double d = row["d_mm"] ? Number(row["d_mm"], "d_mm") : 0.0;
        const double a = row["a_mm"] ? Number(row["a_mm"], "a_mm") : 0.0;
        const double alpha = Angle(row, "alpha");
        // SPEC: N(i+1) = Tz(d_i)·Tx(a_i)·Rx(α_i).
        Eigen::Isometry3d t = Eigen::Isometry3d::Identity();
        t.translate(Eigen::Vector3d(0, 0, d));
        t.translate(Eigen::Vector3d(a, 0, 0));
        t.rotate(Eigen::AngleAxisd(alpha, Eigen::Vector3d::UnitX()));
        rows.push_back(t);
      }
      for (size_t i = 0; i + 1 < rows.size(); ++i) model.links.push_back(rows[i]);
      folded_tool = rows.back();
    } else {
      Fail(root, "links", "missing 'links' (N2…Nn as 4x4 matrices) or 'dh'");
    }

    Eigen::Vector3d tool = Eigen::Vector3d::Zero();
    if (const YAML::Node t = root["tool_mm"]) {
      if (!t.IsSequence() || t.size() != 3) Fail(t, "tool_mm", "expected [x, y, z] in mm");
      for (int i = 0; i < 3; ++i) tool(i) = Number(t[i], "tool_mm");
    }
    model.tool_mm = folded_tool * tool;

    const int n = model.num_joints();
    std::set<std::string> names;
    for (const auto& name : model.ParameterNames()) names.insert(name);
    if (const YAML::Node terms = root["nongeometric"]) {
      if (!terms.IsSequence()) Fail(terms, "nongeometric", "expected a list of terms");
      for (const YAML::Node& node : terms) {
        if (!node.IsMap()) Fail(node, "nongeometric", "expected {name, joint, basis, of}");
        NongeometricTerm term;
        if (!node["name"] || !node["name"].IsScalar()) Fail(node, "name", "expected a term name");
        term.name = node["name"].Scalar();
        if (!names.insert(term.name).second) {
          Fail(node["name"], "name", "duplicate parameter name '" + term.name + "'");
        }
        const int joint = Integer(node["joint"], "joint");
        if (joint < 1 || joint > n) {
          Fail(node["joint"], "joint", "expected a joint number 1…" + std::to_string(n));
        }
        term.joint = joint - 1;
        const std::string basis = node["basis"] ? node["basis"].Scalar() : "";
        if (basis == "cos") {
          term.basis = NongeometricTerm::Basis::kCos;
        } else if (basis == "sign_cos") {
          term.basis = NongeometricTerm::Basis::kSignCos;
        } else {
          Fail(node["basis"] ? node["basis"] : node, "basis", "expected basis 'cos' or 'sign_cos'");
        }
        const YAML::Node of = node["of"];
        if (!of || !of.IsSequence() || of.size() == 0) {
          Fail(node, "of", "expected 'of': a list of joint numbers");
        }
        for (const YAML::Node& j : of) {
          const int k = Integer(j, "of");
          if (k < 1 || k > n) Fail(j, "of", "expected a joint number 1…" + std::to_string(n));
          term.of.push_back(k - 1);
        }
        if (node["value_rad"]) term.fixed_rad = Number(node["value_rad"], "value_rad");
        model.nongeometric.push_back(std::move(term));
      }
    }

    if (const YAML::Node limits = root["joint_limits_deg"]) {
      if (!limits.IsSequence() || static_cast<int>(limits.size()) != n) {
        Fail(limits, "joint_limits_deg", "expected " + std::to_string(n) + " [min, max] pairs");
      }
      for (const YAML::Node& pair : limits) {
        if (!pair.IsSequence() || pair.size() != 2)
          Fail(pair, "joint_limits_deg", "expected [min, max]");
        const double lo = Number(pair[0], "joint_limits_deg"),
                     hi = Number(pair[1], "joint_limits_deg");
        if (!(lo < hi)) Fail(pair, "joint_limits_deg", "expected min < max");
        model.joint_min_rad.push_back(ToRad(lo, AngleUnit::kDeg));
        model.joint_max_rad.push_back(ToRad(hi, AngleUnit::kDeg));
      }
    }
    return model;
  }

 private:
  std::string source_;
};

}  // namespace

calibration::RobotModel ParseRobotModel(const std::string& yaml_text, const std::string& source) {
  YAML::Node root;
  try {
    root = YAML::Load(yaml_text);
  } catch (const YAML::Exception& e) {
    throw InputError({source, e.mark.line + 1, e.mark.column + 1, ""}, "malformed YAML: " + e.msg);
  }
  return Parser(source).Parse(root);
}

calibration::RobotModel LoadRobotModel(const std::string& path) {
  return ParseRobotModel(ReadWholeFile(path), path);
}

}  // namespace armsig::io
