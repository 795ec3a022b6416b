#include "demo/demo_paths.h"

#include <fmt/format.h>

#include <chrono>
#include <cmath>
#include <functional>
#include <thread>
#include <vector>

#include "calibration/compensation.h"
#include "calibration/iso9283_path.h"
#include "instruments/emscon_device.h"
#include "programs/controller.h"
#include "simulation/path_motion.h"
#include "simulation/ur_simulator.h"

namespace armsig::demo {

namespace {

namespace iso = calibration::iso9283;

constexpr double kSpeed = 250.0, kAcceleration = 1200.0, kDt = 0.004;

// The controller's model, its TCP (the reflector where the nominal model puts it, on the
// controller's flange: tool0 need not be the model's last link frame) and the home pose.
struct Cell {
  programs::ControllerModel controller;
  Eigen::Isometry3d tool = Eigen::Isometry3d::Identity();
  Eigen::VectorXd home;
  Eigen::Isometry3d home_tcp = Eigen::Isometry3d::Identity();
};

Cell CellOf(const DemoLab& lab, const calibration::RobotModel& model) {
  Cell c;
  c.controller = simulation::UrControllerModel(lab.robot_truth().kinematics);
  c.home = lab.home();
  calibration::Kinematics kin(model);
  const Eigen::Vector3d reflector = kin.Position(
      Eigen::Isometry3d::Identity(), Eigen::VectorXd::Zero(model.num_parameters()), c.home.data());
  c.tool.translation() = programs::FlangePose(c.controller, c.home).inverse() * reflector;
  c.home_tcp = programs::TcpPose(c.controller, c.home, c.tool);
  return c;
}

// The controller's joint paths through the vertices (the same every cycle), and the joints it
// starts each cycle from: a vertex's command is the TCP at the vertex (the home's orientation),
// or, compensated, where the controller must be sent so the calibrated robot lands there.
struct Program {
  Eigen::VectorXd start;
  std::vector<std::vector<Eigen::VectorXd>> legs;
};

Program ProgramOf(const Cell& cell, const calibration::RobotModel& model,
                  const Eigen::VectorXd& params, const std::vector<Eigen::Vector3d>& vertices,
                  bool compensated) {
  std::vector<Eigen::Isometry3d> commands;
  Program p;
  Eigen::VectorXd near = cell.home;
  for (const Eigen::Vector3d& v : vertices) {
    Eigen::Isometry3d tcp = cell.home_tcp;
    tcp.translation() = v;
    const auto solved = programs::ControllerInverse(cell.controller, {tcp, cell.tool, {}, near});
    if (!solved.joints_rad) throw std::runtime_error("demo: ISO 9283 path vertex out of reach: " + solved.why);
    Eigen::VectorXd q = *solved.joints_rad;
    if (compensated) {
      const auto c = calibration::SolveJoints(model, Eigen::Isometry3d::Identity(), params, v, q);
      if (c.status.ok()) q = c.joints_rad;
      tcp = programs::TcpPose(cell.controller, q, cell.tool);
    }
    if (commands.empty()) p.start = q;
    commands.push_back(tcp);
    near = q;
  }
  for (size_t k = 1; k < commands.size(); ++k) {
    simulation::LinearPathRequest r;
    // From where the leg before ended (the controller follows its solutions along the path;
    // another branch at a vertex would be a jump).
    r.start_rad = p.legs.empty() ? p.start : p.legs.back().back();
    r.to_tcp = commands[k];
    r.tool = cell.tool;
    r.speed_mm_s = kSpeed;
    r.acceleration_mm_s2 = kAcceleration;
    r.dt_s = kDt;
    std::string why;
    auto leg = simulation::LinearPath(cell.controller, r, &why);
    if (!leg) throw std::runtime_error("demo: ISO 9283 path: " + why);
    p.legs.push_back(std::move(*leg));
  }
  return p;
}

// One cycle: the arm to the start, the tracker measuring every 4 ms of its clock while the arm
// runs the legs; the points in the robot frame.
iso::AttainedCycle RunCycle(simulation::VirtualArm& arm, instruments::EmsconDevice& tracker,
                            const Program& program, const StationPose& station,
                            const Eigen::Isometry3d& base_from_world) {
  const auto stand = [&] {
    while (arm.Now().moving) std::this_thread::sleep_for(std::chrono::milliseconds(1));
  };
  arm.MoveJ(program.start, 1.4, 1.05);
  std::this_thread::sleep_for(std::chrono::milliseconds(2));
  stand();
  tracker.StartContinuous({4, std::nullopt});
  std::atomic<bool> done{false};
  iso::AttainedCycle cycle;
  const std::function<void(const instruments::ContinuousRecord&)> keep =
      [&](const instruments::ContinuousRecord& rec) {
        const Eigen::Vector3d world =
            station.position_mm + station.world_from_station * rec.point_in_instrument_mm;
        cycle.samples.push_back({rec.tracker_time_s, base_from_world * world});
      };
  std::thread reader(
      [&] { tracker.ReadContinuous(instruments::Clock::now() + std::chrono::minutes(10), done, keep, {}); });
  for (const auto& leg : program.legs) {
    arm.MovePath(leg, kDt);
    stand();
  }
  done = true;
  reader.join();
  tracker.StopContinuous(keep);  // and what the reader had not read yet: the last leg's end
  return cycle;
}

nlohmann::json FiguresJson(const iso::PathFigures& f, double& cr, double& co) {
  nlohmann::json j = {{"cycles", f.n},          {"AT_mm", f.at_mm},
                      {"mean_AT_mm", f.mean_at_mm}, {"RT_mm", f.rt_mm},
                      {"AV_percent", f.av_percent}, {"RV_percent", f.rv_percent},
                      {"FV_mm_s", f.fv_mm_s},   {"planes", f.planes_used}};
  cr = co = 0.0;
  for (const auto& corner : f.corners) {
    cr = std::max(cr, corner.cr_max_mm);
    if (!std::isnan(corner.co_max_mm)) co = std::max(co, corner.co_max_mm);
  }
  if (!f.corners.empty()) {
    j["CR_mm"] = cr;
    j["CO_mm"] = co;
  }
  return j;
}

}  // namespace

DemoPathFigures MeasureIso9283Paths(const DemoLab& lab, const calibration::RobotModel& model,
                                    const calibration::EstimationResult& fit,
                                    const io::LabConfig& lab_config, const std::atomic<bool>* stop) {
  DemoPathFigures out;
  const Cell cell = CellOf(lab, model);
  const iso::TestPaths paths = iso::BuildTestPaths({cell.home_tcp.translation(), 300.0});
  instruments::EmsconDevice tracker(
      instruments::MakeEmsconTcpTransport("127.0.0.1", lab.tracker()->port()), lab_config.policy);
  simulation::VirtualArm& arm = lab.ur()->arm();
  const StationPose& station = lab_config.stations.front().pose;
  const Eigen::Isometry3d base_from_world = fit.world_from_base.inverse();
  struct Case {
    const char* name;
    const std::vector<Eigen::Vector3d>* vertices;
    int cycles;
  };
  const Case cases[] = {{"line", &paths.line_mm, 10}, {"rectangle", &paths.rectangle_mm, 3}};
  for (const Case& c : cases) {
    for (const bool compensated : {false, true}) {
      if (stop && stop->load()) {
        out.stopped = true;
        return out;
      }
      const Program program = ProgramOf(cell, model, fit.params, *c.vertices, compensated);
      std::vector<iso::AttainedCycle> attained;
      for (int k = 0; k < c.cycles; ++k)
        attained.push_back(RunCycle(arm, tracker, program, station, base_from_world));
      // Speeds over 100 ms (25 records): over one record's 4 ms the tracker's noise alone
      // would be 10 mm/s.
      iso::PathOptions options;
      options.speed_stride = 25;
      const iso::PathFigures f = iso::EvaluatePath({*c.vertices, kSpeed}, attained, options);
      double cr = 0.0, co = 0.0;
      out.json[c.name][compensated ? "compensated" : "original"] = FiguresJson(f, cr, co);
      out.table += fmt::format(
          "  {:<10} {:<12} {:>7.3f} {:>7.3f} {:>7.3f} {:>8.2f} {:>7.2f} {:>7.1f}{}\n", c.name,
          compensated ? "compensated" : "original", f.at_mm, f.mean_at_mm, f.rt_mm, f.av_percent,
          f.rv_percent, f.fv_mm_s,
          f.corners.empty() ? std::string() : fmt::format("  CR {:.3f} CO {:.3f}", cr, co));
    }
  }
  return out;
}

}  // namespace armsig::demo
