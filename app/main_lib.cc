#include <SQLiteCpp/Exception.h>
#include <fmt/format.h>
#include <glog/logging.h>
#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>
#include <unistd.h>

#include <charconv>
#include <cmath>
#include <csignal>
#include <cstdlib>
#include <filesystem>
#include <iostream>
#include <memory>
#include <mutex>

#include "app/command.h"
#include "app/manual.h"
#include "armsig_git.h"
#include "core/error.h"
#include "core/plausibility.h"
#include "core/text.h"
#include "db/connection.h"
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

CLI::Option* NumberOption(CLI::Option* option, double min, double max) {
  return option->check(NumberCheck(min, max));
}

CLI::Option* AddSetOption(CLI::App& sub, std::optional<int>& set) {
  return NumberOption(
      sub.add_option("--set", set,
                     "A stored parameter set by its version (armsig versions); default: the "
                     "active one"),
      1, 1e9);
}

CLI::Validator NumberCheck(double min, double max) {
  const std::string range = fmt::format("{:g} to {:g}", min, max);
  return CLI::Validator(
      [min, max, range](std::string& text) -> std::string {
        double value = 0.0;
        const char* first = text.data() + (text.starts_with('+') ? 1 : 0);
        const char* last = text.data() + text.size();
        const auto [end, error] = std::from_chars(first, last, value);
        if (first == last || error != std::errc() || end != last) {
          return "expected a number from " + range + ", got " + Quoted(text);
        }
        if (!std::isfinite(value) || value < min || value > max) {
          return "expected a finite number from " + range + ", got " + Quoted(text);
        }
        return {};
      },
      "NUMBER " + range, "number in range");
}

void OnExistingDatabase(CLI::App* sub, const GlobalOptions& global, Runner& run,
                        std::function<int(db::Database&)> job) {
  sub->callback([&run, &global, job] {
    run = [&global, job] {
      db::Database database(global.DbPath(), db::OpenMode::kMustExist);
      return job(database);
    };
  });
}

void OnDatabaseToRead(CLI::App* sub, const GlobalOptions& global, Runner& run,
                      std::function<int(db::Database&)> job) {
  sub->callback([&run, &global, job] {
    run = [&global, job] {
      db::Database database(global.DbPath(), db::OpenMode::kReadOnly);
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
                 "The store: an SQLite file, or a PostgreSQL database as a libpq URI "
                 "(postgresql://HOST/DB; credentials from libpq's environment, ~/.pgpass or a "
                 "service file, never in the URI) (default: $ARMSIG_DB, else ./armsig.db)");
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
  SetupIso9283Commands(app, global, run);
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

namespace {

// Every log line is shown, never obeyed: a control character or a byte that is not UTF-8
// in a message (a file name, a value echoed from a file, a name from a database or a
// device) is written as an escape (core/text.h Printable), and a line break inside a
// message is kept but indented, so that no text can begin a line of its own that reads
// like one of armsig's ("armsig: info: …").
// Thread-safe (the _mt sink's own mutex): `worker --jobs N` logs from several threads.
class PrintableSink final : public spdlog::sinks::stderr_color_sink_mt {
 public:
  void log(const spdlog::details::log_msg& msg) override {
    const std::string_view payload(msg.payload.data(), msg.payload.size());
    std::string text;
    for (size_t start = 0;;) {
      const size_t end = payload.find('\n', start);
      text += Printable(payload.substr(start, end == std::string_view::npos ? end : end - start));
      if (end == std::string_view::npos) break;
      text += "\n  ";
      start = end + 1;
    }
    spdlog::details::log_msg printable(msg);
    printable.payload = text;
    spdlog::sinks::stderr_color_sink_mt::log(printable);
  }
};

// Ceres logs through glog: its warnings ("Error in evaluating the ResidualBlock", a dump of
// parameter blocks) are for its developers. They go to the debug log (-v); what the user
// reads is armsig's own message from the solver's status. Only glog's FATAL (a failed CHECK,
// a bug) still reaches stderr, as it ends the process.
class GlogToSpdlog final : public google::LogSink {
 public:
  void send(google::LogSeverity severity, const char*, const char* base_filename, int line,
            const google::LogMessageTime&, const char* message, size_t length) override {
    spdlog::log(severity >= google::GLOG_ERROR ? spdlog::level::debug : spdlog::level::trace,
                "ceres ({}:{}): {}", base_filename, line, std::string_view(message, length));
  }
};

void RouteCeresLogging() {
  static std::once_flag once;
  std::call_once(once, [] {
    if (!google::IsGoogleLoggingInitialized()) google::InitGoogleLogging("armsig");
    for (google::LogSeverity s :
         {google::GLOG_INFO, google::GLOG_WARNING, google::GLOG_ERROR, google::GLOG_FATAL}) {
      google::SetLogDestination(s, "");  // no log files
    }
    FLAGS_logtostderr = false;
    FLAGS_stderrthreshold = google::GLOG_FATAL;
    static GlogToSpdlog sink;
    google::AddLogSink(&sink);
  });
}

}  // namespace

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
  } catch (const CLI::CallForVersion& e) {
    // `--version` after a command (it falls through to the program's own): a script asking
    // for parameter set 3 must not get the program's version and exit 0.
    if (!app.get_subcommands().empty()) {
      std::cerr << "armsig: error: --version after a command is the program's version (armsig "
                   "--version); a stored parameter set is chosen with --set N\n";
      return kInputError;
    }
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    const int code = app.exit(e);  // prints help / version / the usage error
    return code == 0 ? kOk : kInputError;
  }
  auto logger = std::make_shared<spdlog::logger>("armsig", std::make_shared<PrintableSink>());
  spdlog::set_default_logger(logger);
  RouteCeresLogging();
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
  } catch (const db::DatabaseError& e) {
    spdlog::error("database error: {}", e.what());
    return kFailure;
  } catch (const std::exception& e) {
    spdlog::error("failed: {}", e.what());
    return kFailure;
  }
}

}  // namespace armsig::app
