// The command-line face of armsig. Each command has a Setup… that declares its CLI11
// subcommand and a Run… that takes the parsed options and returns an exit code, so
// tests call Run… without a shell. Exit codes (docs/reference/cli.md): 0 ok, 1 failure,
// 2 usage or input error, 3 a quality gate failed, 130 stopped by a signal (every command
// that a Ctrl-C, SIGTERM or SIGHUP stops, its work left resumable).
#pragma once

#include <CLI/CLI.hpp>
#include <atomic>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "db/database.h"
#include "acquisition/session.h"
#include "io/csv.h"
#include "nightly/recalibrate.h"

namespace armsig::app {

// kStopped: a Ctrl-C (or SIGTERM, SIGHUP) stopped the work, left resumable (128 + SIGINT):
// capture, demo (a served lab too), db push, worker, instrument simulate alike.
// kStoredOutputFailed: the work is stored, an output that follows it could not be written
// (StoredButOutputError, core/error.h).
enum ExitCode : int {
  kOk = 0,
  kFailure = 1,
  kInputError = 2,
  kQualityGate = 3,
  kStoredOutputFailed = 6,
  kStopped = 130
};

struct GlobalOptions {
  std::string db_path;  // --db; empty = $ARMSIG_DB, else ./armsig.db
  int verbosity = 0;    // -v: debug, -vv: trace
  bool quiet = false;   // -q: warnings and errors only
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
// The nightly fit's options (--since, --select, --params, --residual-model, the gates and
// drift thresholds, --lock-wait, --force), range-checked, for `recalibrate` and for
// `schedule recalibrate` alike.
void AddRecalibrateOptions(CLI::App& sub, nightly::RecalibrateOptions& options);
void SetupImportCommand(CLI::App& parent, const GlobalOptions& global, Runner& run);
void SetupInstrumentCommand(CLI::App& parent, const GlobalOptions& global, Runner& run);
void SetupDbCommand(CLI::App& parent, const GlobalOptions& global, Runner& run);
void SetupSignatureCommands(CLI::App& parent, const GlobalOptions& global, Runner& run);
void SetupLifecycleCommands(CLI::App& parent, const GlobalOptions& global, Runner& run);
void SetupFleetCommands(CLI::App& parent, const GlobalOptions& global, Runner& run);
// armsig iso9283 plan | report | evaluate (one file each, under the `iso9283` command).
void SetupIso9283Commands(CLI::App& parent, const GlobalOptions& global, Runner& run);
void SetupIso9283PlanCommand(CLI::App& iso9283, const GlobalOptions& global, Runner& run);
void SetupIso9283ReportCommand(CLI::App& iso9283, const GlobalOptions& global, Runner& run);
void SetupIso9283EvaluateCommand(CLI::App& iso9283, const GlobalOptions& global, Runner& run);
void SetupIso9283EvaluatePathCommand(CLI::App& iso9283, const GlobalOptions& global, Runner& run);

// Ctrl-C, SIGTERM (systemctl stop, kill) and SIGHUP (a closed terminal) ask the running
// command to stop at its next safe point; the first call installs the handlers. A
// second signal only repeats the request (the work being stopped is left resumable, never
// half-written); a third ends the process at once.
const std::atomic<bool>& StopRequested();
// Installs those handlers (and unblocks the three signals); the program calls it before main.
void InstallStopSignals();

// Marks an option as naming a file (or a folder) the command will write: the path is
// checked when the command line is parsed (its folder exists and is writable, it is not
// a folder), so a typo is refused with exit 2 before any work is done or stored.
CLI::Option* OutputFile(CLI::Option* option);
CLI::Option* OutputDirectory(CLI::Option* option);
// A name given on the command line (robot, station id): refused at parse time (exit 2,
// naming the option) when longer than 64 bytes or holding control characters; a note
// likewise beyond 1000 bytes (core/plausibility.h).
CLI::Option* NameOption(CLI::Option* option);
CLI::Option* NoteOption(CLI::Option* option);
// A store's address (--db, --to, --queue): an SQLite file, or a PostgreSQL server's URI or
// key/value string read strictly (db/postgres_address.h): one that carries a password or
// that libpq cannot read is refused at parse time (exit 2), without its secrets.
CLI::Option* StoreOption(CLI::Option* option);
// How far a long read has come, on stderr when it is a terminal (nullptr otherwise): a
// line redrawn in place, shown once the read has taken a second (app/progress.cc).
io::ReadProgressFn TerminalReadProgress();
// The terminal's width in columns: of `fd` (TIOCGWINSZ), else $COLUMNS, else 80.
int TerminalColumns(int fd);
// A capture's progress line on stderr as wide as the terminal, redrawn in place; nullptr
// when stderr is not a terminal (no bar in a log or a pipe). `clear_when_done`: the line is
// erased after the last configuration (the demo), else it stays (capture ends it).
std::function<void(const acquisition::Progress&)> TerminalCaptureProgress(bool clear_when_done);
// A number given on the command line (every numeric option of every command is declared
// through here): finite — "nan", "inf" and "1e999" are refused, which CLI11's own Range
// lets through — and within [min, max]; refused at parse time (exit 2) naming the option
// and the range. For an integer option CLI11 refuses a fraction itself.
CLI::Option* NumberOption(CLI::Option* option, double min, double max);
// The same check for an option that takes a list of numbers (--seed-deg 0,-90,90).
CLI::Validator NumberCheck(double min, double max);
// An option that takes one of `choices`: refused at parse time (exit 2) with the choices and
// the nearest one ("expected robot or measurement, got 'robt' (did you mean 'robot'?)");
// the bash completion offers the choices.
// `convert`, when given, turns an accepted word into the text the option's variable is parsed
// from (EnumOption: the value's number).
CLI::Option* ChoiceOption(CLI::Option* option, std::vector<std::string> choices,
                          std::function<std::string(const std::string&)> convert = {});
// The choices ChoiceOption gave `option` (empty for any other option).
const std::vector<std::string>& ChoicesOf(const CLI::Option* option);
// ChoiceOption for an option bound to an enum (or a list of them): the words are the
// values' ToString, checked as ChoiceOption checks them, then turned into the value. Its
// default is shown as the word.
template <typename Enum>
CLI::Option* EnumOption(CLI::Option* option, std::vector<Enum> values, Enum shown_default) {
  std::vector<std::string> words;
  for (const Enum v : values) words.emplace_back(ToString(v));
  ChoiceOption(option, words, [values](const std::string& word) {
    for (const Enum v : values) {
      if (word == ToString(v)) return std::to_string(static_cast<int>(v));
    }
    return word;
  });
  option->default_str(ToString(shown_default));
  return option;
}

// `--set N`: a stored parameter set (version) of the robot instead of the active one.
CLI::Option* AddSetOption(CLI::App& sub, std::optional<int>& set);
// Bounds for counts and ids given on the command line.
inline constexpr double kMaxPoses = 1e6;                // configurations of one session or fit
inline constexpr double kMaxId = 9.007199254740992e15;  // 2^53: a database row id

// Marks a command that stores and changes nothing (it reads the store or converts files):
// when one of its outputs cannot be written, the message says that nothing was changed.
// OnDatabaseToRead marks its commands itself.
CLI::App* OnlyReads(CLI::App* sub);

// Sets `sub`'s job to `job(database)` on the existing database --db names (a command that
// adds to what is there: a missing file is refused, never created).
void OnExistingDatabase(CLI::App* sub, const GlobalOptions& global, Runner& run,
                        std::function<int(db::Database&)> job);
// The same for a command that only reads (db::OpenMode::kReadOnly): nothing is created,
// initialised, migrated or written, and an empty file is refused.
void OnDatabaseToRead(CLI::App* sub, const GlobalOptions& global, Runner& run,
                      std::function<int(db::Database&)> job);

// "armsig 0.1.0 (git 1a2b3c4d5e6f, database schema v3)".
std::string VersionText();

// Builds the whole CLI (used by main and by tests).
void SetupAll(CLI::App& app, GlobalOptions& global, Runner& run);

// Parses argv and runs the chosen command; every exception becomes its exit code with
// a message on stderr. Standard output is checked to its last byte (app/checked_stdout.h)
// and closed at the end: a failed write is exit code 1 with a message naming it and saying
// what the command did. What main() does.
int Main(int argc, const char* const* argv);

}  // namespace armsig::app
