// The robot error model of Chen & Chao, paper eq. (2)–(7):
//   x = (N1 H1 Θ1)(N2 H2 Θ2)…(Nn Hn Θn)(x̄ + [a_{n+1} b_{n+1} c_{n+1} 0]ᵀ)
// with H_i = Trans(a_i, b_i, c_i)·Rx(α_i)·Ry(β_i)·Rz(γ_i) and Θ_i a rotation about z
// by the true joint angle θ_i = θ̄_i + Σ h_k f_k(θ̄) (non-geometric terms).
// With a known tool mounting (ToolMounting::kKnown) the target sits exactly at x̄ and the
// flange's own turn after Θ_n takes the place of the offset:
//   x = (N1 H1 Θ1)…(Nn Hn Θn)·T·x̄,  T = Rot(u1, α_{n+1})·Rot(u2, β_{n+1})
// about two axes across the lever x̄ (AxesAcross).
//
// RobotModel is immutable and shared; Kinematics evaluates it with its own scratch
// space (one per thread), Pinocchio-style.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <optional>
#include <string>
#include <vector>

namespace armsig::calibration {

// Where a non-geometric term comes from: written in the model file (the paper's h1…h4),
// or generated from the nominal geometry (calibration/terms.h).
enum class TermFamily {
  kModel,       // given in the model file
  kCompliance,  // joint deflection under the gravity torque of a lumped unit mass
  kHarmonics,   // transmission error: sin / cos of the joint's own angle, orders 1 and 2
};

// A term added to a true joint angle: θ_joint += (h + fixed) · f(θ̄).
struct NongeometricTerm {
  enum class Basis {
    kCos,      // cos(order · Σθ̄_of)        paper eq. (6) (order 1)
    kSignCos,  // SIGN[cos(Σθ̄_of)]          paper eq. (7): backlash
    kSin,      // sin(order · Σθ̄_of)        transmission harmonics
    // The gravity torque about this joint's axis of a unit mass at the origin of joint
    // `mass_at`'s frame (the target point when mass_at = num_joints()), computed on the
    // nominal geometry at the encoder angles with gravity along RobotModel::gravity_in_base:
    // τ = z·((p − o) × g) / 1000 mm, i.e. the torque counted in units of a unit mass one
    // metre out, a pure number like cos θ. Its coefficient (rad) is a compliance: the
    // deflection under that unit torque; the joint yields in the direction of the torque.
    kGravityTorque,
  };
  std::string name;
  int joint = 0;  // 0-based joint whose true angle it corrects
  Basis basis = Basis::kCos;
  std::vector<int> of;  // kCos, kSignCos, kSin: 0-based joints whose encoder angles are summed
  int order = 1;        // kCos, kSin: harmonic order (multiplies the angle sum)
  int mass_at = -1;     // kGravityTorque: 0-based joint frame carrying the mass (n = target)
  TermFamily family = TermFamily::kModel;
  // A correction already known (exported models); the parameter adds to it.
  double fixed_rad = 0.0;

  friend bool operator==(const NongeometricTerm&, const NongeometricTerm&) = default;
};

// Every non-geometric coefficient is in rad: its basis is a pure number (cos, SIGN, sin,
// or a gravity torque counted in unit-mass metres).
enum class ParameterUnit { kMm, kRad };

// The arc of one joint's encoder angles that a fitted set's poses covered: from
// `start_rad`, counter-clockwise over `length_rad` (≥ 2π: the whole turn). Every
// non-geometric basis is 2π-periodic in each joint, so an arc, not an interval, is what the
// data support.
struct JointArc {
  double start_rad = 0.0;
  double length_rad = 2.0 * 3.14159265358979323846;
  bool whole_turn() const { return length_rad >= 2.0 * 3.14159265358979323846; }
  // The angle itself inside the arc, else the nearer of its ends (as start_rad + 2πk or
  // start_rad + length_rad + 2πk, the representative nearest `angle_rad`).
  double Clamp(double angle_rad) const;
  bool Contains(double angle_rad) const { return Clamp(angle_rad) == angle_rad; }
  friend bool operator==(const JointArc&, const JointArc&) = default;
};

// The smallest arc per joint holding every configuration's angle (the complement of the
// largest gap between them). Configurations: num_joints values each.
std::vector<JointArc> ArcsCovering(const std::vector<Eigen::VectorXd>& joints_rad, int num_joints);

// Where the calibration target sits on the flange. kFitted: the model file's x̄ is nominal, and
// the fit's offset a b c{n+1} at the target takes the probe's mounting and the flange's own
// turn after the last joint together (they cannot be told apart). kKnown: the target sits
// exactly at x̄ (a machined adapter, measured), so what the fit finds there is the flange's:
// its turn α β{n+1} across the lever, which a production tool inherits.
enum class ToolMounting { kFitted, kKnown };
const char* ToString(ToolMounting mounting);  // "fitted", "known"

// Two unit axes across a lever `lever` (not zero), in its frame: u1 = normalize(e_y × l̂) (e_z
// × l̂ when the lever lies along e_y), u2 = l̂ × u1. A lever along z gives u1 = x, u2 = y.
Eigen::Matrix<double, 3, 2> AxesAcross(const Eigen::Vector3d& lever);

// A turn by `angle` about unit axis `u` (Rodrigues), on any scalar type.
template <typename T>
Eigen::Matrix<T, 3, 3> TurnAbout(const Eigen::Vector3d& u, const T& angle) {
  using std::cos;
  using std::sin;
  Eigen::Matrix<T, 3, 3> k;
  k << T(0), T(-u.z()), T(u.y()), T(u.z()), T(0), T(-u.x()), T(-u.y()), T(u.x()), T(0);
  return Eigen::Matrix<T, 3, 3>::Identity() + sin(angle) * k + (T(1) - cos(angle)) * (k * k);
}

struct RobotModel {
  std::string name;
  // N1: measurement frame from robot base. nullopt = "auto" (rigid best fit to the data).
  std::optional<Eigen::Isometry3d> base;
  std::vector<Eigen::Isometry3d> links;               // N2…Nn
  Eigen::Vector3d tool_mm = Eigen::Vector3d::Zero();  // x̄, in the last link frame
  // The flange (tool0, where a production tool is mounted) in the last link frame: for a model
  // given by DH rows the last row's Tz(d)·Tx(a)·Rx(α), else identity, unless the file gives
  // `flange:`. The signature's geometry up to the flange is what a production tool inherits.
  Eigen::Isometry3d flange = Eigen::Isometry3d::Identity();
  std::vector<NongeometricTerm> nongeometric;
  // Direction of gravity in the robot's base frame (the frame N1 maps from), unit length:
  // base z up unless the model file says otherwise. Used by kGravityTorque terms only.
  Eigen::Vector3d gravity_in_base = -Eigen::Vector3d::UnitZ();
  // Optional joint limits (rad); empty when unknown.
  std::vector<double> joint_min_rad, joint_max_rad;
  // No extrapolation of the non-geometric terms: when set (one arc per joint, a fitted
  // set's support), every term is evaluated at the encoder angles clamped to these arcs, so
  // outside the joint ranges its set was fitted on a term keeps the value it has at the
  // nearest edge instead of following its formula where no data checked it. Empty: the
  // formulas everywhere (fitting, and sets stored before supports were).
  std::vector<JointArc> term_support;
  // Whether the target's place on the flange is known (the model file's `tool_mounting`).
  ToolMounting tool_mounting = ToolMounting::kFitted;
  // The lever the flange turn's axes lie across: the calibration target's x̄, kept when the
  // model is evaluated at another point of the last link (AtPoint: a production TCP), so that
  // alpha{n+1} beta{n+1} turn about the same axes there. nullopt: tool_mm.
  std::optional<Eigen::Vector3d> turn_lever_mm;

  int num_joints() const { return static_cast<int>(links.size()) + 1; }
  bool known_mounting() const { return tool_mounting == ToolMounting::kKnown; }
  // 6n + 3, and the flange turn's 2 with a known mounting.
  int num_geometric() const { return 6 * num_joints() + 3 + (known_mounting() ? 2 : 0); }
  int num_parameters() const { return num_geometric() + static_cast<int>(nongeometric.size()); }
  // Index of a{n+1} (the offset at the target; b, c follow).
  int tool_index() const { return 6 * num_joints(); }
  // Index of alpha{n+1} (beta{n+1} follows), -1 with a fitted mounting.
  int flange_turn_index() const { return known_mounting() ? 6 * num_joints() + 3 : -1; }
  // The parameters held at zero, never identified (ascending): with a known mounting the
  // offset a b c{n+1} (the target's place is known: a lateral shift there is the turn) and
  // gamma{n} (on a position it and the turn about the lever are one unknown, the rest of it
  // is the turn across). Empty with a fitted mounting.
  std::vector<int> HeldParameters() const;
  bool IsHeld(int parameter) const;
  // The index of row `row` (0–5: a b c alpha beta gamma) of frame `frame` (0-based; n: the
  // target's a b c and, with a known mounting, the flange turn's alpha beta), or -1.
  int GeometricIndex(int frame, int row) const;
  // u1 u2 of a known mounting's flange turn (AxesAcross the target's lever).
  Eigen::Matrix<double, 3, 2> FlangeTurnAxes() const {
    return AxesAcross(turn_lever_mm.value_or(tool_mm));
  }

  // a1 b1 c1 alpha1 beta1 gamma1 … gamma{n} a{n+1} b{n+1} c{n+1} [alpha{n+1} beta{n+1}], then
  // the h-terms.
  std::vector<std::string> ParameterNames() const;
  ParameterUnit UnitOf(int parameter) const;
  // Index of a parameter name, or -1.
  int IndexOf(const std::string& name) const;
};

// How two models of one robot differ, one line per differing value ("link 2 (N3)
// translation x: 650.3 mm against 650 mm"; `a` first), to `tolerance_mm` for lengths and
// 1e-9 for matrix entries and angles. Empty when they describe the same arm (names and
// the way the file was written do not count).
std::vector<std::string> ModelDifferences(const RobotModel& a, const RobotModel& b,
                                          double tolerance_mm = 1e-6);

// The value f_k(θ̄) of every non-geometric term of `model` for the encoder angles
// (model.nongeometric.size() values into `values`), clamped to model.term_support when it
// is set. One pass of the nominal chain when the model has gravity-torque terms.
void EvaluateTerms(const RobotModel& model, const double* joints_rad, double* values);

// The nominal chain in the robot's base frame for the encoder angles (H_i = I, true angle =
// encoder angle): a point on each joint axis (the origin of its frame), the axis, and the
// target point. The gravity-torque terms are computed from it.
struct NominalFrames {
  std::vector<Eigen::Vector3d> origin, axis;
  Eigen::Vector3d target = Eigen::Vector3d::Zero();
  std::vector<double> clamped_rad;  // scratch: the angles clamped to the term support
};

// The terms whose value a configuration's clamping to model.term_support changes (their
// indices into model.nongeometric), with the joints outside their arcs that those terms
// depend on. Empty without a support or inside it.
struct HeldTerms {
  std::vector<int> terms;
  std::vector<int> joints;  // 0-based, outside their arc
};
HeldTerms TermsHeldAtSupport(const RobotModel& model, const double* joints_rad);
// The same with caller-owned scratch (no allocation once sized).
void EvaluateTerms(const RobotModel& model, const double* joints_rad, double* values,
                   NominalFrames& scratch);

// The same arm evaluated at another point of its last link (`point_mm` in the last link frame,
// a production tool's TCP): its parameters mean what they meant at the target.
RobotModel AtPoint(const RobotModel& model, const Eigen::Vector3d& point_mm);

// A known mounting's flange turn T = Rot(u1, alpha{n+1})·Rot(u2, beta{n+1}) in the last link
// frame for `params` (identity with a fitted mounting).
Eigen::Matrix3d FlangeTurn(const RobotModel& model, const Eigen::VectorXd& params);

// Homogeneous transforms of paper eq. (2) and (3).
Eigen::Isometry3d ErrorTransform(double a, double b, double c, double alpha, double beta,
                                 double gamma);
Eigen::Isometry3d JointRotation(double theta_rad);

// Evaluates the model; owns the scratch space, so use one per thread.
class Kinematics {
 public:
  explicit Kinematics(const RobotModel& model);
  // The model is referenced, not copied: a temporary would dangle.
  explicit Kinematics(RobotModel&&) = delete;

  // Target position in the measurement frame for encoder angles `joints_rad`.
  Eigen::Vector3d Position(const Eigen::Isometry3d& world_from_base, const Eigen::VectorXd& params,
                           const double* joints_rad);

  // Position and its analytic derivative with respect to every parameter
  // (3 × num_parameters, written into `jacobian`).
  Eigen::Vector3d PositionAndJacobian(
      const Eigen::Isometry3d& world_from_base, const Eigen::VectorXd& params,
      const double* joints_rad, Eigen::Ref<Eigen::Matrix<double, 3, Eigen::Dynamic>> jacobian);

  // Position and its derivatives with the rotation's (6 × num_parameters): rows 0–2 as
  // PositionAndJacobian, rows 3–5 how each parameter turns the last link frame, as a
  // world-side rotation vector: a change dp turns it by exp([J_rot·dp]×)·R. Translations (a,
  // b, c, the tool offset) turn nothing; α, β, γ turn about their axes, a non-geometric term
  // about its joint's axis by its basis value. The last link's rotation is LastRotation().
  Eigen::Vector3d PoseAndJacobian(const Eigen::Isometry3d& world_from_base,
                                  const Eigen::VectorXd& params, const double* joints_rad,
                                  Eigen::Ref<Eigen::Matrix<double, 6, Eigen::Dynamic>> jacobian);

  // ∂x/∂θ_i with respect to the true joint angles (3 × n), from the last evaluation.
  // Used by compensation (inverse kinematics on the calibrated model).
  Eigen::Matrix<double, 3, Eigen::Dynamic> JointJacobian() const;
  // The same into `jacobian` (3 × n, allocated by the caller: a solver's loop allocates nothing).
  void WriteJointJacobian(Eigen::Ref<Eigen::Matrix<double, 3, Eigen::Dynamic>> jacobian) const;

  // The rotation of the last link frame (world from link n, turned by a known mounting's
  // flange turn: a production tool turns with the flange) and the joint axes in the world
  // frame (3 × n: ∂ω/∂θ_i), from the last evaluation. Used to solve for a whole pose (the
  // ISO 9283 plan keeps the tool's orientation).
  const Eigen::Matrix3d& LastRotation() const { return last_rot_; }
  Eigen::Matrix<double, 3, Eigen::Dynamic> JointAxes() const;
  void WriteJointAxes(Eigen::Ref<Eigen::Matrix<double, 3, Eigen::Dynamic>> axes) const;

  // True joint angles for the encoder angles under the model's h-terms.
  void TrueJointAngles(const Eigen::VectorXd& params, const double* joints_rad, double* true_rad);

  const RobotModel& model() const { return model_; }

 private:
  void Forward(const Eigen::Isometry3d& world_from_base, const Eigen::VectorXd& params,
               const double* joints_rad);
  // H_i rotations do not depend on the pose: recomputed only when the parameters change.
  void PrepareParameters(const Eigen::VectorXd& params);
  // The world axis of a known mounting's flange turn α (k = 0) or β (k = 1), last evaluation.
  Eigen::Vector3d FlangeTurnAxis(int k) const;

  const RobotModel& model_;
  // Scratch, per joint i: frame before H_i (F), after H_i (G), axes for α, β.
  std::vector<Eigen::Matrix3d> f_rot_, g_rot_;
  std::vector<Eigen::Vector3d> h_origin_, alpha_axis_, beta_axis_;
  std::vector<double> true_angles_;
  Eigen::Matrix<double, 3, 2> turn_axes_ = Eigen::Matrix<double, 3, 2>::Zero();  // u1 u2 (link n)
  Eigen::Matrix3d turn_rot_ = Eigen::Matrix3d::Identity();   // T of a known mounting
  Eigen::Matrix3d link_rot_ = Eigen::Matrix3d::Identity();   // world from link n, before T
  Eigen::Vector3d flange_origin_ = Eigen::Vector3d::Zero();  // pivot of T (link n's origin)
  std::vector<double> term_values_;  // f_k(θ̄) of the last evaluation
  NominalFrames nominal_frames_;
  std::vector<Eigen::Matrix3d> h_rot_, hx_rot_;  // Rx·Ry·Rz and Rx of every H_i
  Eigen::VectorXd prepared_params_;
  Eigen::Vector3d x_ = Eigen::Vector3d::Zero();
  Eigen::Matrix3d last_rot_ = Eigen::Matrix3d::Identity();
};

// A turn by `a` about coordinate axis `axis` (0 x, 1 y, 2 z) as a 4 × 4 homogeneous matrix
// (core/rotation.h's turns, on any scalar type).
template <typename T>
Eigen::Matrix<T, 4, 4> AxisTurn(int axis, const T& a) {
  using std::cos;
  using std::sin;
  Eigen::Matrix<T, 4, 4> m = Eigen::Matrix<T, 4, 4>::Identity();
  const int i = (axis + 1) % 3, j = (axis + 2) % 3;
  m(i, i) = cos(a);
  m(i, j) = -sin(a);
  m(j, i) = sin(a);
  m(j, j) = cos(a);
  return m;
}

// The same model templated on the scalar type (for automatic differentiation with
// ceres::Jet and as an independent check of the analytic Jacobian).
template <typename T>
Eigen::Matrix<T, 3, 1> TargetPosition(const RobotModel& model,
                                      const Eigen::Isometry3d& world_from_base, const T* params,
                                      const double* joints_rad) {
  using Mat4 = Eigen::Matrix<T, 4, 4>;
  const int n = model.num_joints();
  std::vector<T> theta(n);
  for (int i = 0; i < n; ++i) theta[i] = T(joints_rad[i]);
  std::vector<double> f(model.nongeometric.size());
  EvaluateTerms(model, joints_rad, f.data());
  for (size_t k = 0; k < model.nongeometric.size(); ++k) {
    const auto& term = model.nongeometric[k];
    theta[term.joint] += (params[model.num_geometric() + k] + T(term.fixed_rad)) * f[k];
  }
  Mat4 chain = world_from_base.matrix().template cast<T>();
  for (int i = 0; i < n; ++i) {
    if (i > 0) chain = chain * model.links[i - 1].matrix().template cast<T>();
    const T* p = params + 6 * i;
    Mat4 translation = Mat4::Identity();
    translation(0, 3) = p[0];
    translation(1, 3) = p[1];
    translation(2, 3) = p[2];
    chain = chain * translation * AxisTurn(0, p[3]) * AxisTurn(1, p[4]) * AxisTurn(2, p[5]) *
            AxisTurn(2, theta[i]);
  }
  const T* tool = params + model.tool_index();
  Eigen::Matrix<T, 3, 1> at_target(T(model.tool_mm.x()) + tool[0], T(model.tool_mm.y()) + tool[1],
                                   T(model.tool_mm.z()) + tool[2]);
  if (model.known_mounting()) {
    const Eigen::Matrix<double, 3, 2> u = model.FlangeTurnAxes();
    const T* turn = params + model.flange_turn_index();
    at_target = TurnAbout<T>(u.col(0), turn[0]) * TurnAbout<T>(u.col(1), turn[1]) * at_target;
  }
  Eigen::Matrix<T, 4, 1> point;
  point << at_target, T(1.0);
  return (chain * point).template head<3>();
}

}  // namespace armsig::calibration
