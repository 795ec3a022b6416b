// armsig demo: the main job on the embedded default.
#include <iostream>

#include "app/command.h"

namespace armsig::app {

struct DemoOptions {
  std::string json;
};

void SetupDemoCommand(CLI::App& parent, const GlobalOptions&, Runner& run) {
  auto options = std::make_shared<DemoOptions>();
  auto* sub = parent.add_subcommand(
      "demo", "The whole chain on a virtual lab: capture, reduction, calibration");
  sub->add_option("--json", options->json, "Write the demo's results as JSON");
  sub->callback([&run] {
    run = [] {
      std::cerr << "armsig demo: the virtual lab (instrument simulators, capture, reduction) is "
                   "not built yet (issue #6); nothing was done.\n";
      return static_cast<int>(kFailure);
    };
  });
}

}  // namespace armsig::app
