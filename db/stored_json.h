// JSON read back from the store is input like a file: an edited, damaged or hostile database
// could hold 100,000 nested arrays where a list of numbers belongs (nlohmann's writer
// recurses once per level: printed with indentation, 10,000 levels are 200 MB, 100,000 a
// crash), 1 GB of text, or an array where a number belongs (nlohmann's type_error.302,
// naming no table or row). Every stored JSON column is read through here: refused with an
// InputError (exit code 2) naming the store, table, row and column, before anything uses it.
#pragma once

#include <cstddef>
#include <cstdint>
#include <nlohmann/json.hpp>
#include <string>
#include <string_view>

namespace armsig::db {

// Where a stored JSON value lives.
struct JsonCell {
  std::string store;  // Database::path()
  std::string table;
  int64_t row = 0;  // the row's id (the session's for sessions, …)
  std::string column;
  // "lab.db: table poses, row 17, column joints_json"
  std::string Describe() const;
};

// Far beyond what armsig writes (its deepest JSON, a calibration report, nests 5 levels;
// its largest, a residual map of 2,773 configurations, is about 1 MB).
inline constexpr int kMaxStoredJsonDepth = 64;
inline constexpr std::size_t kMaxStoredJsonBytes = std::size_t{64} << 20;

// Throws InputError naming `cell` when `text` is larger than kMaxStoredJsonBytes or nests
// deeper than kMaxStoredJsonDepth (a scan of its brackets, no parse): after this, parsing
// and printing the text are bounded. Loaders that keep a column's text for later check it.
void CheckStoredJsonText(std::string_view text, const JsonCell& cell);

// The value of `text`; null for an empty text (a column not written yet). Throws InputError
// naming `cell` when the text is larger than kMaxStoredJsonBytes, nested deeper than
// kMaxStoredJsonDepth or not JSON.
nlohmann::json ParseStoredJson(std::string_view text, const JsonCell& cell);

// Throws InputError naming `cell`: "…: expected <what>, got …".
[[noreturn]] void RefuseStoredJson(const JsonCell& cell, const std::string& why);

// read(ParseStoredJson(text, cell)), with a JSON type error inside `read` (a nested array
// where a number belongs, a missing key) turned into an InputError naming `cell`.
template <typename Read>
auto ReadStoredJson(std::string_view text, const JsonCell& cell, Read&& read) {
  const nlohmann::json json = ParseStoredJson(text, cell);
  try {
    return read(json);
  } catch (const nlohmann::json::exception& e) {
    RefuseStoredJson(cell, std::string("not the JSON armsig stores there (") + e.what() + ")");
  }
}

}  // namespace armsig::db
