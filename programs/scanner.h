// What the three program lexers share: a token with its bytes and line, and the scanning
// of number literals. Internal to programs/.
#pragma once

#include <cstddef>
#include <initializer_list>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "core/error.h"
#include "programs/program.h"

namespace armsig::programs::detail {

struct Token {
  enum class Kind { kIdentifier, kNumber, kString, kPunct, kEndOfStatement };
  Kind kind = Kind::kPunct;
  std::size_t begin = 0, end = 0;  // bytes in the file
  int line = 1;
  std::string_view text;  // view into the file's text
  bool Is(std::string_view punct) const { return kind == Kind::kPunct && text == punct; }
  bool IsWord(std::string_view word) const;  // an identifier equal to `word`, case-insensitive
};

// The end of a number literal starting at `at` (digits, one point, an exponent: "12",
// "1.5", ".433", "9E+09", "1e-3"), or `at` when none starts there.
std::size_t ScanNumber(std::string_view text, std::size_t at);

// What follows blanks, comments and strings in all three languages: a number literal (a
// digit, or a point before one; "1abc" is one word, not a number), a word (`word_start`
// at `at`, then `is_word_char`), else punctuation: one of the two-character `operators`
// or one character. Its kind and end.
struct Lexeme {
  Token::Kind kind = Token::Kind::kPunct;
  std::size_t end = 0;
};
Lexeme ScanLexeme(std::string_view text, std::size_t at, bool word_start, bool (*is_word_char)(char),
                  std::initializer_list<std::string_view> operators);

bool EqualsIgnoreCase(std::string_view a, std::string_view b);
std::string Upper(std::string_view text);

// A signed number literal at tokens[*i] ("-", "+" then a number): its field (bytes from
// the sign to the number's end), advancing *i past it; nullopt when none is there.
std::optional<NumberField> SignedNumber(const std::vector<Token>& tokens, std::size_t* i);

// Brackets: ( [ { open, ) ] } close.
bool OpensBracket(const Token& t);
bool ClosesBracket(const Token& t);
// The index of the bracket that closes the one at tokens[open], looking before `end`; `end`
// when none does.
std::size_t ClosingBracket(const std::vector<Token>& tokens, std::size_t open, std::size_t end);
// The first `punct` outside brackets in tokens[begin, end), or `end`.
std::size_t FindTopLevel(const std::vector<Token>& tokens, std::size_t begin, std::size_t end,
                         std::string_view punct);
// The top-level pieces of tokens[begin, end) split at `sep` (outside brackets), as
// [first, last) index pairs: one piece more than separators.
std::vector<std::pair<std::size_t, std::size_t>> SplitTopLevel(const std::vector<Token>& tokens,
                                                               std::size_t begin, std::size_t end,
                                                               std::string_view sep);

// Throws the InputError of a lexer or parser: file, line, column of `at`.
[[noreturn]] void Fail(const ProgramFile& file, std::size_t at, const std::string& message);

// 1-based line and column of byte `at`.
std::pair<int, int> LineColumn(std::string_view text, std::size_t at);

}  // namespace armsig::programs::detail
