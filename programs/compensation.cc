#include "programs/compensation.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <set>
#include <stdexcept>

#include "calibration/damped_step.h"
#include "calibration/pose_solver.h"
#include "calibration/residual_map.h"
#include "core/units.h"

namespace armsig::programs {

namespace {

// The signed robot's chain carrying a tool: the model's target point moved to the TCP. The
// calibration point's fitted offset (a, b, c of its tool parameters) stays: the probe is
// taken to sit where the model file says, so what the fit found there is the flange's.
class SignedChain {
 public:
  SignedChain(const SignedRobot& robot, const Eigen::Isometry3d& tool)
      : robot_(robot), model_(*robot.model), params_(robot.params), kin_(model_) {
    const int n = model_.num_joints();
    if (params_.size() != model_.num_parameters())
      throw std::invalid_argument("the signature's parameters do not fit its model");
    flange_tool_ = model_.flange * tool;
    model_ = calibration::AtPoint(model_, flange_tool_.translation());
    corrected_.resize(n);
    map_jacobian_.resize(3, n);
  }

  // The TCP at encoder angles q; with `jacobian` its derivative by them (rows 0–2 the
  // position, 3–5 the world-side rotation).
  SignedPose Evaluate(const Eigen::VectorXd& q, Eigen::MatrixXd* jacobian) {
    SignedPose out;
    const calibration::ResidualMap* map = robot_.map;
    bool curves_inside = true;
    corrected_ = q;
    if (map) curves_inside = map->CorrectJoints(q.data(), corrected_.data());
    Eigen::Vector3d x = kin_.Position(Eigen::Isometry3d::Identity(), params_, corrected_.data());
    if (jacobian) {
      jacobian->resize(6, q.size());
      jacobian->topRows(3) = kin_.JointJacobian();
      jacobian->bottomRows(3) = kin_.JointAxes();
    }
    if (map) {
      const calibration::MapPrediction p = map->PredictWithJacobian(q.data(), map_jacobian_);
      out.map_extrapolated = !(p.supported && curves_inside);
      x += p.correction_in_base_mm;  // robot frame: the map's own base frame
      if (jacobian) jacobian->topRows(3) += map_jacobian_;
    }
    out.tcp.linear() = kin_.LastRotation() * flange_tool_.linear();
    out.tcp.translation() = x;
    return out;
  }

 private:
  const SignedRobot& robot_;
  calibration::RobotModel model_;
  Eigen::VectorXd params_;
  calibration::Kinematics kin_;
  Eigen::Isometry3d flange_tool_ = Eigen::Isometry3d::Identity();
  Eigen::VectorXd corrected_;
  Eigen::Matrix<double, 3, Eigen::Dynamic> map_jacobian_;
};

double AngleDeg(const Eigen::Matrix3d& a, const Eigen::Matrix3d& b) {
  return Eigen::AngleAxisd(a * b.transpose()).angle() / kRadPerDeg;
}

bool SameFrame(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b) {
  return (a.translation() - b.translation()).norm() < 1e-6 && (a.linear() - b.linear()).norm() < 1e-9;
}

bool HasStated(const StatedConfiguration& s) { return s.kuka_status || s.kuka_turn || s.abb_cf; }

std::string Flags(const ArmConfiguration& a) {
  return fmt::format("{}, elbow {}, wrist {}", a.overhead ? "behind joint 1" : "in front of joint 1",
                     a.elbow ? "past stretched" : "short of stretched", a.wrist ? "flipped" : "not flipped");
}

}  // namespace

SignedPose SignedTcp(const SignedRobot& robot, const Eigen::Isometry3d& tool, const Eigen::VectorXd& q) {
  SignedChain chain(robot, tool);
  return chain.Evaluate(q, nullptr);
}

Eigen::Vector3d SignedCalibrationPoint(const SignedRobot& robot, const Eigen::VectorXd& q) {
  const std::vector<calibration::MappedPosition> p = calibration::PredictPositions(
      *robot.model, Eigen::Isometry3d::Identity(), robot.params, robot.map, {q});
  return p.at(0).position_mm;
}

calibration::JointSolution SolveSigned(const SignedRobot& robot, const Eigen::Isometry3d& tool,
                                       const Eigen::Isometry3d& pose, const Eigen::VectorXd& seed,
                                       const calibration::JointSolveOptions& options) {
  options.Check();
  SignedChain chain(robot, tool);
  calibration::JointSolution s;
  s.joints_rad = seed;
  Eigen::Matrix<double, 6, 1> e;
  Eigen::MatrixXd j;
  auto evaluate = [&](const Eigen::VectorXd& q, Eigen::MatrixXd* jacobian) {
    const SignedPose p = chain.Evaluate(q, jacobian);
    s.map_extrapolated = p.map_extrapolated;
    const Eigen::AngleAxisd turn(pose.linear() * p.tcp.linear().transpose());
    e.head<3>() = pose.translation() - p.tcp.translation();
    e.tail<3>() = calibration::kPoseLeverMm * turn.angle() * turn.axis();
    if (jacobian) jacobian->bottomRows(3) *= calibration::kPoseLeverMm;
    return e.norm();
  };
  calibration::StallWatch watch;
  for (; s.iterations < options.max_iterations; ++s.iterations) {
    s.residual_mm = evaluate(s.joints_rad, &j);
    if (!(s.residual_mm >= options.tolerance_mm)) break;
    s.joints_rad += calibration::DampedJointStep(j, e, s.residual_mm, options);
    if (watch.Stalled(s.residual_mm)) break;
  }
  s.residual_mm = evaluate(s.joints_rad, nullptr);
  if (!std::isfinite(s.residual_mm) || !s.joints_rad.allFinite()) {
    s.status = {SolveCode::kNonFinite, "the solution is not a finite number"};
    return s;
  }
  if (s.residual_mm > options.tolerance_mm * 10) {
    s.status = {SolveCode::kNotConverged,
                fmt::format("no joints put the TCP there (closest {:.3f} mm and {:.4f}°)", e.head<3>().norm(),
                            e.tail<3>().norm() / calibration::kPoseLeverMm / kRadPerDeg)};
    return s;
  }
  s.residual_mm = e.head<3>().norm();
  s.status = calibration::JointLimitStatus(*robot.model, s.joints_rad);
  return s;
}

const char* ToString(TargetStatus status) {
  switch (status) {
    case TargetStatus::kOk:
      return "ok";
    case TargetStatus::kOutsideJointRange:
      return "outside_joint_range";
    case TargetStatus::kOutsideMeasuredVolume:
      return "outside_measured_volume";
    case TargetStatus::kOutOfReach:
      return "out_of_reach";
    case TargetStatus::kConfigurationChange:
      return "configuration_change";
    case TargetStatus::kTaughtJointsMissPose:
      return "taught_joints_miss_pose";
    case TargetStatus::kFrameUnknown:
      return "frame_unknown";
    case TargetStatus::kConflictingUse:
      return "conflicting_use";
  }
  return "?";
}

bool IsRefusal(TargetStatus s) {
  return s == TargetStatus::kOutsideJointRange || s == TargetStatus::kOutsideMeasuredVolume ||
         s == TargetStatus::kOutOfReach || s == TargetStatus::kConfigurationChange ||
         s == TargetStatus::kTaughtJointsMissPose;
}

namespace {

class Compensator {
 public:
  Compensator(const Program& program, const ControllerModel& controller, const SignedRobot& robot,
              const ValidatedVolume* volume, const CompensationOptions& options)
      : p_(program), c_(controller), robot_(robot), volume_(volume), options_(options) {
    const int n = c_.num_joints();
    if (!robot.model || robot.model->num_joints() != n)
      throw std::invalid_argument("the controller's model and the signature's have different joint counts");
    for (const Motion& m : p_.motions)
      for (int t : m.targets) uses_[t].push_back(&m);
  }

  ProgramCompensation Run() {
    ProgramCompensation out;
    out.allow_outside = options_.allow_outside;
    std::set<int> done;
    std::optional<Eigen::VectorXd> previous;
    for (const Motion& m : p_.motions) {
      for (int t : m.targets) {
        if (!done.insert(t).second) continue;
        TargetReport r = One(t, previous, &out.edits);
        if (r.nominal_joints_rad.size() == c_.num_joints()) previous = r.nominal_joints_rad;
        if (IsRefusal(r.status)) ++out.refused;
        out.targets.push_back(std::move(r));
      }
    }
    if (out.refused > 0 && !options_.allow_outside) {
      out.edits.clear();
      for (auto& r : out.targets) r.written = false;
    }
    return out;
  }

 private:
  TargetReport One(int index, const std::optional<Eigen::VectorXd>& previous, std::vector<Edit>* edits) {
    const Target& t = p_.targets[static_cast<std::size_t>(index)];
    TargetReport r;
    r.target = index;
    r.orientation_measured = robot_.orientation_measured;
    const auto& uses = uses_.at(index);
    for (const Motion* m : uses) r.motions.push_back(m->place.line);
    auto fail = [&](Refusal refusal) {
      r.status = refusal.status;
      r.why = std::move(refusal.why);
      return r;
    };
    // One tool and one base for all its motions.
    const bool pose_target = t.kind() == TargetKind::kPose;
    if (auto refused = FramesOf(uses, pose_target)) return fail(std::move(*refused));
    const Motion& first = *uses.front();
    const Eigen::Isometry3d tool = *first.tool.transform;
    const Eigen::Isometry3d base = pose_target ? *first.base.transform : Eigen::Isometry3d::Identity();

    // Intent and the controller's own joints.
    Intent intent;
    intent.near = previous;
    if (auto refused = IntentOf(t, tool, base, intent, r)) return fail(std::move(*refused));

    // The signed robot onto the intent, from the controller's joints.
    const calibration::JointSolution s =
        SolveSigned(robot_, tool, intent.pose, r.nominal_joints_rad, options_.solve);
    if (!s.status.ok())
      return fail({TargetStatus::kOutOfReach, fmt::format("the calibrated robot: {}", s.status.message)});
    r.compensated_joints_rad = s.joints_rad;
    r.residual_mm = s.residual_mm;
    r.map_extrapolated = s.map_extrapolated;
    const Eigen::Isometry3d written = TcpPose(c_, s.joints_rad, tool);
    r.correction_mm = (written.translation() - intent.pose.translation()).norm();
    r.correction_deg = AngleDeg(written.linear(), intent.pose.linear());
    // A fitted mounting put the flange's turn into the offset at the calibration point: it
    // misses the TCP by the lever between them.
    if (!robot_.model->known_mounting())
      r.lever_mm = ((robot_.model->flange * tool).translation() - robot_.model->tool_mm).norm();

    // Inside what the set was validated on, and what it promises there: known wherever the
    // compensated joints are, whatever else refuses the target.
    const Refusal outside = OutsideVolume(s.joints_rad);
    Promise(tool, s.joints_rad, outside.why, r);

    // The configuration the program's numbers ask for must be the compensated joints' own.
    if (auto refused = ConfigurationChange(t, tool, written, intent, r.nominal_joints_rad, s.joints_rad))
      return fail(std::move(*refused));

    if (outside.status != TargetStatus::kOk) {
      r.status = outside.status;
      r.why = outside.why;
      if (!options_.allow_outside) return r;
    }

    // The rewrite.
    const std::vector<Edit> own =
        pose_target ? RewritePose(t, base.inverse() * written) : RewriteJoints(t, s.joints_rad);
    edits->insert(edits->end(), own.begin(), own.end());
    // A waypoint's taught joints follow its pose (unless a motion moves to them on their own).
    if (intent.near_target && !uses_.count(*t.config.near_target) &&
        rewritten_near_.insert(*t.config.near_target).second) {
      const std::vector<Edit> q = RewriteJoints(*intent.near_target, s.joints_rad);
      edits->insert(edits->end(), q.begin(), q.end());
    }
    r.written = true;
    return r;
  }

  // Why a target is not rewritten (kOk and "" where nothing refuses it).
  struct Refusal {
    TargetStatus status = TargetStatus::kOk;
    std::string why;
  };

  // Every motion to a target with a known tool (and, for a pose, base), all the same.
  static std::optional<Refusal> FramesOf(const std::vector<const Motion*>& uses, bool pose_target) {
    const Motion& first = *uses.front();
    for (const Motion* m : uses) {
      if (!m->tool.known())
        return Refusal{TargetStatus::kFrameUnknown,
                       fmt::format("the tool of {} at line {} ({}): {}", m->instruction, m->place.line,
                                   m->tool.name, m->tool.unknown_why)};
      if (pose_target && !m->base.known())
        return Refusal{TargetStatus::kFrameUnknown,
                       fmt::format("the base of {} at line {} ({}): {}", m->instruction, m->place.line,
                                   m->base.name, m->base.unknown_why)};
      if (first.tool.known() && !SameFrame(*m->tool.transform, *first.tool.transform))
        return Refusal{TargetStatus::kConflictingUse,
                       fmt::format("used with tool {} at line {} and tool {} at line {}: one set of numbers "
                                   "cannot land both", first.tool.name, first.place.line, m->tool.name,
                                   m->place.line)};
      if (pose_target && first.base.known() && !SameFrame(*m->base.transform, *first.base.transform))
        return Refusal{TargetStatus::kConflictingUse,
                       fmt::format("used in base {} at line {} and base {} at line {}", first.base.name,
                                   first.place.line, m->base.name, m->place.line)};
    }
    return std::nullopt;
  }

  // Where the program means the TCP to be, and the joints to start from.
  struct Intent {
    Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
    std::optional<Eigen::VectorXd> near;  // the joints the controller's solution is nearest
    const Target* near_target = nullptr;  // a waypoint's taught joints (RAPID, KRL)
  };

  // The intent of target `t` and the joints the controller's own model gives it
  // (r.nominal_joints_rad), or why there are none.
  std::optional<Refusal> IntentOf(const Target& t, const Eigen::Isometry3d& tool, const Eigen::Isometry3d& base,
                                  Intent& intent, TargetReport& r) const {
    const int n = c_.num_joints();
    if (t.kind() != TargetKind::kPose) {
      if (static_cast<int>(t.fields.size()) != n)
        return Refusal{TargetStatus::kOutOfReach,
                       fmt::format("{} joint values for a robot of {} joints", t.fields.size(), n)};
      r.nominal_joints_rad = JointsOf(t);
      intent.pose = TcpPose(c_, r.nominal_joints_rad, tool);
      return std::nullopt;
    }
    intent.pose = base * PoseOf(t);
    if (t.config.near_target) {
      intent.near_target = &p_.targets[static_cast<std::size_t>(*t.config.near_target)];
      if (static_cast<int>(intent.near_target->fields.size()) == n) {
        const Eigen::VectorXd taught = JointsOf(*intent.near_target);
        const Eigen::Isometry3d at = TcpPose(c_, taught, tool);
        const double mm = (at.translation() - intent.pose.translation()).norm();
        const double deg = AngleDeg(at.linear(), intent.pose.linear());
        if (mm > options_.taught_tolerance_mm || deg > options_.taught_tolerance_deg) {
          r.nominal_joints_rad = taught;
          return Refusal{TargetStatus::kTaughtJointsMissPose,
                         fmt::format("its taught joints {} put the TCP {:.3f} mm and {:.4f}° from it on the "
                                     "controller's model ({})", intent.near_target->name, mm, deg, c_.description)};
        }
        intent.near = taught;
      }
    }
    if (!intent.near && !HasStated(t.config))
      r.note = "no joints to start from (no qnear, no target before it): the controller's solution "
               "nearest all joints at zero is assumed";
    InverseRequest request;
    request.tcp = intent.pose;
    request.tool = tool;
    request.stated = t.config;
    request.stated.near_target.reset();
    request.near_rad = intent.near;
    const InverseSolution inv = ControllerInverse(c_, request);
    if (!inv.joints_rad) {
      if (inv.reachable && HasStated(t.config))
        return Refusal{TargetStatus::kTaughtJointsMissPose,
                       fmt::format("its configuration data {} fit none of its pose's solutions on the "
                                   "controller's model: {}", Describe(t.config), inv.why)};
      return Refusal{TargetStatus::kOutOfReach, fmt::format("the controller's model: {}", inv.why)};
    }
    r.nominal_joints_rad = *inv.joints_rad;
    return std::nullopt;
  }

  // Compensated joints `q` outside the joint arcs or the volume the set was validated on.
  Refusal OutsideVolume(const Eigen::VectorXd& q) const {
    if (!volume_ || volume_->empty()) return {};
    if (auto why = volume_->OutsideJoints(q))
      return {TargetStatus::kOutsideJointRange, fmt::format("{} ({})", *why, volume_->source())};
    if (const double d = volume_->DistanceOutside(SignedCalibrationPoint(robot_, q)); d > 1e-6)
      return {TargetStatus::kOutsideMeasuredVolume,
              fmt::format("the calibration point lies {:.1f} mm outside the volume measured in {}", d,
                          volume_->source())};
    return {};
  }

  // The compensated joints `q` in another configuration than the program's numbers ask for
  // (the controller's nominal joints `nominal`; a UR: its solution nearest where it starts).
  std::optional<Refusal> ConfigurationChange(const Target& t, const Eigen::Isometry3d& tool,
                                             const Eigen::Isometry3d& written, const Intent& intent,
                                             const Eigen::VectorXd& nominal_q, const Eigen::VectorXd& q) const {
    const bool pose_target = t.kind() == TargetKind::kPose;
    const ArmConfiguration nominal = ConfigurationOf(c_, nominal_q);
    const ArmConfiguration compensated = ConfigurationOf(c_, q);
    if (pose_target && c_.kind == ControllerKind::kUniversalRobots) {
      InverseRequest again;
      again.tcp = written;
      again.tool = tool;
      again.near_rad = intent.near;
      const InverseSolution back = ControllerInverse(c_, again);
      if (!back.joints_rad || (*back.joints_rad - q).cwiseAbs().maxCoeff() > 1e-5)
        return Refusal{TargetStatus::kConfigurationChange,
                       "the controller's solution nearest the joints it starts from is another configuration "
                       "than the compensated joints"};
    } else if (pose_target && HasStated(t.config)) {
      if (!Matches(t.config, compensated)) {
        StatedConfiguration got;
        if (t.config.abb_cf) got.abb_cf = compensated.abb_cf;
        if (t.config.kuka_status) got.kuka_status = compensated.kuka_status;
        if (t.config.kuka_turn) got.kuka_turn = compensated.kuka_turn;
        return Refusal{TargetStatus::kConfigurationChange,
                       fmt::format("the compensated joints are in configuration {}, the program's {}",
                                   Describe(got), Describe(t.config))};
      }
    } else if (nominal.overhead != compensated.overhead || nominal.elbow != compensated.elbow ||
               nominal.wrist != compensated.wrist) {
      return Refusal{TargetStatus::kConfigurationChange,
                     fmt::format("the compensated joints are {}, the program's {}", Flags(compensated),
                                 Flags(nominal))};
    }
    return std::nullopt;
  }

  // The support and predicted σ of compensated joints `q`; `outside_volume` says why they lie
  // outside the arcs or the volume the set was validated on ("" inside).
  void Promise(const Eigen::Isometry3d& tool, const Eigen::VectorXd& q, const std::string& outside_volume,
               TargetReport& r) const {
    const calibration::SetValidity none;
    const calibration::SetValidity& validity = robot_.validity ? *robot_.validity : none;
    const calibration::Support support =
        calibration::SupportAt(*robot_.model, robot_.params, validity, q, r.map_extrapolated);
    r.inside_support = support.inside && outside_volume.empty();
    if (r.inside_support) {
      r.support = "inside";
    } else if (outside_volume.empty()) {
      r.support = support.Describe(q, validity);
    } else {
      r.support = outside_volume;
      if (support.map_outside) r.support += "; outside the residual map";
    }
    // The parameters' own σ where the TCP is (the model's point moved to it), with the
    // held-out σ of inside or outside.
    const calibration::RobotModel at_tcp =
        calibration::AtPoint(*robot_.model, (robot_.model->flange * tool).translation());
    const double parametric =
        calibration::ParametricSigmaMm(at_tcp, robot_.params, robot_.identified, robot_.covariance, q);
    r.sigma_mm = calibration::PredictionSigmaMm(parametric, validity, r.inside_support);
  }

  const Program& p_;
  const ControllerModel& c_;
  const SignedRobot& robot_;
  const ValidatedVolume* volume_;
  const CompensationOptions& options_;
  std::map<int, std::vector<const Motion*>> uses_;
  std::set<int> rewritten_near_;
};

}  // namespace

ProgramCompensation CompensateProgram(const Program& program, const ControllerModel& controller,
                                      const SignedRobot& robot, const ValidatedVolume* volume,
                                      const CompensationOptions& options) {
  return Compensator(program, controller, robot, volume, options).Run();
}

}  // namespace armsig::programs
