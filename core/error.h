// Input errors carry their context (file, line, column, what was expected). They are
// thrown at the edges and turned into exit code 2 in one place (app/main.cc).
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

std::string FormatLocation(const SourceLocation& where);

}  // namespace armsig
