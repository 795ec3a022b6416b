// Commands whose capability is not built yet: present in --help, and saying so (exit 1).
#include <iostream>

#include "app/command.h"

namespace armsig::app {

namespace {

void NotYet(CLI::App& parent, const std::string& name, const std::string& description,
            const std::string& issue, Runner& run) {
  auto* sub = parent.add_subcommand(name, description + " [not yet implemented]");
  sub->allow_extras();
  sub->callback([&run, name, issue] {
    run = [name, issue] {
      std::cerr << "armsig " << name << ": not yet implemented (tracked in issue " << issue
                << "); nothing was done.\n";
      return static_cast<int>(kFailure);
    };
  });
}

}  // namespace

void SetupRecalibrateCommand(CLI::App& parent, const GlobalOptions&, Runner& run) {
  NotYet(parent, "recalibrate", "The nightly recalibration job", "#7", run);
}

}  // namespace armsig::app
