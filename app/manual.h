// The manual page (roff, man section 1), the bash completion script and the command
// reference (Markdown, docs/reference/commands.md), generated from the CLI11 tree that main()
// parses with: `armsig generate man|bash-completion|markdown` (hidden), run by the build to
// produce the installed files and by a test that keeps the checked-in reference current.
#pragma once

#include <CLI/CLI.hpp>
#include <string>

namespace armsig::app {

std::string ManPage(const CLI::App& app, const std::string& version, const std::string& date);
std::string BashCompletion(const CLI::App& app);
std::string MarkdownReference(const CLI::App& app);

}  // namespace armsig::app
