#include "core/text.h"

#include <algorithm>
#include <limits>
#include <numeric>
#include <vector>
#include <cstdio>

namespace armsig {

std::optional<char32_t> NextCodePoint(std::string_view text, std::size_t* pos) {
  const std::size_t i = *pos;
  const auto byte = [&](std::size_t k) -> unsigned {
    return i + k < text.size() ? static_cast<unsigned char>(text[i + k]) : 0u;
  };
  const unsigned b0 = byte(0);
  ++*pos;  // a malformed byte is skipped alone
  if (b0 < 0x80) return b0;
  // Unicode 15, table 3-7: the well-formed byte sequences.
  unsigned length = 0, lo = 0x80, hi = 0xbf;
  char32_t c = 0;
  if (b0 >= 0xc2 && b0 <= 0xdf) {
    length = 2;
    c = b0 & 0x1f;
  } else if (b0 >= 0xe0 && b0 <= 0xef) {
    length = 3;
    c = b0 & 0x0f;
    if (b0 == 0xe0) lo = 0xa0;
    if (b0 == 0xed) hi = 0x9f;  // no surrogates
  } else if (b0 >= 0xf0 && b0 <= 0xf4) {
    length = 4;
    c = b0 & 0x07;
    if (b0 == 0xf0) lo = 0x90;
    if (b0 == 0xf4) hi = 0x8f;  // nothing beyond U+10FFFF
  } else {
    return std::nullopt;
  }
  for (unsigned k = 1; k < length; ++k) {
    const unsigned b = byte(k);
    if (i + k >= text.size() || b < (k == 1 ? lo : 0x80) || b > (k == 1 ? hi : 0xbf)) {
      return std::nullopt;
    }
    c = (c << 6) | (b & 0x3f);
  }
  *pos = i + length;
  return c;
}

bool IsValidUtf8(std::string_view text) {
  for (std::size_t pos = 0; pos < text.size();) {
    if (!NextCodePoint(text, &pos)) return false;
  }
  return true;
}

bool IsControlCharacter(char32_t c) {
  return c < 0x20 || (c >= 0x7f && c <= 0x9f) || c == 0x200e || c == 0x200f ||
         (c >= 0x2028 && c <= 0x202e) || (c >= 0x2066 && c <= 0x2069);
}

bool IsInvisible(char32_t c) {
  switch (c) {
    case 0x20:
    case 0xa0:
    case 0xad:    // soft hyphen
    case 0x34f:   // combining grapheme joiner
    case 0x61c:   // Arabic letter mark
    case 0x115f:  // Hangul fillers
    case 0x1160:
    case 0x1680:
    case 0x17b4:
    case 0x17b5:
    case 0x202f:
    case 0x205f:
    case 0x3000:
    case 0x3164:
    case 0xfeff:  // BOM, zero-width no-break space
    case 0xffa0:
      return true;
    default:
      break;
  }
  return (c >= 0x180b && c <= 0x180f) ||  // Mongolian selectors and vowel separator
         (c >= 0x2000 && c <= 0x200f) ||  // spaces, zero-width space, joiners, marks
         (c >= 0x2028 && c <= 0x202e) || (c >= 0x2060 && c <= 0x206f) ||
         (c >= 0xfe00 && c <= 0xfe0f) ||    // variation selectors
         (c >= 0xe0000 && c <= 0xe0fff) ||  // tags, variation selectors supplement
         IsControlCharacter(c);
}

namespace {

void AppendUtf8(char32_t c, std::string& out) {
  if (c < 0x80) {
    out += static_cast<char>(c);
  } else if (c < 0x800) {
    out += static_cast<char>(0xc0 | (c >> 6));
    out += static_cast<char>(0x80 | (c & 0x3f));
  } else if (c < 0x10000) {
    out += static_cast<char>(0xe0 | (c >> 12));
    out += static_cast<char>(0x80 | ((c >> 6) & 0x3f));
    out += static_cast<char>(0x80 | (c & 0x3f));
  } else {
    out += static_cast<char>(0xf0 | (c >> 18));
    out += static_cast<char>(0x80 | ((c >> 12) & 0x3f));
    out += static_cast<char>(0x80 | ((c >> 6) & 0x3f));
    out += static_cast<char>(0x80 | (c & 0x3f));
  }
}

void AppendEscape(char32_t c, std::string& out) {
  char buffer[16];
  switch (c) {
    case '\n':
      out += "\\n";
      return;
    case '\r':
      out += "\\r";
      return;
    case '\t':
      out += "\\t";
      return;
    case 0:
      out += "\\0";
      return;
    default:
      break;
  }
  if (c < 0x100) {
    std::snprintf(buffer, sizeof buffer, "\\x%02x", static_cast<unsigned>(c));
  } else {
    std::snprintf(buffer, sizeof buffer, "\\u{%x}", static_cast<unsigned>(c));
  }
  out += buffer;
}

}  // namespace

std::string Printable(std::string_view text) {
  std::string out;
  out.reserve(text.size());
  for (std::size_t pos = 0; pos < text.size();) {
    const std::size_t start = pos;
    const auto c = NextCodePoint(text, &pos);
    if (!c) {
      AppendEscape(static_cast<unsigned char>(text[start]), out);
    } else if (IsControlCharacter(*c)) {
      AppendEscape(*c, out);
    } else {
      AppendUtf8(*c, out);
    }
  }
  return out;
}

std::string_view TruncateUtf8(std::string_view text, std::size_t max_bytes) {
  if (text.size() <= max_bytes) return text;
  std::size_t end = 0;
  for (std::size_t pos = 0; pos < text.size();) {
    NextCodePoint(text, &pos);
    if (pos > max_bytes) break;
    end = pos;
  }
  return text.substr(0, end);
}

std::string Quoted(std::string_view text, std::size_t max_bytes) {
  if (text.size() <= max_bytes) return "'" + Printable(text) + "'";
  return "'" + Printable(TruncateUtf8(text, max_bytes)) + "…' (" + std::to_string(text.size()) +
         " bytes)";
}

std::string_view Trim(std::string_view text, std::string_view characters) {
  const std::size_t first = text.find_first_not_of(characters);
  if (first == std::string_view::npos) return {};
  return text.substr(first, text.find_last_not_of(characters) - first + 1);
}

int EditDistance(std::string_view a, std::string_view b) {
  // Wagner–Fischer, one row.
  std::vector<int> row(b.size() + 1);
  std::iota(row.begin(), row.end(), 0);
  for (size_t i = 1; i <= a.size(); ++i) {
    int diagonal = row[0];
    row[0] = static_cast<int>(i);
    for (size_t j = 1; j <= b.size(); ++j) {
      const int substitution = diagonal + (a[i - 1] == b[j - 1] ? 0 : 1);
      diagonal = row[j];
      row[j] = std::min({row[j] + 1, row[j - 1] + 1, substitution});
    }
  }
  return row[b.size()];
}

std::optional<std::string> NearestKey(std::string_view word,
                                      const std::vector<std::string_view>& candidates) {
  std::optional<std::string> best;
  int best_distance = std::numeric_limits<int>::max();
  for (const auto& candidate : candidates) {
    const int d = EditDistance(word, candidate);
    if (d < best_distance) {
      best_distance = d;
      best = std::string(candidate);
    }
  }
  // A typo changes a few characters; beyond that the suggestion would be a guess.
  const int limit = std::max<int>(2, static_cast<int>(word.size()) / 3);
  if (best_distance > limit) return std::nullopt;
  return best;
}

std::optional<std::string> NearestKey(std::string_view word,
                                      const std::vector<std::string>& candidates) {
  return NearestKey(word, std::vector<std::string_view>(candidates.begin(), candidates.end()));
}

std::string EscapeMarkup(std::string_view text) {
  std::string out;
  out.reserve(text.size());
  for (char c : text) {
    switch (c) {
      case '<':
        out += "&lt;";
        break;
      case '>':
        out += "&gt;";
        break;
      case '&':
        out += "&amp;";
        break;
      case '"':
        out += "&quot;";
        break;
      case '\'':
        out += "&#39;";
        break;
      default:
        out += c;
    }
  }
  return out;
}

}  // namespace armsig
