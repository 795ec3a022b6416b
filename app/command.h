// The command-line face of armsig. Each command has a Setup… that declares its CLI11
// subcommand and a Run… that takes the parsed options and returns an exit code, so
// tests call Run… without a shell. Exit codes (SPEC): 0 ok, 1 failure, 2 usage or
// input error, 3 a quality gate failed.
#pragma once

#include <CLI/CLI.hpp>
#include <functional>
#include <string>

namespace armsig::app {

enum ExitCode : int { kOk = 0, kFailure = 1, kInputError = 2, kQualityGate = 3 };

struct GlobalOptions {
  std::string db_path;  // --db; empty = $ARMSIG_DB, else ./armsig.db
  int verbosity = 0;  // -v: debug, -vv: trace
  bool quiet = false;  // -q: warnings and errors only
  std::string DbPath() const;
};

using Runner = std::function<int()>;

void SetupDemoCommand(CLI::App& parent, const GlobalOptions& global, Runner& run);
void SetupOrientCommand(CLI::App& parent, const GlobalOptions& global, Runner& run);
void SetupTriangulateCommand(CLI::App& parent, const GlobalOptions& global, Runner& run);
void SetupCalibrateCommand(CLI::App& parent, const GlobalOptions& global, Runner& run);
void SetupCaptureCommand(CLI::App& parent, const GlobalOptions& global, Runner& run);
void SetupReduceCommand(CLI::App& parent, const GlobalOptions& global, Runner& run);
void SetupRecalibrateCommand(CLI::App& parent, const GlobalOptions& global, Runner& run);
void SetupImportCommand(CLI::App& parent, const GlobalOptions& global, Runner& run);
void SetupInstrumentCommand(CLI::App& parent, const GlobalOptions& global, Runner& run);
void SetupDbCommand(CLI::App& parent, const GlobalOptions& global, Runner& run);
void SetupSignatureCommands(CLI::App& parent, const GlobalOptions& global, Runner& run);

// Builds the whole CLI (used by main and by tests).
void SetupAll(CLI::App& app, GlobalOptions& global, Runner& run);

// Parses argv and runs the chosen command; every exception becomes its exit code with
// a message on stderr. What main() does, callable from tests.
int Main(int argc, const char* const* argv);

}  // namespace armsig::app
