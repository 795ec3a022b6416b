#include "simulation/program_runner.h"

#include <fmt/format.h>

#include <algorithm>
#include <random>

namespace armsig::simulation {

Eigen::Isometry3d TrueTcp(const TrueRobot& robot, const Eigen::Isometry3d& tool, const Eigen::VectorXd& q) {
  const Eigen::Isometry3d flange_tool = robot.model.flange * tool;
  const calibration::RobotModel model = calibration::AtPoint(robot.model, flange_tool.translation());
  calibration::Kinematics kin(model);
  Eigen::Isometry3d tcp = Eigen::Isometry3d::Identity();
  const Eigen::VectorXd true_angles = robot.joint_errors.TrueAngles(q);
  tcp.translation() = kin.Position(Eigen::Isometry3d::Identity(), robot.params, true_angles.data());
  tcp.linear() = kin.LastRotation() * flange_tool.linear();
  return tcp;
}

Execution RunProgram(const programs::Program& program, const programs::ControllerModel& controller,
                     const Eigen::VectorXd& start_rad) {
  Execution out;
  Eigen::VectorXd at = start_rad;
  const int n = controller.num_joints();
  for (const programs::Motion& m : program.motions) {
    if (!m.tool.known()) {
      out.skipped.push_back({m.place, fmt::format("{}: the tool: {}", m.instruction, m.tool.unknown_why)});
      continue;
    }
    std::vector<ExecutedTarget> reached;
    std::string why;
    for (int index : m.targets) {
      const programs::Target& t = program.targets[static_cast<std::size_t>(index)];
      ExecutedTarget e;
      e.motion = m.place;
      e.instruction = m.instruction;
      e.target = index;
      e.tool = *m.tool.transform;
      if (t.kind() == programs::TargetKind::kJoints) {
        if (static_cast<int>(t.fields.size()) != n) {
          why = fmt::format("{} joint values for {} joints", t.fields.size(), n);
          break;
        }
        e.joints_rad = programs::JointsOf(t);
        e.commanded = programs::TcpPose(controller, e.joints_rad, e.tool);
      } else {
        if (!m.base.known()) {
          why = "the base: " + m.base.unknown_why;
          break;
        }
        e.commanded = *m.base.transform * programs::PoseOf(t);
        programs::InverseRequest request;
        request.tcp = e.commanded;
        request.tool = e.tool;
        request.stated = t.config;
        request.stated.near_target.reset();
        request.near_rad = at;
        if (t.config.near_target) {
          const auto& near = program.targets[static_cast<std::size_t>(*t.config.near_target)];
          if (static_cast<int>(near.fields.size()) == n) request.near_rad = programs::JointsOf(near);
        }
        const programs::InverseSolution s = programs::ControllerInverse(controller, request);
        if (!s.joints_rad) {
          why = "the controller's inverse: " + s.why;
          break;
        }
        e.joints_rad = *s.joints_rad;
      }
      at = e.joints_rad;
      reached.push_back(std::move(e));
    }
    if (!why.empty()) {
      out.skipped.push_back({m.place, fmt::format("{}: {}", m.instruction, why)});
      continue;
    }
    for (auto& e : reached) out.targets.push_back(std::move(e));
  }
  return out;
}

std::vector<ProgramStep> StepsOf(const Execution& run, const std::vector<programs::Wait>& waits) {
  std::vector<ProgramStep> steps;
  for (const ExecutedTarget& e : run.targets) steps.push_back({e.motion.line, e.joints_rad, 0.0});
  for (const programs::Wait& w : waits) steps.push_back({w.place.line, std::nullopt, w.seconds});
  std::stable_sort(steps.begin(), steps.end(),
                   [](const ProgramStep& a, const ProgramStep& b) { return a.line < b.line; });
  return steps;
}

ProgramPlayer::Status ProgramPlayer::Tick(VirtualArm& arm,
                                          const std::function<void(const Eigen::VectorXd&)>& move) {
  const VirtualArm::State s = arm.Now();
  if (s.stop != VirtualArm::Stop::kNone || !s.powered) return Status::kStopped;
  if (s.moving || s.t < wait_until_) return Status::kRunning;
  wait_until_ = -1.0;
  if (next_ == steps_.size()) return Status::kFinished;
  const ProgramStep& step = steps_[next_++];
  if (step.joints_rad) {
    move(*step.joints_rad);
  } else {
    wait_until_ = s.t + step.wait_s;
  }
  return Status::kRunning;
}

std::vector<Eigen::Vector3d> MeasureLandings(const VirtualCell& cell, const Execution& run) {
  std::mt19937 rng(cell.seed);
  std::normal_distribution<double> unit(0.0, 1.0);
  auto noise = [&](double sigma) -> Eigen::Vector3d {
    return Eigen::Vector3d(unit(rng), unit(rng), unit(rng)) * sigma;
  };
  std::vector<Eigen::Vector3d> out;
  for (const ExecutedTarget& e : run.targets) {
    const Eigen::Vector3d landed = TrueTcp(cell.robot, e.tool, e.joints_rad).translation() +
                                   noise(cell.repeatability_mm);
    const Eigen::Vector3d in_lab = cell.lab_from_base * landed;
    out.push_back(in_lab + noise(TrackerSigmaMm(cell.tracker, in_lab.norm())));
  }
  return out;
}

}  // namespace armsig::simulation
