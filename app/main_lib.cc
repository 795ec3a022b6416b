#include <SQLiteCpp/Exception.h>
#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>

#include <cstdlib>
#include <iostream>

#include "app/command.h"
#include "core/error.h"

namespace armsig::app {

std::string GlobalOptions::DbPath() const {
  if (!db_path.empty()) return db_path;
  if (const char* env = std::getenv("ARMSIG_DB"); env && *env) return env;
  return "armsig.db";
}

void SetupAll(CLI::App& app, GlobalOptions& global, Runner& run) {
  app.require_subcommand(1);
  app.set_version_flag("--version", std::string("armsig ") + ARMSIG_VERSION);
  app.add_option("--db", global.db_path,
                 "SQLite database file (default: $ARMSIG_DB, else ./armsig.db)");
  app.add_flag("-v,--verbose", global.verbosity, "More log output on stderr (repeat for more)");
  app.add_flag("-q,--quiet", global.quiet, "Only warnings and errors on stderr");
  SetupDemoCommand(app, global, run);
  SetupOrientCommand(app, global, run);
  SetupTriangulateCommand(app, global, run);
  SetupCalibrateCommand(app, global, run);
  SetupCaptureCommand(app, global, run);
  SetupReduceCommand(app, global, run);
  SetupRecalibrateCommand(app, global, run);
  SetupImportCommand(app, global, run);
  SetupInstrumentCommand(app, global, run);
  SetupDbCommand(app, global, run);
  SetupSignatureCommands(app, global, run);
}

int Main(int argc, const char* const* argv) {
  CLI::App app{
      "armsig: measure an industrial robot with external instruments and fit its arm signature "
      "(Chen & Chao error model)",
      "armsig"};
  GlobalOptions global;
  Runner run;
  SetupAll(app, global, run);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    const int code = app.exit(e);  // prints help / version / the usage error
    return code == 0 ? kOk : kInputError;
  }
  auto logger = spdlog::stderr_color_st("armsig");
  spdlog::set_default_logger(logger);
  spdlog::set_pattern("armsig: %^%l%$: %v");
  // Progress and decisions (info) by default; -q keeps warnings, -v adds the details.
  spdlog::set_level(global.quiet            ? spdlog::level::warn
                    : global.verbosity >= 2 ? spdlog::level::trace
                    : global.verbosity == 1 ? spdlog::level::debug
                                            : spdlog::level::info);
  try {
    return run ? run() : kInputError;
  } catch (const InputError& e) {
    spdlog::error("{}", e.what());
    return kInputError;
  } catch (const QualityGateError& e) {
    spdlog::error("quality gate failed: {}", e.what());
    return kQualityGate;
  } catch (const SQLite::Exception& e) {
    spdlog::error("database error: {} (SQLite code {})", e.what(), e.getErrorCode());
    return kFailure;
  } catch (const std::exception& e) {
    spdlog::error("failed: {}", e.what());
    return kFailure;
  }
}

}  // namespace armsig::app
