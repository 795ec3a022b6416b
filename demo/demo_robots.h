// The robots of `armsig demo --robot NAME`, one entry each: adding a robot is an entry in
// demo_robots.cc (its model, its controller's protocol, its calibration stages) and, for a new
// controller, the branch that starts its simulator in DemoLab (demo/demo_lab.cc).
#pragma once

#include <string>
#include <vector>

#include "io/lab_file.h"

namespace armsig::demo {

struct DemoRobot {
  std::string name;         // --robot: puma, ur10, kuka, abb
  std::string db_robot;     // its robot in the database: puma760-demo, ur10-demo
  std::string description;  // "a PUMA 760 (hidden errors: the paper's Table 3)"
  std::string model_file;   // the model's file in the lab folder: puma760.yaml
  const char* model_yaml = nullptr;  // its text (io/builtin_models.h)
  io::ControllerProtocol controller = io::ControllerProtocol::kKawasakiAs;  // its lab file's
  std::string controller_text;       // "a Kawasaki-AS-style controller on a pseudo-terminal"
  bool tracker_only = false;         // measured by the laser tracker alone
  bool paper = false;                // the narrative compares with the paper's figures
  std::vector<std::string> stages;   // the calibration's parameter sets, in order
  double time_scale = 0.25;          // --time-scale when not given
  std::string not_built;             // the answer while its controller is not built yet
};

const std::vector<DemoRobot>& DemoRobots();
// "puma, ur10, kuka or abb"
std::string DemoRobotChoices();
// The robot's entry; InputError naming --robot for an unknown name, or with the entry's
// answer for one whose controller is not built yet.
const DemoRobot& FindDemoRobot(const std::string& name);
// The entry whose database robot is `db_robot` (a resumed session's), nullptr when none.
const DemoRobot* DemoRobotOfStored(const std::string& db_robot);

}  // namespace armsig::demo
