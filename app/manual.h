// The manual page (roff, man section 1) and the bash completion script, generated from
// the CLI11 tree that main() parses with: `armsig generate man|bash-completion` (hidden),
// run by the build to produce the installed files.
#pragma once

#include <CLI/CLI.hpp>
#include <string>

namespace armsig::app {

std::string ManPage(const CLI::App& app, const std::string& version, const std::string& date);
std::string BashCompletion(const CLI::App& app);

}  // namespace armsig::app
