#include <SQLiteCpp/Exception.h>
#include <fmt/format.h>
#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>
#include <unistd.h>

#include <csignal>
#include <cstdlib>
#include <filesystem>
#include <iostream>
#include <memory>

#include "app/command.h"
#include "app/manual.h"
#include "armsig_git.h"
#include "core/error.h"
#include "core/plausibility.h"
#include "db/schema.h"
#include "io/atomic_file.h"

namespace armsig::app {

std::string GlobalOptions::DbPath() const {
  if (!db_path.empty()) return db_path;
  if (const char* env = std::getenv("ARMSIG_DB"); env && *env) return env;
  return "armsig.db";
}

namespace {

std::atomic<bool> g_stop{false};
std::atomic<int> g_signals{0};

void OnStopSignal(int signal) {
  g_stop = true;
  const int n = ++g_signals;
  if (n == 2) {
    static const char kMessage[] =
        "\narmsig: stopping at the next safe point (a third signal ends at once, leaving the "
        "work to be resumed)\n";
    [[maybe_unused]] const auto written = ::write(STDERR_FILENO, kMessage, sizeof kMessage - 1);
  } else if (n >= 3) {
    std::signal(signal, SIG_DFL);
    std::raise(signal);
  }
}

}  // namespace

const std::atomic<bool>& StopRequested() {
  static const bool installed = [] {
    for (int s : {SIGINT, SIGTERM, SIGHUP}) std::signal(s, OnStopSignal);
    return true;
  }();
  (void)installed;
  return g_stop;
}

namespace {

CLI::Option* CheckedOutput(CLI::Option* option, bool folder) {
  const std::string name = option->get_name();
  return option->check(CLI::Validator(
      [name, folder](std::string& path) -> std::string {
        try {
          if (folder) {
            io::CheckOutputDirectory(path, name);
          } else {
            io::CheckOutputFile(path, name);
          }
          return {};
        } catch (const InputError& e) {
          return e.message();  // CLI11 prefixes the option's name
        }
      },
      folder ? "DIR" : "FILE", "output path"));
}

}  // namespace

CLI::Option* OutputFile(CLI::Option* option) { return CheckedOutput(option, false); }

CLI::Option* NameOption(CLI::Option* option) {
  return option->check(CLI::Validator(
      [](std::string& text) { return plausible::CheckName(text).value_or(std::string()); }, "NAME",
      "name"));
}

CLI::Option* NoteOption(CLI::Option* option) {
  return option->check(CLI::Validator(
      [](std::string& text) { return plausible::CheckNote(text).value_or(std::string()); }, "TEXT",
      "note"));
}
CLI::Option* OutputDirectory(CLI::Option* option) { return CheckedOutput(option, true); }

void OnExistingDatabase(CLI::App* sub, const GlobalOptions& global, Runner& run,
                        std::function<int(db::Database&)> job) {
  sub->callback([&run, &global, job] {
    run = [&global, job] {
      db::Database database(global.DbPath(), db::OpenMode::kMustExist);
      return job(database);
    };
  });
}

std::string VersionText() {
  return fmt::format("armsig {} (git {}, database schema v{})", ARMSIG_VERSION, ARMSIG_GIT_COMMIT,
                     db::LatestSchemaVersion());
}

void SetupAll(CLI::App& app, GlobalOptions& global, Runner& run) {
  app.require_subcommand(1);
  // Global options anywhere: an option a (nested) subcommand does not know goes up to
  // its parent. Inherited by every subcommand created after this line, so it comes first.
  app.fallthrough();
  app.set_version_flag("--version", VersionText());
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
  SetupLifecycleCommands(app, global, run);
  SetupFleetCommands(app, global, run);
  // Hidden (no group): the build runs it to make the manual page and the completion.
  auto* generate = app.add_subcommand("generate", "Manual page or bash completion")->group("");
  auto what = std::make_shared<std::string>();
  generate->add_option("what", *what, "man | bash-completion")
      ->required()
      ->check(CLI::IsMember({"man", "bash-completion"}));
  generate->callback([&app, &run, what] {
    run = [&app, what] {
      std::cout << (*what == "man" ? ManPage(app, ARMSIG_VERSION, ARMSIG_GIT_DATE)
                                   : BashCompletion(app));
      return kOk;
    };
  });
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
  // _mt: `worker --jobs N` logs from several threads.
  auto logger = spdlog::stderr_color_mt("armsig");
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
