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
#include <map>
#include <memory>
#include <mutex>

#include "app/checked_stdout.h"
#include "app/command.h"
#include "app/manual.h"
#include "armsig_git.h"
#include "core/error.h"
#include "core/plausibility.h"
#include "core/text.h"
#include "db/connection.h"
#include "db/postgres_address.h"
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
std::atomic<bool> g_only_reads{false};  // OnlyReads: the command changes nothing
std::atomic<int> g_signals{0};
std::atomic<bool> g_polled{false};  // the running command looks at StopRequested()

void OnStopSignal(int signal) {
  g_stop = true;
  const int n = ++g_signals;
  if (!g_polled.load()) {
    // A command with no safe point of its own ends now, as it would at one: each write to
    // the store is a transaction (rolled back unless committed), each output file appears
    // whole or not at all (its temporary file is removed here).
    io::RemoveLiveTemporaries();
    static const char kStoppedMessage[] =
        "\narmsig: stopped by a signal before finishing (exit 130): every store write and "
        "output file is whole or absent; run the same command again\n";
    [[maybe_unused]] const auto written =
        ::write(STDERR_FILENO, kStoppedMessage, sizeof kStoppedMessage - 1);
    ::_exit(kStopped);
  }
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

// Every command, from before main (app/main.cc) and again at its start: a command that asks
// for StopRequested() stops at its own safe points; any other ends at once with exit 130
// (OnStopSignal). The three signals are unblocked too: a parent that blocked them (a shell's
// job control, a supervisor) must not leave one pending and unheard.
void InstallStopSignals() {
  sigset_t stop;
  sigemptyset(&stop);
  for (int s : {SIGINT, SIGTERM, SIGHUP}) {
    std::signal(s, OnStopSignal);
    sigaddset(&stop, s);
  }
  ::sigprocmask(SIG_UNBLOCK, &stop, nullptr);
}

const std::atomic<bool>& StopRequested() {
  g_polled = true;
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

CLI::Option* StoreOption(CLI::Option* option) {
  const std::string name = option->get_name();
  return option->check(CLI::Validator(
      [name](std::string& text) -> std::string {
        try {
          db::CheckStoreAddress(text, name);
          return {};
        } catch (const InputError& e) {
          return e.message();  // CLI11 prefixes the option's name
        }
      },
      "STORE", "store address"));
}

CLI::Option* NumberOption(CLI::Option* option, double min, double max) {
  // Plain value names in --help, the manual and the completion: "--select N", not CLI11's
  // "INT:NUMBER 0 to 1e+06"; the range is in the message of a refused value.
  const std::string type = option->get_type_name();
  option->check(NumberCheck(min, max));
  option->type_name(type.find("INT") != std::string::npos ? "N" : "NUMBER");
  return option;
}

namespace {
// The choices of every ChoiceOption: the command line is built once per process (or per
// test), and options live as long as their App.
std::map<const CLI::Option*, std::vector<std::string>>& ChoiceRegistry() {
  static std::map<const CLI::Option*, std::vector<std::string>> registry;
  return registry;
}
}  // namespace

CLI::Option* ChoiceOption(CLI::Option* option, std::vector<std::string> choices,
                          std::function<std::string(const std::string&)> convert) {
  std::string list;
  for (size_t k = 0; k < choices.size(); ++k)
    list += (k == 0 ? "" : k + 1 == choices.size() ? " or " : ", ") + choices[k];
  CLI::Validator validator(
      [choices, list, convert](std::string& text) -> std::string {
        if (std::find(choices.begin(), choices.end(), text) != choices.end()) {
          if (convert) text = convert(text);
          return {};
        }
        const auto nearest = NearestKey(text, choices);
        return "expected " + list + ", got " + Quoted(text) +
               (nearest ? " (did you mean " + Quoted(*nearest) + "?)" : std::string());
      },
      "", "one of the choices");
  // A converting validator must be a transform (CLI11 hands a check a copy); it is the
  // option's only validator, so that no other sees the converted text.
  if (convert) {
    option->transform(validator);
  } else {
    option->check(validator);
  }
  std::string type;
  for (const auto& c : choices) type += (type.empty() ? "" : "|") + c;
  option->type_name(type);
  ChoiceRegistry()[option] = std::move(choices);
  return option;
}

const std::vector<std::string>& ChoicesOf(const CLI::Option* option) {
  static const std::vector<std::string> none;
  const auto it = ChoiceRegistry().find(option);
  return it == ChoiceRegistry().end() ? none : it->second;
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
      "", "number in range");
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
  OnlyReads(sub);
  sub->callback([&run, &global, job] {
    run = [&global, job]() -> int {
      db::Database database(global.DbPath(), db::OpenMode::kReadOnly);
      const int code = job(database);
      if (database.ChangedWhileRead()) {
        spdlog::error(
            "{}: another process wrote to the database while this command read it "
            "(a large write reached the file): what was printed may mix the states "
            "before and after; run the command again",
            database.path());
        return kFailure;
      }
      return code;
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
  StoreOption(app.add_option(
      "--db", global.db_path,
      "The store: an SQLite file, or a PostgreSQL database as a libpq URI "
      "(postgresql://HOST/DB) or key/value string ('host=HOST dbname=DB'); credentials from "
      "libpq's environment, ~/.pgpass or a service file, never in the address (default: "
      "$ARMSIG_DB, else ./armsig.db)"));
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
  // Hidden (no group): the build runs it to make the manual page and the completion, a test
  // to keep docs/reference/commands.md current.
  auto* generate =
      app.add_subcommand("generate", "Manual page, bash completion or command reference")->group("");
  auto what = std::make_shared<std::string>();
  generate->add_option("what", *what, "man | bash-completion | markdown")
      ->required()
      ->check(CLI::IsMember({"man", "bash-completion", "markdown"}));
  OnlyReads(generate);
  generate->callback([&app, &run, what] {
    run = [&app, what] {
      if (*what == "man") {
        std::cout << ManPage(app, ARMSIG_VERSION, ARMSIG_GIT_DATE);
      } else if (*what == "markdown") {
        std::cout << MarkdownReference(app);
      } else {
        std::cout << BashCompletion(app);
      }
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

void SetUpLogging() {
  auto logger = std::make_shared<spdlog::logger>("armsig", std::make_shared<PrintableSink>());
  spdlog::set_default_logger(logger);
  RouteCeresLogging();
  spdlog::set_pattern("armsig: %^%l%$: %v");
}

// Every option a command accepts: its own and (global options go up) its parents'.
std::vector<const CLI::Option*> OptionsOf(const CLI::App* command) {
  std::vector<const CLI::Option*> out;
  for (const CLI::App* app = command; app; app = app->get_parent()) {
    for (const CLI::Option* option : app->get_options()) out.push_back(option);
  }
  return out;
}

const CLI::Option* FindOption(const CLI::App* command, const std::string& token) {
  const bool is_long = token.rfind("--", 0) == 0;
  const std::string name = token.substr(is_long ? 2 : 1);
  for (const CLI::Option* option : OptionsOf(command)) {
    const auto& names = is_long ? option->get_lnames() : option->get_snames();
    if (std::find(names.begin(), names.end(), name) != names.end()) return option;
  }
  return nullptr;
}

std::string CommandPath(const CLI::App* command) {
  std::string path;
  for (const CLI::App* app = command; app && app->get_parent(); app = app->get_parent())
    path = app->get_name() + (path.empty() ? "" : " " + path);
  return path.empty() ? "armsig" : "armsig " + path;
}

// What was typed wrong, in the user's words: an unknown command or option named with the
// nearest valid one; else CLI11's own message. Found by walking the arguments the way the
// parser does (commands, then options with their values).
std::string ParseErrorText(const CLI::App& app, const CLI::ParseError& error, int argc,
                           const char* const* argv) {
  const CLI::App* command = &app;
  for (int k = 1; k < argc; ++k) {
    const std::string token = argv[k];
    if (token == "--") break;
    if (token.size() > 1 && token[0] == '-' && token != "-") {
      const std::string bare = token.substr(0, token.find('='));
      const CLI::Option* option = FindOption(command, bare);
      if (!option) {
        std::vector<std::string> names;
        for (const CLI::Option* o : OptionsOf(command)) {
          for (const auto& l : o->get_lnames()) names.push_back("--" + l);
        }
        const auto nearest = NearestKey(bare, names);
        return fmt::format("{}: unknown option {}{}", CommandPath(command), Quoted(bare),
                           nearest ? " (did you mean " + Quoted(*nearest) + "?)"
                                   : "; " + CommandPath(command) + " --help lists the options");
      }
      // An option's value is the next word unless it came with '=' or the option is a flag.
      if (bare == token && option->get_type_size_min() > 0 && option->get_expected_min() > 0)
        ++k;
      continue;
    }
    const auto subcommands = command->get_subcommands([](const CLI::App*) { return true; });
    const CLI::App* next = nullptr;
    for (const CLI::App* sub : subcommands) {
      if (sub->get_name() == token) next = sub;
    }
    if (next) {
      command = next;
      continue;
    }
    bool takes_positionals = false;
    for (const CLI::Option* o : command->get_options()) takes_positionals |= o->get_positional();
    if (!subcommands.empty() && !takes_positionals) {
      std::vector<std::string> names;
      for (const CLI::App* sub : subcommands) {
        if (!sub->get_group().empty()) names.push_back(sub->get_name());
      }
      const auto nearest = NearestKey(token, names);
      return fmt::format("unknown command {}{}", Quoted(CommandPath(command) + " " + token),
                         nearest ? " (did you mean " + Quoted(CommandPath(command) + " " +
                                                              *nearest) + "?)"
                                 : "; " + CommandPath(command) + " --help lists the commands");
    }
  }
  return error.what();
}

// Parses argv and runs the chosen command: every exception becomes its exit code.
int ParseAndRun(int argc, const char* const* argv) {
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
    g_only_reads = true;  // nothing ran
    // `--version` after a command (it falls through to the program's own): a script asking
    // for parameter set 3 must not get the program's version and exit 0.
    if (!app.get_subcommands().empty()) {
      std::cerr << "armsig: error: --version after a command is the program's version (armsig "
                   "--version); a stored parameter set is chosen with --set N\n";
      return kInputError;
    }
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    g_only_reads = true;  // nothing ran
    if (e.get_exit_code() == 0) return app.exit(e);  // --help
    std::cerr << "armsig: error: " << ParseErrorText(app, e, argc, argv) << "\n";
    return kInputError;
  }
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
  } catch (const StoredButOutputError& e) {
    spdlog::error("{}", e.what());
    return kStoredOutputFailed;
  } catch (const OutputError& e) {
    // A command that stores says itself what it stored before its output failed.
    spdlog::error("{}{}", e.what(),
                  g_only_reads ? "; the command only reads: nothing was stored or changed" : "");
    return kFailure;
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

}  // namespace

CLI::App* OnlyReads(CLI::App* sub) {
  sub->parse_complete_callback([] { g_only_reads = true; });
  return sub;
}

int Main(int argc, const char* const* argv) {
  InstallStopSignals();
  SetUpLogging();
  // The one place every command's standard output is checked, to its last byte.
  CheckedStdout out(STDOUT_FILENO);
  std::streambuf* const previous = std::cout.rdbuf(&out);
  const int code = ParseAndRun(argc, argv);
  std::cout.flush();
  const auto failure = out.Finish();
  std::cout.rdbuf(previous);
  if (!failure) return code;
  spdlog::error("{}", DescribeStdoutFailure(*failure, g_only_reads, code, io::CommittedFiles()));
  return kFailure;
}

}  // namespace armsig::app
