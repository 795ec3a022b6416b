#include "programs/scanner.h"

#include <cctype>
#include <cstdlib>

namespace armsig::programs::detail {

bool EqualsIgnoreCase(std::string_view a, std::string_view b) {
  if (a.size() != b.size()) return false;
  for (std::size_t i = 0; i < a.size(); ++i) {
    if (std::toupper(static_cast<unsigned char>(a[i])) != std::toupper(static_cast<unsigned char>(b[i])))
      return false;
  }
  return true;
}

std::string Upper(std::string_view text) {
  std::string out(text);
  for (char& c : out) c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
  return out;
}

Lexeme ScanLexeme(std::string_view text, std::size_t at, bool word_start, bool (*is_word_char)(char),
                  std::initializer_list<std::string_view> operators) {
  auto digit = [&](std::size_t i) { return i < text.size() && std::isdigit(static_cast<unsigned char>(text[i])); };
  auto word_end = [&](std::size_t j) {
    while (j < text.size() && is_word_char(text[j])) ++j;
    return j;
  };
  if (digit(at) || (text[at] == '.' && digit(at + 1))) {
    const std::size_t end = ScanNumber(text, at);
    const std::size_t j = word_end(end);
    return {j == end ? Token::Kind::kNumber : Token::Kind::kIdentifier, j};
  }
  if (word_start) return {Token::Kind::kIdentifier, word_end(at + 1)};
  const std::string_view two = text.substr(at, 2);
  for (std::string_view op : operators)
    if (two == op) return {Token::Kind::kPunct, at + 2};
  return {Token::Kind::kPunct, at + 1};
}

bool Token::IsWord(std::string_view word) const {
  return kind == Kind::kIdentifier && EqualsIgnoreCase(text, word);
}

std::size_t ScanNumber(std::string_view text, std::size_t at) {
  auto digit = [&](std::size_t i) { return i < text.size() && std::isdigit(static_cast<unsigned char>(text[i])); };
  std::size_t i = at;
  bool digits = false;
  while (digit(i)) {
    ++i;
    digits = true;
  }
  if (i < text.size() && text[i] == '.') {
    std::size_t j = i + 1;
    bool fraction = false;
    while (digit(j)) {
      ++j;
      fraction = true;
    }
    if (digits || fraction) {
      i = j;
      digits = true;
    }
  }
  if (!digits) return at;
  if (i < text.size() && (text[i] == 'e' || text[i] == 'E')) {
    std::size_t j = i + 1;
    if (j < text.size() && (text[j] == '+' || text[j] == '-')) ++j;
    if (digit(j)) {
      while (digit(j)) ++j;
      i = j;
    }
  }
  return i;
}

bool OpensBracket(const Token& t) { return t.Is("(") || t.Is("[") || t.Is("{"); }
bool ClosesBracket(const Token& t) { return t.Is(")") || t.Is("]") || t.Is("}"); }

std::size_t ClosingBracket(const std::vector<Token>& tokens, std::size_t open, std::size_t end) {
  int depth = 0;
  for (std::size_t k = open; k < end; ++k) {
    if (OpensBracket(tokens[k])) ++depth;
    if (ClosesBracket(tokens[k]) && --depth == 0) return k;
  }
  return end;
}

std::size_t FindTopLevel(const std::vector<Token>& tokens, std::size_t begin, std::size_t end,
                         std::string_view punct) {
  int depth = 0;
  for (std::size_t k = begin; k < end; ++k) {
    const Token& t = tokens[k];
    if (OpensBracket(t)) ++depth;
    if (ClosesBracket(t)) --depth;
    if (depth == 0 && t.Is(punct)) return k;
  }
  return end;
}

std::vector<std::pair<std::size_t, std::size_t>> SplitTopLevel(const std::vector<Token>& tokens,
                                                               std::size_t begin, std::size_t end,
                                                               std::string_view sep) {
  std::vector<std::pair<std::size_t, std::size_t>> out;
  int depth = 0;
  std::size_t start = begin;
  for (std::size_t k = begin; k <= end; ++k) {
    if (k < end) {
      const Token& t = tokens[k];
      if (OpensBracket(t)) ++depth;
      if (ClosesBracket(t)) --depth;
      if (!(depth == 0 && t.Is(sep))) continue;
    }
    out.emplace_back(start, k);
    start = k + 1;
  }
  return out;
}

std::optional<NumberField> SignedNumber(const std::vector<Token>& tokens, std::size_t* i) {
  std::size_t k = *i;
  if (k >= tokens.size()) return std::nullopt;
  const std::size_t begin = tokens[k].begin;
  double sign = 1.0;
  if (tokens[k].Is("-") || tokens[k].Is("+")) {
    sign = tokens[k].Is("-") ? -1.0 : 1.0;
    ++k;
  }
  if (k >= tokens.size() || tokens[k].kind != Token::Kind::kNumber) return std::nullopt;
  NumberField f;
  f.begin = begin;
  f.end = tokens[k].end;
  f.value = sign * std::strtod(std::string(tokens[k].text).c_str(), nullptr);
  f.text = std::string(tokens[*i].text.data(), f.end - f.begin);  // one file: views are contiguous
  *i = k + 1;
  return f;
}

std::pair<int, int> LineColumn(std::string_view text, std::size_t at) {
  int line = 1, column = 1;
  for (std::size_t i = 0; i < at && i < text.size(); ++i) {
    if (text[i] == '\n') {
      ++line;
      column = 1;
    } else {
      ++column;
    }
  }
  return {line, column};
}

void Fail(const ProgramFile& file, std::size_t at, const std::string& message) {
  const auto [line, column] = LineColumn(file.text, at);
  throw InputError({file.name, line, column, ""}, message);
}

}  // namespace armsig::programs::detail
