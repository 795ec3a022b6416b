#include "core/error.h"

#include "core/text.h"

namespace armsig {

std::string FormatLocation(const SourceLocation& where) {
  // A file name is input too: a newline or an escape sequence in it is shown, not obeyed.
  std::string out = Printable(where.file);
  if (where.line > 0) {
    out += ":" + std::to_string(where.line);
    if (where.column > 0) out += ":" + std::to_string(where.column);
  }
  if (!where.column_name.empty()) out += " (" + Printable(where.column_name) + ")";
  return out;
}

namespace {
std::string Compose(const SourceLocation& where, const std::string& message) {
  const std::string location = FormatLocation(where);
  return location.empty() ? message : location + ": " + message;
}
}  // namespace

const char* ToString(SolveCode code) {
  switch (code) {
    case SolveCode::kOk:
      return "ok";
    case SolveCode::kNotConverged:
      return "not_converged";
    case SolveCode::kTooFewObservations:
      return "too_few_observations";
    case SolveCode::kDegenerate:
      return "degenerate";
    case SolveCode::kOutOfRange:
      return "out_of_range";
    case SolveCode::kNonFinite:
      return "non_finite";
  }
  return "unknown";
}

InputError::InputError(SourceLocation where, const std::string& message)
    : std::runtime_error(Compose(where, message)), where_(std::move(where)), message_(message) {}

}  // namespace armsig
