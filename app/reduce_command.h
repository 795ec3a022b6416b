#pragma once

#include "app/command.h"

namespace armsig::app {

void SetupImportObservations(CLI::App& import, const GlobalOptions& global, Runner& run);

}  // namespace armsig::app
