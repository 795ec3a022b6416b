// armsig's error policy, one rule per layer:
//
// - Pure math (calibration/, reduction/) never throws for a property of the data. A solve
//   returns its result with a `SolveStatus` the caller must look at (`status.ok()`), and
//   never reports kOk when any estimate is non-finite. Programming errors (a size mismatch
//   between arguments) may throw std::invalid_argument / std::logic_error.
// - Edges that read what a user wrote (files, command options, stored YAML, serial
//   replies turned into readings) throw `InputError` carrying the file (or option or
//   device), line, column and what was expected. `app/` turns it into exit code 2 in one
//   place (app/main_lib.cc). Library parse failures (std::stoi, yaml-cpp, nlohmann) are
//   caught at the edge and re-thrown as InputError with the location: a user never
//   reads "stoi".
// - A quality gate that fails after the work ran throws `QualityGateError` (exit code 3).
// - Transport and database failures (a port that vanished, SQLite's own errors) are
//   std::runtime_error / SQLite::Exception: exit code 1.
// - An output that cannot be written (a full disk, a quota, an I/O error) throws
//   `OutputError` naming the file and the system's reason: exit code 1, and the command
//   says what it did and did not do.
#pragma once

#include <stdexcept>
#include <string>

namespace armsig {

struct SourceLocation {
  std::string file;         // empty when the input is not a file (a port, a command option)
  int line = 0;             // 1-based; 0 = whole file
  int column = 0;           // 1-based; 0 = whole line
  std::string column_name;  // CSV column or YAML key, when known
};

// Malformed or missing user input. what() reads "file:line:column: message".
class InputError : public std::runtime_error {
 public:
  InputError(SourceLocation where, const std::string& message);
  explicit InputError(const std::string& message) : InputError(SourceLocation{}, message) {}

  const SourceLocation& where() const { return where_; }
  const std::string& message() const { return message_; }

 private:
  SourceLocation where_;
  std::string message_;
};

// A quality gate failed (exit code 3): the work ran, its result is not good enough.
class QualityGateError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// An output file could not be written. what() reads "FILE: write failed (No space left on
// device); FILE was not changed".
class OutputError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// What was asked is stored (a session, a parameter set), and then an output that could only
// follow it could not be written (exit code 6). what() says what was stored, which output
// failed and why, and how to write it again.
class StoredButOutputError : public OutputError {
 public:
  using OutputError::OutputError;
};

std::string FormatLocation(const SourceLocation& where);

// The outcome of a numerical solve (Ceres-style Summary status): the one status type of
// calibration/ and reduction/. `message` says why when not ok.
enum class SolveCode {
  kOk,
  kNotConverged,        // iterations ran out or the solver failed
  kTooFewObservations,  // fewer equations than unknowns (one ray, too few poses)
  kDegenerate,          // the geometry does not determine the unknowns (parallel rays, …)
  kOutOfRange,          // the solution lies outside the admissible domain (joint limits)
  kNonFinite,           // an input or estimate is not a finite number
};
const char* ToString(SolveCode code);

struct SolveStatus {
  SolveCode code = SolveCode::kOk;
  std::string message;  // why, when not ok
  bool ok() const { return code == SolveCode::kOk; }
};

}  // namespace armsig
