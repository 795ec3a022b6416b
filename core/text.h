// Text that came from outside (a file, a command line, a database, a device) on its way into
// messages, log lines, names and JSON: the one place that knows UTF-8 and which characters a
// terminal or a log reader obeys instead of showing.
//
//   throw InputError(where, "expected a number, got " + Quoted(field));
//
// Every reader echoes a value through Quoted, so that a field holding "\narmsig: info: …",
// an escape sequence, a NUL byte or 50 MB comes out as one short, inert line.
#pragma once

#include <cstddef>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace armsig {

// The code point starting at `*pos`, advancing `*pos` past it; nullopt (advancing one byte)
// when the byte there does not start a well-formed UTF-8 sequence (a stray continuation
// byte, an overlong form, a surrogate, beyond U+10FFFF, a truncated sequence).
std::optional<char32_t> NextCodePoint(std::string_view text, std::size_t* pos);
bool IsValidUtf8(std::string_view text);

// Characters a terminal, a log reader or a text layout acts on rather than shows: the C0
// controls, DEL, the C1 controls, the line and paragraph separators U+2028/2029 and the
// bidirectional controls (U+200E/200F, U+202A–202E, U+2066–2069).
bool IsControlCharacter(char32_t c);
// Characters that print nothing visible: white space (U+0020, U+00A0, U+1680, U+2000–200A,
// U+202F, U+205F, U+3000) and zero-width or format characters (soft hyphen, zero-width
// space and joiners, word joiner, invisible operators, variation selectors, BOM, tags, the
// Hangul fillers). A name made only of these looks empty.
bool IsInvisible(char32_t c);

// `text` with every control character and every byte that is not well-formed UTF-8 written
// as an escape (\n, \r, \t, \0, \x1b, \u{202e}, a stray byte as \xff); everything else as it
// is. The result is valid UTF-8 and prints on one line.
std::string Printable(std::string_view text);

// An input value for a message: 'value' made Printable, cut after `max_bytes` bytes of the
// input (at a character boundary) with "…' (N bytes)" when it is longer.
inline constexpr std::size_t kMaxQuotedBytes = 60;
std::string Quoted(std::string_view text, std::size_t max_bytes = kMaxQuotedBytes);

// `text` cut to at most `max_bytes` bytes without splitting a UTF-8 character.
std::string_view TruncateUtf8(std::string_view text, std::size_t max_bytes);

// The text of a JSON document (an nlohmann::json; header-only, so core links no JSON
// library): every JSON output and every JSON stored goes through here. A string that is not
// valid UTF-8 (a name from a damaged or edited database) is written with U+FFFD in place of
// the bad bytes instead of throwing halfway through a command whose work is already stored.
template <typename Json>
std::string JsonText(const Json& json, int indent = -1) {
  return json.dump(indent, ' ', false, Json::error_handler_t::replace);
}

// Levenshtein distance (insertions, deletions, substitutions), for "did you mean".
int EditDistance(std::string_view a, std::string_view b);

// `text` without the `characters` it begins and ends with (by default blanks, tabs and line
// ends). Each reader names the set its format allows: a GSI or robot line " \r\n", a CSV
// field " \t".
std::string_view Trim(std::string_view text, std::string_view characters = " \t\r\n");
// The candidate nearest to `word`, when near enough to be a likely typo of it (a few
// characters: at most max(2, |word| / 3) edits); nullopt otherwise.
std::optional<std::string> NearestKey(std::string_view word,
                                      const std::vector<std::string_view>& candidates);
std::optional<std::string> NearestKey(std::string_view word,
                                      const std::vector<std::string>& candidates);

// `text` for HTML or XML: & < > " ' as entities (&#39; for the apostrophe, which both read),
// safe in element content and in quoted attribute values.
std::string EscapeMarkup(std::string_view text);

}  // namespace armsig
