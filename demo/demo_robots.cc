#include "demo/demo_robots.h"

#include "core/error.h"
#include "core/text.h"
#include "io/builtin_models.h"

namespace armsig::demo {

const std::vector<DemoRobot>& DemoRobots() {
  static const std::vector<DemoRobot> robots = [] {
    std::vector<DemoRobot> r;
    DemoRobot puma;
    puma.name = "puma";
    puma.db_robot = "puma760-demo";
    puma.description = "a PUMA 760 (hidden errors: the paper's Table 3)";
    puma.model_file = "puma760.yaml";
    puma.model_yaml = io::kPuma760Yaml;
    puma.controller = io::ControllerProtocol::kKawasakiAs;
    puma.controller_text = "a robot controller on a pseudo-terminal";
    puma.paper = true;
    puma.stages = {"geometric", "geometric,h3,h4", "all"};
    puma.time_scale = 0.25;
    r.push_back(puma);
    DemoRobot ur10;
    ur10.name = "ur10";
    ur10.db_robot = "ur10-demo";
    ur10.description =
        "a Universal Robots UR10 (hidden errors: geometric, and joint-angle errors of a few "
        "arc-seconds periodic in each joint's angle)";
    ur10.model_file = "ur10.yaml";
    ur10.model_yaml = io::kUr10Yaml;
    ur10.controller = io::ControllerProtocol::kUr;
    ur10.controller_text =
        "its e-Series controller speaking RTDE, the primary and secondary interfaces and the "
        "dashboard server on loopback TCP";
    ur10.tracker_only = true;
    ur10.stages = {"geometric", "all"};
    ur10.time_scale = 0.02;  // moves take the real arm's time: 50 times faster
    r.push_back(ur10);
    DemoRobot kuka;
    kuka.name = "kuka";
    kuka.db_robot = "kr16-demo";
    kuka.description =
        "a KUKA KR 16-2 (hidden errors: geometric, and joint-angle errors of a few arc-seconds "
        "periodic in each joint's angle)";
    kuka.model_file = "kr16_2.yaml";
    kuka.model_yaml = io::kKr16Yaml;
    kuka.controller = io::ControllerProtocol::kKuka;
    kuka.controller_text =
        "its KR C4 controller running ARMSIG, read and commanded through a variable server "
        "(KukaVarProxy's protocol) on loopback TCP";
    kuka.tracker_only = true;
    kuka.stages = {"geometric", "all"};
    kuka.time_scale = 0.02;  // moves take the real arm's time: 50 times faster
    r.push_back(kuka);
    DemoRobot abb;
    abb.name = "abb";
    abb.db_robot = "irb4600-demo";
    abb.description =
        "an ABB IRB 4600-40/2.55 (hidden errors: geometric, and joint-angle errors of a few "
        "arc-seconds periodic in each joint's angle)";
    abb.model_file = "irb4600.yaml";
    abb.model_yaml = io::kIrb4600Yaml;
    abb.controller = io::ControllerProtocol::kAbb;
    abb.controller_text =
        "its OmniCore controller speaking Robot Web Services 2.0 over TLS on loopback TCP, "
        "running armsig's RAPID module";
    abb.tracker_only = true;
    abb.stages = {"geometric", "all"};
    abb.time_scale = 0.02;  // moves take the real arm's time: 50 times faster
    r.push_back(abb);
    return r;
  }();
  return robots;
}

std::string DemoRobotChoices() {
  std::string list;
  const auto& robots = DemoRobots();
  for (size_t k = 0; k < robots.size(); ++k)
    list += (k == 0 ? "" : k + 1 == robots.size() ? " or " : ", ") + robots[k].name;
  return list;
}

const DemoRobot& FindDemoRobot(const std::string& name) {
  for (const auto& r : DemoRobots()) {
    if (r.name != name) continue;
    if (!r.not_built.empty()) throw InputError({"--robot", 0, 0, ""}, name + ": " + r.not_built);
    return r;
  }
  throw InputError({"--robot", 0, 0, ""},
                   "expected " + DemoRobotChoices() + ", got " + Quoted(name));
}

const DemoRobot* DemoRobotOfStored(const std::string& db_robot) {
  for (const auto& r : DemoRobots()) {
    if (!r.db_robot.empty() && r.db_robot == db_robot) return &r;
  }
  return nullptr;
}

}  // namespace armsig::demo
