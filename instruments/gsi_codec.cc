#include "instruments/gsi_codec.h"

#include <charconv>
#include <cmath>
#include <cstdio>
#include <numbers>
#include <stdexcept>

#include "core/text.h"

namespace armsig::instruments::gsi {

namespace {
constexpr double kPi = std::numbers::pi;

bool AllDigits(std::string_view s) {
  if (s.empty()) return false;
  for (char c : s) {
    if (c < '0' || c > '9') return false;
  }
  return true;
}

std::optional<long long> Integer(std::string_view s) {
  long long v = 0;
  if (!AllDigits(s)) return std::nullopt;
  auto [p, ec] = std::from_chars(s.data(), s.data() + s.size(), v);
  if (ec != std::errc()) return std::nullopt;
  return v;
}
}  // namespace

std::optional<Word> ParseWord(std::string_view text, bool gsi16, std::string* why) {
  const size_t size = gsi16 ? 23 : 15;
  auto fail = [&](std::string m) -> std::optional<Word> {
    if (why) *why = std::move(m);
    return std::nullopt;
  };
  if (text.size() < size) return fail("expected a " + std::to_string(size + 1) + "-character word");
  Word w;
  w.gsi16 = gsi16;
  std::string wi;
  for (int i = 0; i < 3; ++i) {
    if (text[i] != '.') wi += text[i];
  }
  // WI 11/41 carry the block number in positions 3–6: "110001", "41...." etc.
  std::string_view index = text.substr(0, 3);
  if (index.substr(0, 2) == "11" || index.substr(0, 2) == "41") {
    wi = std::string(index.substr(0, 2));
    w.aux = std::string(text.substr(2, 4));
  } else {
    w.aux = std::string(text.substr(3, 2));
    w.unit = text[5];
  }
  auto number = Integer(wi);
  if (!number)
    return fail("expected a word index (digits and '.') in positions 1-3, got " +
                Quoted(std::string(text.substr(0, 3))));
  w.wi = static_cast<int>(*number);
  w.sign = text[6];
  if (w.sign != '+' && w.sign != '-') {
    return fail("expected '+' or '-' in position 7, got " + Quoted(std::string(1, w.sign)));
  }
  w.data = std::string(text.substr(7, gsi16 ? 16 : 8));
  return w;
}

FileResult ParseFile(std::string_view text) {
  FileResult out;
  int line = 1;
  size_t i = 0;
  while (i < text.size()) {
    // One line (block), terminated by CR, LF or CR LF.
    size_t end = text.find_first_of("\r\n", i);
    if (end == std::string_view::npos) end = text.size();
    std::string_view block_text = text.substr(i, end - i);
    const int this_line = line;
    // Advance past the terminator; CR LF counts as one line end.
    if (end < text.size()) {
      if (text[end] == '\r' && end + 1 < text.size() && text[end + 1] == '\n') ++end;
      ++end;
      ++line;
    }
    i = end;
    while (!block_text.empty() && block_text.back() == ' ') block_text.remove_suffix(1);
    size_t pos = 0;
    while (pos < block_text.size() && block_text[pos] == ' ') ++pos;
    if (pos >= block_text.size()) continue;
    Block block;
    block.line = this_line;
    if (block_text[pos] == '*') {
      block.gsi16 = true;
      ++pos;
    }
    // Words are fixed width; a GSI-16 block may also hold GSI-8 words (mixed files).
    while (pos < block_text.size()) {
      while (pos < block_text.size() && block_text[pos] == ' ') ++pos;
      if (pos >= block_text.size()) break;
      size_t word_end = block_text.find(' ', pos);
      if (word_end == std::string_view::npos) word_end = block_text.size();
      const std::string_view word_text = block_text.substr(pos, word_end - pos);
      const bool wide = word_text.size() >= 23;
      std::string why;
      auto word = ParseWord(word_text, wide, &why);
      if (!word || (word_text.size() != 15 && word_text.size() != 23)) {
        out.error = DecodeError{
            this_line, static_cast<int>(pos) + 1,
            word ? "expected a 16- or 24-character GSI word, got " + Quoted(std::string(word_text))
                 : why};
        return out;
      }
      word->column = static_cast<int>(pos) + 1;
      block.words.push_back(*word);
      pos = word_end;
    }
    out.blocks.push_back(std::move(block));
  }
  return out;
}

std::optional<double> AngleRad(const Word& w, std::string* why) {
  auto fail = [&](std::string m) -> std::optional<double> {
    if (why) *why = std::move(m);
    return std::nullopt;
  };
  const std::string& d = w.data;
  auto v = Integer(d);
  if (!v) return fail("expected digits, got " + Quoted(d));
  const double sign = w.sign == '-' ? -1.0 : 1.0;
  switch (w.unit) {
    case '2':  // gon, 5 decimals
      return sign * (*v / 1e5) * kPi / 200.0;
    case '3':  // decimal degrees, 5 decimals
      return sign * (*v / 1e5) * kPi / 180.0;
    case '4': {  // DDDMMSSs: degrees, minutes, seconds, tenths
      const long long x = *v;
      const long long tenths = x % 10;
      const long long seconds = (x / 10) % 100;
      const long long minutes = (x / 1000) % 100;
      const long long degrees = x / 100000;
      if (minutes >= 60 || seconds >= 60) return fail("minutes or seconds ≥ 60 in " + Quoted(d));
      return sign * (degrees + minutes / 60.0 + (seconds + tenths / 10.0) / 3600.0) * kPi / 180.0;
    }
    case '5':  // mil (6400 per circle), 4 decimals
      return sign * (*v / 1e4) * 2.0 * kPi / 6400.0;
    default:
      return fail(std::string("unit '") + w.unit + "' is not an angle unit (2, 3, 4 or 5)");
  }
}

std::optional<double> LengthMm(const Word& w, std::string* why) {
  auto fail = [&](std::string m) -> std::optional<double> {
    if (why) *why = std::move(m);
    return std::nullopt;
  };
  auto v = Integer(w.data);
  if (!v) return fail("expected digits, got " + Quoted(w.data));
  const double sign = w.sign == '-' ? -1.0 : 1.0;
  constexpr double kFootMm = 304.8;
  switch (w.unit) {
    case '0':
      return sign * static_cast<double>(*v);  // 1 mm
    case '1':
      return sign * (*v / 1000.0) * kFootMm;
    case '6':
      return sign * (*v / 10.0);
    case '7':
      return sign * (*v / 10000.0) * kFootMm;
    case '8':
      return sign * (*v / 100.0);
    default:
      return fail(std::string("unit '") + w.unit + "' is not a length unit (0, 1, 6, 7 or 8)");
  }
}

std::string Identifier(const Word& w) {
  size_t start = w.data.find_first_not_of('0');
  if (start == std::string::npos) return "0";
  return w.data.substr(start);
}

std::optional<int> BlockNumber(const Word& w) {
  if (w.wi != 11 && w.wi != 41) return std::nullopt;
  auto v = Integer(w.aux);
  if (!v) return std::nullopt;
  return static_cast<int>(*v);
}

std::string FormatWord(const Word& w) {
  const size_t width = w.gsi16 ? 16 : 8;
  if (w.data.size() != width) {
    throw std::invalid_argument("GSI word " + std::to_string(w.wi) + ": data " + Quoted(w.data) +
                                " is not " + std::to_string(width) + " characters");
  }
  if (w.sign != '+' && w.sign != '-')
    throw std::invalid_argument("GSI word " + std::to_string(w.wi) + ": sign must be '+' or '-'");
  std::string index = std::to_string(w.wi);
  if (w.wi == 11 || w.wi == 41) {
    // Positions 3–6 carry the block number.
    if (w.aux.size() != 4)
      throw std::invalid_argument("GSI word " + index + ": block number must be 4 characters");
    return index + w.aux + w.sign + w.data + ' ';
  }
  if (w.wi < 0 || index.size() > 3)
    throw std::invalid_argument("GSI word index " + index + " does not fit in 3 positions");
  if (w.aux.size() != 2)
    throw std::invalid_argument("GSI word " + index +
                                ": auxiliary information must be 2 characters");
  while (index.size() < 3) index += '.';
  return index + w.aux + w.unit + w.sign + w.data + ' ';
}

std::string FormatBlock(const Block& block) {
  std::string out = block.gsi16 ? "*" : "";
  for (const auto& w : block.words) out += FormatWord(w);
  return out;
}

std::string FormatFile(const std::vector<Block>& blocks) {
  std::string out;
  for (const auto& b : blocks) out += FormatBlock(b) + "\r\n";
  return out;
}

namespace {

// A non-negative magnitude as the zero-filled data field of a word.
std::string DataDigits(int wi, unsigned long long magnitude, bool gsi16) {
  const size_t width = gsi16 ? 16 : 8;
  std::string digits = std::to_string(magnitude);
  if (digits.size() > width) {
    throw std::out_of_range("GSI word " + std::to_string(wi) + ": " + digits + " needs " +
                            std::to_string(digits.size()) + " digits, a GSI-" +
                            std::to_string(width) + " word has " + std::to_string(width));
  }
  return std::string(width - digits.size(), '0') + digits;
}

Word ValueWord(int wi, char unit, double value, double scaled_magnitude, bool gsi16) {
  if (!(scaled_magnitude < 1e17))  // also NaN and infinity
    throw std::out_of_range("GSI word " + std::to_string(wi) + ": " + std::to_string(value) +
                            " is not finite or does not fit in a word");
  const unsigned long long magnitude = std::llround(scaled_magnitude);
  Word w;
  w.wi = wi;
  w.aux = "..";
  w.unit = unit;
  w.sign = value < 0 && magnitude != 0 ? '-' : '+';
  w.gsi16 = gsi16;
  w.data = DataDigits(wi, magnitude, gsi16);
  return w;
}

}  // namespace

Word AngleWord(int wi, double rad, bool gsi16, char unit) {
  const double a = std::abs(rad);
  switch (unit) {
    case '2':
      return ValueWord(wi, unit, rad, a * 200.0 / kPi * 1e5, gsi16);
    case '3':
      return ValueWord(wi, unit, rad, a * 180.0 / kPi * 1e5, gsi16);
    case '4': {  // DDDMMSSs
      if (!(a < 1e6))
        throw std::out_of_range("GSI word " + std::to_string(wi) + ": angle out of range");
      const long long tenths = std::llround(a * 180.0 / kPi * 36000.0);
      const long long degrees = tenths / 36000, rest = tenths % 36000;
      const double packed = static_cast<double>(degrees * 100000 + (rest / 600) * 1000 +
                                                ((rest % 600) / 10) * 10 + rest % 10);
      return ValueWord(wi, unit, rad, packed, gsi16);
    }
    case '5':
      return ValueWord(wi, unit, rad, a * 6400.0 / (2.0 * kPi) * 1e4, gsi16);
    default:
      throw std::invalid_argument(std::string("GSI unit '") + unit +
                                  "' is not an angle unit (2, 3, 4 or 5)");
  }
}

Word LengthWord(int wi, double mm, bool gsi16, char unit) {
  constexpr double kFootMm = 304.8;
  const double a = std::abs(mm);
  switch (unit) {
    case '0':
      return ValueWord(wi, unit, mm, a, gsi16);
    case '1':
      return ValueWord(wi, unit, mm, a / kFootMm * 1000.0, gsi16);
    case '6':
      return ValueWord(wi, unit, mm, a * 10.0, gsi16);
    case '7':
      return ValueWord(wi, unit, mm, a / kFootMm * 10000.0, gsi16);
    case '8':
      return ValueWord(wi, unit, mm, a * 100.0, gsi16);
    default:
      throw std::invalid_argument(std::string("GSI unit '") + unit +
                                  "' is not a length unit (0, 1, 6, 7 or 8)");
  }
}

Word TextWord(int wi, std::string_view text, bool gsi16) {
  const size_t width = gsi16 ? 16 : 8;
  if (text.size() > width) {
    throw std::out_of_range("GSI word " + std::to_string(wi) + ": " + Quoted(std::string(text)) +
                            " is longer than " + std::to_string(width) + " characters");
  }
  Word w;
  w.wi = wi;
  w.aux = wi == 11 || wi == 41 ? "0001" : "..";
  w.gsi16 = gsi16;
  w.data = std::string(width - text.size(), '0') + std::string(text);
  return w;
}

// --- GSI Online -----------------------------------------------------------------------

namespace {

std::optional<int> SmallInteger(std::string_view s) {
  auto v = Integer(s);
  if (!v || *v > 1000000) return std::nullopt;
  return static_cast<int>(*v);
}

}  // namespace

std::string FormatOnlineRequest(const OnlineRequest& q) {
  if (q.kind == OnlineRequest::Kind::kSet)
    return "SET/" + std::to_string(q.param) + "/" + std::to_string(q.value) + "\r\n";
  return std::string("GET/") + q.mode + "/WI" + std::to_string(q.wi) + "\r\n";
}

std::optional<OnlineRequest> ParseOnlineRequest(std::string_view line, std::string* why) {
  const std::string_view text = Trim(line, " \r\n");
  auto fail = [&](std::string m) -> std::optional<OnlineRequest> {
    if (why) *why = std::move(m);
    return std::nullopt;
  };
  OnlineRequest q;
  if (text.rfind("GET/", 0) == 0) {
    if (text.size() < 9 || text[5] != '/' || text.substr(6, 2) != "WI")
      return fail("expected GET/<I|M|C>/WI<word index>, got " + Quoted(std::string(text)));
    q.mode = text[4];
    if (q.mode != 'I' && q.mode != 'M' && q.mode != 'C')
      return fail("GET: expected mode I, M or C in position 5, got " +
                  Quoted(std::string(1, q.mode)));
    auto wi = SmallInteger(text.substr(8));
    if (!wi)
      return fail("GET: expected a word index (digits) after WI, got " +
                  Quoted(std::string(text.substr(8))));
    q.wi = *wi;
    return q;
  }
  if (text.rfind("SET/", 0) == 0) {
    const size_t slash = text.find('/', 4);
    if (slash == std::string_view::npos)
      return fail("expected SET/<parameter>/<value>, got " + Quoted(std::string(text)));
    auto param = SmallInteger(text.substr(4, slash - 4));
    auto value = SmallInteger(text.substr(slash + 1));
    if (!param || !value)
      return fail("SET: expected SET/<parameter digits>/<value digits>, got " +
                  Quoted(std::string(text)));
    q.kind = OnlineRequest::Kind::kSet;
    q.param = *param;
    q.value = *value;
    return q;
  }
  return fail("expected GET/… or SET/…, got " + Quoted(std::string(text)));
}

std::string FormatOnlineReply(const OnlineReply& r) {
  switch (r.kind) {
    case OnlineReply::Kind::kAck:
      return "?\r\n";
    case OnlineReply::Kind::kWarning:
      return "@W" + std::to_string(r.code) + "\r\n";
    case OnlineReply::Kind::kError:
      return "@E" + std::to_string(r.code) + "\r\n";
    case OnlineReply::Kind::kWord:
      break;
  }
  return (r.word.gsi16 ? "*" : "") + FormatWord(r.word) + "\r\n";
}

std::optional<OnlineReply> ParseOnlineReply(std::string_view line, std::string* why) {
  const std::string_view text = Trim(line, " \r\n");
  auto fail = [&](std::string m) -> std::optional<OnlineReply> {
    if (why) *why = std::move(m);
    return std::nullopt;
  };
  if (text.empty()) return fail("empty line");
  OnlineReply r;
  if (text.rfind("@E", 0) == 0 || text.rfind("@W", 0) == 0) {
    auto code = SmallInteger(text.substr(2));
    if (!code)
      return fail("expected a number after " + std::string(text.substr(0, 2)) + ", got " +
                  Quoted(std::string(text)));
    r.kind = text[1] == 'E' ? OnlineReply::Kind::kError : OnlineReply::Kind::kWarning;
    r.code = *code;
    return r;
  }
  if (text == "?") {
    r.kind = OnlineReply::Kind::kAck;
    return r;
  }
  std::string_view word = text.front() == '*' ? text.substr(1) : text;
  auto w = ParseWord(word, word.size() >= 23, why);
  if (!w) return std::nullopt;
  r.word = *w;
  return r;
}

std::string Describe(const OnlineReply& r) { return std::string(Trim(FormatOnlineReply(r), " \r\n")); }

}  // namespace armsig::instruments::gsi
