#include "core/error.h"

namespace armsig {

std::string FormatLocation(const SourceLocation& where) {
  std::string out = where.file;
  if (where.line > 0) {
    out += ":" + std::to_string(where.line);
    if (where.column > 0) out += ":" + std::to_string(where.column);
  }
  if (!where.column_name.empty()) out += " (" + where.column_name + ")";
  return out;
}

namespace {
std::string Compose(const SourceLocation& where, const std::string& message) {
  const std::string location = FormatLocation(where);
  return location.empty() ? message : location + ": " + message;
}
}  // namespace

InputError::InputError(SourceLocation where, const std::string& message)
    : std::runtime_error(Compose(where, message)), where_(std::move(where)), message_(message) {}

}  // namespace armsig
