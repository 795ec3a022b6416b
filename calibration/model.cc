#include "calibration/model.h"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <stdexcept>
#include <string>

namespace armsig::calibration {

namespace {

void NominalChain(const RobotModel& model, const double* joints_rad, NominalFrames& frames) {
  const int n = model.num_joints();
  frames.origin.resize(n);
  frames.axis.resize(n);
  Eigen::Matrix3d rot = Eigen::Matrix3d::Identity();
  Eigen::Vector3d pos = Eigen::Vector3d::Zero();
  for (int i = 0; i < n; ++i) {
    if (i > 0) {
      pos += rot * model.links[i - 1].translation();
      rot = rot * model.links[i - 1].linear();
    }
    frames.origin[i] = pos;
    frames.axis[i] = rot.col(2);
    rot = rot * Eigen::AngleAxisd(joints_rad[i], Eigen::Vector3d::UnitZ()).toRotationMatrix();
  }
  frames.target = pos + rot * model.tool_mm;
}

double AngleBasis(const NongeometricTerm& term, const double* joints_rad) {
  double sum = 0.0;
  for (int j : term.of) sum += joints_rad[j];
  switch (term.basis) {
    case NongeometricTerm::Basis::kCos:
      return std::cos(term.order * sum);
    case NongeometricTerm::Basis::kSin:
      return std::sin(term.order * sum);
    case NongeometricTerm::Basis::kSignCos: {
      // Paper eq. (7): SIGN[x] = x/|x|; at exactly zero the backlash side is undefined, take 0.
      const double c = std::cos(sum);
      return c > 0.0 ? 1.0 : (c < 0.0 ? -1.0 : 0.0);
    }
    case NongeometricTerm::Basis::kGravityTorque:
      break;
  }
  throw std::logic_error("gravity-torque term evaluated as an angle basis");
}

}  // namespace

void EvaluateTerms(const RobotModel& model, const double* joints_rad, double* values) {
  NominalFrames frames;
  EvaluateTerms(model, joints_rad, values, frames);
}

double JointArc::Clamp(double angle_rad) const {
  constexpr double kTurn = 2.0 * std::numbers::pi;
  if (whole_turn() || !std::isfinite(angle_rad)) return angle_rad;
  double r = std::fmod(angle_rad - start_rad, kTurn);
  if (r < 0.0) r += kTurn;
  if (r <= length_rad) return angle_rad;
  const double past_end = r - length_rad, to_start = kTurn - r;
  return past_end <= to_start ? angle_rad - past_end : angle_rad + to_start;
}

std::vector<JointArc> ArcsCovering(const std::vector<Eigen::VectorXd>& joints_rad,
                                   int num_joints) {
  constexpr double kTurn = 2.0 * std::numbers::pi;
  // The arcs reach a nanoradian past the outermost angles, so that every configuration they
  // were made from lies inside whatever the rounding of fmod.
  constexpr double kMargin = 1e-9;
  std::vector<JointArc> arcs(num_joints);
  if (joints_rad.empty()) return arcs;
  for (int j = 0; j < num_joints; ++j) {
    std::vector<double> a;
    a.reserve(joints_rad.size());
    for (const auto& q : joints_rad) {
      double r = std::fmod(q(j), kTurn);
      if (r < 0.0) r += kTurn;
      a.push_back(r);
    }
    std::sort(a.begin(), a.end());
    double gap = a.front() + kTurn - a.back();  // the wrap-around gap
    size_t after = 0;                           // the arc starts after the largest gap
    for (size_t k = 1; k < a.size(); ++k) {
      if (a[k] - a[k - 1] > gap) {
        gap = a[k] - a[k - 1];
        after = k;
      }
    }
    const double length = kTurn - gap + 2.0 * kMargin;
    arcs[j].start_rad = a[after] - kMargin;
    arcs[j].length_rad = length >= kTurn ? kTurn : length;
  }
  return arcs;
}

HeldTerms TermsHeldAtSupport(const RobotModel& model, const double* joints_rad) {
  HeldTerms held;
  if (model.term_support.empty() || model.nongeometric.empty()) return held;
  std::vector<int> outside;
  for (int j = 0; j < model.num_joints(); ++j) {
    if (!model.term_support[j].Contains(joints_rad[j])) outside.push_back(j);
  }
  if (outside.empty()) return held;
  RobotModel free = model;
  free.term_support.clear();
  const size_t terms = model.nongeometric.size();
  std::vector<double> formula(terms), clamped(terms);
  EvaluateTerms(free, joints_rad, formula.data());
  EvaluateTerms(model, joints_rad, clamped.data());
  for (size_t k = 0; k < terms; ++k) {
    if (std::abs(formula[k] - clamped[k]) > 1e-12) held.terms.push_back(static_cast<int>(k));
  }
  if (held.terms.empty()) return held;
  // The joints whose clamping alone changes a term: those the held terms depend on.
  std::vector<double> q(joints_rad, joints_rad + model.num_joints()), one(terms);
  for (int j : outside) {
    const double keep = q[j];
    q[j] = model.term_support[j].Clamp(keep);
    EvaluateTerms(free, q.data(), one.data());
    q[j] = keep;
    for (size_t k = 0; k < terms; ++k) {
      if (std::abs(formula[k] - one[k]) > 1e-12) {
        held.joints.push_back(j);
        break;
      }
    }
  }
  return held;
}

void EvaluateTerms(const RobotModel& model, const double* joints_rad, double* values,
                   NominalFrames& frames) {
  if (!model.term_support.empty()) {
    const int n = model.num_joints();
    if (static_cast<int>(model.term_support.size()) != n) {
      throw std::logic_error("term support of " + std::to_string(model.term_support.size()) +
                             " joints on a model of " + std::to_string(n));
    }
    frames.clamped_rad.resize(n);
    for (int j = 0; j < n; ++j) frames.clamped_rad[j] = model.term_support[j].Clamp(joints_rad[j]);
    joints_rad = frames.clamped_rad.data();
  }
  bool chained = false;
  for (size_t k = 0; k < model.nongeometric.size(); ++k) {
    const NongeometricTerm& term = model.nongeometric[k];
    if (term.basis != NongeometricTerm::Basis::kGravityTorque) {
      values[k] = AngleBasis(term, joints_rad);
      continue;
    }
    if (!chained) {
      NominalChain(model, joints_rad, frames);
      chained = true;
    }
    // τ = z·((p − o) × g) for a unit mass at p, in unit mass × m.
    const Eigen::Vector3d& p =
        term.mass_at < model.num_joints() ? frames.origin[term.mass_at] : frames.target;
    values[k] =
        frames.axis[term.joint].dot((p - frames.origin[term.joint]).cross(model.gravity_in_base)) /
        1000.0;
  }
}

const char* ToString(ToolMounting mounting) {
  return mounting == ToolMounting::kKnown ? "known" : "fitted";
}

Eigen::Matrix<double, 3, 2> AxesAcross(const Eigen::Vector3d& lever) {
  if (!(lever.norm() > 0.0)) throw std::invalid_argument("no axes across a lever of zero length");
  const Eigen::Vector3d along = lever.normalized();
  Eigen::Vector3d u1 = Eigen::Vector3d::UnitY().cross(along);
  // Along e_y (to rounding) e_y × l̂ has no direction: take e_z × l̂.
  if (u1.norm() < 1e-9) u1 = Eigen::Vector3d::UnitZ().cross(along);
  Eigen::Matrix<double, 3, 2> axes;
  axes.col(0) = u1.normalized();
  axes.col(1) = along.cross(axes.col(0));
  return axes;
}

RobotModel AtPoint(const RobotModel& model, const Eigen::Vector3d& point_mm) {
  RobotModel out = model;
  if (!out.turn_lever_mm) out.turn_lever_mm = model.tool_mm;
  out.tool_mm = point_mm;
  return out;
}

Eigen::Matrix3d FlangeTurn(const RobotModel& model, const Eigen::VectorXd& params) {
  if (!model.known_mounting()) return Eigen::Matrix3d::Identity();
  const Eigen::Matrix<double, 3, 2> u = model.FlangeTurnAxes();
  const int t = model.flange_turn_index();
  return TurnAbout<double>(u.col(0), params(t)) * TurnAbout<double>(u.col(1), params(t + 1));
}

std::vector<int> RobotModel::HeldParameters() const {
  if (!known_mounting()) return {};
  const int t = tool_index();
  return {t - 1, t, t + 1, t + 2};  // gamma{n}, a b c{n+1}
}

bool RobotModel::IsHeld(int parameter) const {
  const std::vector<int> held = HeldParameters();
  return std::find(held.begin(), held.end(), parameter) != held.end();
}

int RobotModel::GeometricIndex(int frame, int row) const {
  const int n = num_joints();
  if (frame < 0 || frame > n || row < 0 || row > 5) return -1;
  if (frame < n) return 6 * frame + row;
  if (row < 3) return tool_index() + row;
  return known_mounting() && row < 5 ? flange_turn_index() + row - 3 : -1;
}

std::vector<std::string> RobotModel::ParameterNames() const {
  static const char* kPerJoint[] = {"a", "b", "c", "alpha", "beta", "gamma"};
  std::vector<std::string> names;
  names.reserve(num_parameters());
  const int n = num_joints();
  for (int i = 1; i <= n; ++i) {
    for (const char* p : kPerJoint) names.push_back(std::string(p) + std::to_string(i));
  }
  for (const char* p : {"a", "b", "c"}) names.push_back(std::string(p) + std::to_string(n + 1));
  if (known_mounting()) {
    for (const char* p : {"alpha", "beta"}) names.push_back(std::string(p) + std::to_string(n + 1));
  }
  for (const auto& term : nongeometric) names.push_back(term.name);
  return names;
}

ParameterUnit RobotModel::UnitOf(int parameter) const {
  if (parameter >= num_geometric()) return ParameterUnit::kRad;
  if (known_mounting() && parameter >= flange_turn_index()) return ParameterUnit::kRad;
  if (parameter >= tool_index()) return ParameterUnit::kMm;
  return (parameter % 6) < 3 ? ParameterUnit::kMm : ParameterUnit::kRad;
}

int RobotModel::IndexOf(const std::string& name) const {
  const auto names = ParameterNames();
  for (size_t i = 0; i < names.size(); ++i) {
    if (names[i] == name) return static_cast<int>(i);
  }
  return -1;
}

Eigen::Isometry3d ErrorTransform(double a, double b, double c, double alpha, double beta,
                                 double gamma) {
  Eigen::Isometry3d h = Eigen::Isometry3d::Identity();
  h.translation() = Eigen::Vector3d(a, b, c);
  h.linear() = (Eigen::AngleAxisd(alpha, Eigen::Vector3d::UnitX()) *
                Eigen::AngleAxisd(beta, Eigen::Vector3d::UnitY()) *
                Eigen::AngleAxisd(gamma, Eigen::Vector3d::UnitZ()))
                   .toRotationMatrix();
  return h;
}

Eigen::Isometry3d JointRotation(double theta_rad) {
  Eigen::Isometry3d r = Eigen::Isometry3d::Identity();
  r.linear() = Eigen::AngleAxisd(theta_rad, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  return r;
}

namespace {

Eigen::Matrix3d Rx(double a) {
  const double c = std::cos(a), s = std::sin(a);
  Eigen::Matrix3d m;
  m << 1, 0, 0, 0, c, -s, 0, s, c;
  return m;
}
Eigen::Matrix3d Ry(double a) {
  const double c = std::cos(a), s = std::sin(a);
  Eigen::Matrix3d m;
  m << c, 0, s, 0, 1, 0, -s, 0, c;
  return m;
}
Eigen::Matrix3d Rz(double a) {
  const double c = std::cos(a), s = std::sin(a);
  Eigen::Matrix3d m;
  m << c, -s, 0, s, c, 0, 0, 0, 1;
  return m;
}

}  // namespace

Kinematics::Kinematics(const RobotModel& model) : model_(model) {
  const int n = model.num_joints();
  f_rot_.resize(n);
  g_rot_.resize(n);
  h_origin_.resize(n);
  alpha_axis_.resize(n);
  beta_axis_.resize(n);
  true_angles_.resize(n);
  term_values_.resize(model.nongeometric.size());
  h_rot_.resize(n);
  hx_rot_.resize(n);
  if (model.known_mounting()) turn_axes_ = model.FlangeTurnAxes();
}

void Kinematics::PrepareParameters(const Eigen::VectorXd& params) {
  if (prepared_params_.size() == params.size() && prepared_params_ == params) return;
  const int n = model_.num_joints();
  for (int i = 0; i < n; ++i) {
    const double* p = params.data() + 6 * i;
    hx_rot_[i] = Rx(p[3]);
    h_rot_[i] = hx_rot_[i] * Ry(p[4]) * Rz(p[5]);
  }
  if (model_.known_mounting()) {
    const double* turn = params.data() + model_.flange_turn_index();
    turn_rot_ = TurnAbout<double>(turn_axes_.col(0), turn[0]) *
                TurnAbout<double>(turn_axes_.col(1), turn[1]);  // FlangeTurn, axes kept
  }
  prepared_params_ = params;
}

void Kinematics::TrueJointAngles(const Eigen::VectorXd& params, const double* joints_rad,
                                 double* true_rad) {
  const int n = model_.num_joints();
  for (int i = 0; i < n; ++i) true_rad[i] = joints_rad[i];
  EvaluateTerms(model_, joints_rad, term_values_.data(), nominal_frames_);
  const int g = model_.num_geometric();
  for (size_t k = 0; k < model_.nongeometric.size(); ++k) {
    const auto& term = model_.nongeometric[k];
    true_rad[term.joint] += (params[g + static_cast<int>(k)] + term.fixed_rad) * term_values_[k];
  }
}

void Kinematics::Forward(const Eigen::Isometry3d& world_from_base, const Eigen::VectorXd& params,
                         const double* joints_rad) {
  const int n = model_.num_joints();
  if (params.size() != model_.num_parameters()) {
    throw std::invalid_argument("parameter vector has " + std::to_string(params.size()) +
                                " entries, model " + model_.name + " has " +
                                std::to_string(model_.num_parameters()));
  }
  PrepareParameters(params);
  TrueJointAngles(params, joints_rad, true_angles_.data());
  // Running transform (R, t): world from the current frame.
  Eigen::Matrix3d rot = world_from_base.linear();
  Eigen::Vector3d pos = world_from_base.translation();
  for (int i = 0; i < n; ++i) {
    if (i > 0) {
      const Eigen::Isometry3d& link = model_.links[i - 1];
      pos += rot * link.translation();
      rot = rot * link.linear();
    }
    const double* p = params.data() + 6 * i;
    f_rot_[i] = rot;  // frame before H_i
    pos += rot * Eigen::Vector3d(p[0], p[1], p[2]);
    h_origin_[i] = pos;  // origin of the rotations α, β, γ, θ of joint i
    alpha_axis_[i] = rot.col(0);
    beta_axis_[i] = rot * hx_rot_[i].col(1);
    rot = rot * h_rot_[i];
    g_rot_[i] = rot;  // frame after H_i, before Θ_i: its z is the joint axis
    // Θ_i: only the first two columns change (rotation about z).
    const double c = std::cos(true_angles_[i]), s = std::sin(true_angles_[i]);
    const Eigen::Vector3d x_axis = c * rot.col(0) + s * rot.col(1);
    rot.col(1) = c * rot.col(1) - s * rot.col(0);
    rot.col(0) = x_axis;
  }
  // A known mounting's flange turns after Θ_n about link n's origin, and the target (and a
  // production tool) with it.
  link_rot_ = rot;
  flange_origin_ = pos;
  last_rot_ = model_.known_mounting() ? Eigen::Matrix3d(rot * turn_rot_) : rot;
  const double* tool = params.data() + model_.tool_index();
  x_ = pos + last_rot_ * (model_.tool_mm + Eigen::Vector3d(tool[0], tool[1], tool[2]));
}

Eigen::Vector3d Kinematics::FlangeTurnAxis(int k) const {
  const double* turn = prepared_params_.data() + model_.flange_turn_index();
  const Eigen::Vector3d u1 = turn_axes_.col(0);
  if (k == 0) return link_rot_ * u1;
  return link_rot_ * (TurnAbout<double>(u1, turn[0]) * turn_axes_.col(1));
}

Eigen::Vector3d Kinematics::Position(const Eigen::Isometry3d& world_from_base,
                                     const Eigen::VectorXd& params, const double* joints_rad) {
  Forward(world_from_base, params, joints_rad);
  return x_;
}

Eigen::Vector3d Kinematics::PositionAndJacobian(
    const Eigen::Isometry3d& world_from_base, const Eigen::VectorXd& params,
    const double* joints_rad, Eigen::Ref<Eigen::Matrix<double, 3, Eigen::Dynamic>> jacobian) {
  Forward(world_from_base, params, joints_rad);
  const int n = model_.num_joints();
  // Every derivative is taken in the world frame: a translation along axis u moves the
  // target by u; a rotation about axis u through point o moves it by u × (x − o).
  for (int i = 0; i < n; ++i) {
    const Eigen::Vector3d lever = x_ - h_origin_[i];
    jacobian.col(6 * i + 0) = f_rot_[i].col(0);
    jacobian.col(6 * i + 1) = f_rot_[i].col(1);
    jacobian.col(6 * i + 2) = f_rot_[i].col(2);
    jacobian.col(6 * i + 3) = alpha_axis_[i].cross(lever);
    jacobian.col(6 * i + 4) = beta_axis_[i].cross(lever);
    // γ_i and θ_i turn about the same axis (the joint axis, z of G_i).
    jacobian.col(6 * i + 5) = g_rot_[i].col(2).cross(lever);
  }
  jacobian.middleCols(model_.tool_index(), 3) = last_rot_;
  if (model_.known_mounting()) {
    // The flange turn: Rot(u1, α)·Rot(u2, β) about link n's origin; β's axis is u2 turned by α.
    const Eigen::Vector3d lever = x_ - flange_origin_;
    const int t = model_.flange_turn_index();
    jacobian.col(t) = FlangeTurnAxis(0).cross(lever);
    jacobian.col(t + 1) = FlangeTurnAxis(1).cross(lever);
  }
  const int g = model_.num_geometric();
  for (size_t k = 0; k < model_.nongeometric.size(); ++k) {
    const auto& term = model_.nongeometric[k];
    // Paper eq. (6)–(7): ∂x/∂h = ∂x/∂θ_joint · f(θ̄) (f from this evaluation).
    jacobian.col(g + static_cast<int>(k)) = jacobian.col(6 * term.joint + 5) * term_values_[k];
  }
  return x_;
}

Eigen::Vector3d Kinematics::PoseAndJacobian(
    const Eigen::Isometry3d& world_from_base, const Eigen::VectorXd& params,
    const double* joints_rad, Eigen::Ref<Eigen::Matrix<double, 6, Eigen::Dynamic>> jacobian) {
  PositionAndJacobian(world_from_base, params, joints_rad, jacobian.topRows<3>());
  const int n = model_.num_joints();
  auto rotation = jacobian.bottomRows<3>();
  rotation.setZero();
  for (int i = 0; i < n; ++i) {
    rotation.col(6 * i + 3) = alpha_axis_[i];
    rotation.col(6 * i + 4) = beta_axis_[i];
    rotation.col(6 * i + 5) = g_rot_[i].col(2);  // γ_i and θ_i: the joint axis
  }
  if (model_.known_mounting()) {
    rotation.col(model_.flange_turn_index()) = FlangeTurnAxis(0);
    rotation.col(model_.flange_turn_index() + 1) = FlangeTurnAxis(1);
  }
  const int g = model_.num_geometric();
  for (size_t k = 0; k < model_.nongeometric.size(); ++k) {
    const auto& term = model_.nongeometric[k];
    rotation.col(g + static_cast<int>(k)) = g_rot_[term.joint].col(2) * term_values_[k];
  }
  return x_;
}

Eigen::Matrix<double, 3, Eigen::Dynamic> Kinematics::JointJacobian() const {
  Eigen::Matrix<double, 3, Eigen::Dynamic> j(3, model_.num_joints());
  WriteJointJacobian(j);
  return j;
}

void Kinematics::WriteJointJacobian(Eigen::Ref<Eigen::Matrix<double, 3, Eigen::Dynamic>> jacobian) const {
  for (int i = 0; i < model_.num_joints(); ++i) jacobian.col(i) = g_rot_[i].col(2).cross(x_ - h_origin_[i]);
}

std::vector<std::string> ModelDifferences(const RobotModel& a, const RobotModel& b,
                                          double tolerance_mm) {
  std::vector<std::string> out;
  auto transform = [&](const std::string& what, const Eigen::Isometry3d& x,
                       const Eigen::Isometry3d& y) {
    static constexpr const char* kAxis[3] = {"x", "y", "z"};
    for (int k = 0; k < 3; ++k) {
      if (std::abs(x.translation()(k) - y.translation()(k)) > tolerance_mm) {
        out.push_back(fmt::format("{} translation {}: {:.6g} mm against {:.6g} mm", what, kAxis[k],
                                  x.translation()(k), y.translation()(k)));
      }
    }
    if (!x.linear().isApprox(y.linear(), 1e-9)) {
      out.push_back(fmt::format("{} rotation: [{}] against [{}]", what,
                                fmt::join(x.linear().reshaped<Eigen::RowMajor>(), " "),
                                fmt::join(y.linear().reshaped<Eigen::RowMajor>(), " ")));
    }
  };
  if (a.num_joints() != b.num_joints()) {
    out.push_back(fmt::format("{} joints against {}", a.num_joints(), b.num_joints()));
    return out;
  }
  for (size_t k = 0; k < a.links.size(); ++k) {
    transform(fmt::format("link {} (N{})", k + 1, k + 2), a.links[k], b.links[k]);
  }
  if (a.base.has_value() != b.base.has_value()) {
    out.push_back(fmt::format("base: {} against {}", a.base ? "a matrix" : "auto",
                              b.base ? "a matrix" : "auto"));
  } else if (a.base) {
    transform("base (N1)", *a.base, *b.base);
  }
  transform("flange", a.flange, b.flange);
  if (a.tool_mounting != b.tool_mounting) {
    out.push_back(fmt::format("tool mounting: {} against {}", ToString(a.tool_mounting),
                              ToString(b.tool_mounting)));
  }
  for (int k = 0; k < 3; ++k) {
    if (std::abs(a.tool_mm(k) - b.tool_mm(k)) > tolerance_mm) {
      out.push_back(fmt::format("tool_mm[{}]: {:.6g} mm against {:.6g} mm", k, a.tool_mm(k),
                                b.tool_mm(k)));
    }
  }
  if (a.nongeometric != b.nongeometric) {
    out.push_back(fmt::format("non-geometric terms: {} against {} (or defined differently)",
                              a.nongeometric.size(), b.nongeometric.size()));
  }
  if (!a.gravity_in_base.isApprox(b.gravity_in_base, 1e-9)) out.push_back("gravity direction");
  if (a.joint_min_rad != b.joint_min_rad || a.joint_max_rad != b.joint_max_rad)
    out.push_back("joint limits");
  return out;
}

Eigen::Matrix<double, 3, Eigen::Dynamic> Kinematics::JointAxes() const {
  Eigen::Matrix<double, 3, Eigen::Dynamic> axes(3, model_.num_joints());
  WriteJointAxes(axes);
  return axes;
}

void Kinematics::WriteJointAxes(Eigen::Ref<Eigen::Matrix<double, 3, Eigen::Dynamic>> axes) const {
  for (int i = 0; i < model_.num_joints(); ++i) axes.col(i) = g_rot_[i].col(2);
}

}  // namespace armsig::calibration
