#include "db/stored_json.h"

#include <fmt/format.h>

#include <optional>

#include "core/error.h"
#include "core/text.h"

namespace armsig::db {

namespace {

// How deep `text` nests (brackets outside strings), stopping once past `limit`: checked
// before nlohmann builds (or later prints) anything.
std::optional<std::size_t> DeeperThan(std::string_view text, int limit) {
  int depth = 0;
  bool in_string = false;
  for (std::size_t i = 0; i < text.size(); ++i) {
    const char c = text[i];
    if (in_string) {
      if (c == '\\') {
        ++i;
      } else if (c == '"') {
        in_string = false;
      }
    } else if (c == '"') {
      in_string = true;
    } else if (c == '[' || c == '{') {
      if (++depth > limit) return i;
    } else if (c == ']' || c == '}') {
      --depth;
    }
  }
  return std::nullopt;
}

}  // namespace

std::string JsonCell::Describe() const {
  return fmt::format("table {}, row {}, column {}", table, row, column);
}

void RefuseStoredJson(const JsonCell& cell, const std::string& why) {
  throw InputError(
      {cell.store, 0, 0, ""},
      cell.Describe() + ": " + why + " (an edited or damaged database; armsig leaves it as it is)");
}

void CheckStoredJsonText(std::string_view text, const JsonCell& cell) {
  if (text.size() > kMaxStoredJsonBytes) {
    RefuseStoredJson(cell, fmt::format("{} bytes of JSON, more than armsig reads there ({} MiB)",
                                       text.size(), kMaxStoredJsonBytes >> 20));
  }
  if (const auto at = DeeperThan(text, kMaxStoredJsonDepth)) {
    RefuseStoredJson(cell, fmt::format("JSON nested deeper than {} levels (at byte {})",
                                       kMaxStoredJsonDepth, *at + 1));
  }
}

nlohmann::json ParseStoredJson(std::string_view text, const JsonCell& cell) {
  if (text.empty()) return nullptr;
  CheckStoredJsonText(text, cell);
  auto json = nlohmann::json::parse(text, nullptr, /*allow_exceptions=*/false);
  if (json.is_discarded()) {
    RefuseStoredJson(cell, "not JSON: " + Quoted(text));
  }
  return json;
}

}  // namespace armsig::db
