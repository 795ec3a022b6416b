#include "instruments/gsi_codec.h"

#include <charconv>
#include <cmath>
#include <cstdio>
#include <numbers>

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
    return fail("expected a word index (digits and '.') in positions 1-3, got '" +
                std::string(text.substr(0, 3)) + "'");
  w.wi = static_cast<int>(*number);
  w.sign = text[6];
  if (w.sign != '+' && w.sign != '-') {
    return fail("expected '+' or '-' in position 7, got '" + std::string(1, w.sign) + "'");
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
            word ? "expected a 16- or 24-character GSI word, got '" + std::string(word_text) + "'"
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
  if (!v) return fail("expected digits, got '" + d + "'");
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
      if (minutes >= 60 || seconds >= 60) return fail("minutes or seconds ≥ 60 in '" + d + "'");
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
  if (!v) return fail("expected digits, got '" + w.data + "'");
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
  if (!AllDigits(w.aux)) return std::nullopt;
  return std::stoi(w.aux);
}

namespace {
std::string Compose(int wi, std::string_view aux2, char unit, char sign, std::string_view digits,
                    bool gsi16) {
  std::string index = std::to_string(wi);
  while (index.size() < 3) index += '.';
  std::string data(digits);
  const size_t width = gsi16 ? 16 : 8;
  if (data.size() > width) data = data.substr(data.size() - width);
  while (data.size() < width) data = "0" + data;
  return (gsi16 ? "" : "") + index + std::string(aux2) + unit + sign + data + ' ';
}
}  // namespace

std::string EncodeAngleWord(int wi, double rad, bool gsi16, char unit) {
  while (rad < 0) rad += 2 * kPi;
  long long value = 0;
  if (unit == '3') {
    value = std::llround(rad * 180.0 / kPi * 1e5);
  } else if (unit == '4') {
    const long long tenths_total = std::llround(rad * 180.0 / kPi * 36000.0);
    const long long degrees = tenths_total / 36000, rest = tenths_total % 36000;
    value = degrees * 100000 + (rest / 600) * 1000 + ((rest % 600) / 10) * 10 + rest % 10;
  } else {
    unit = '2';
    value = std::llround(rad * 200.0 / kPi * 1e5);
  }
  return Compose(wi, "..", unit, '+', std::to_string(value), gsi16);
}

std::string EncodeLengthWord(int wi, double mm, bool gsi16, char unit) {
  double scale = 1.0;
  if (unit == '6')
    scale = 10.0;
  else if (unit == '8')
    scale = 100.0;
  else
    unit = '0';
  const long long value = std::llround(std::abs(mm) * scale);
  return Compose(wi, "..", unit, mm < 0 ? '-' : '+', std::to_string(value), gsi16);
}

std::string EncodeTextWord(int wi, std::string_view text, bool gsi16) {
  std::string index = std::to_string(wi);
  while (index.size() < 2) index += '.';
  const size_t width = gsi16 ? 16 : 8;
  std::string data(text.substr(0, width));
  while (data.size() < width) data = "0" + data;
  // WI 11/41 use positions 3–6 for the block number; others two '.' then unit '.'.
  if (wi == 11 || wi == 41) return index + "0001" + '+' + data + ' ';
  while (index.size() < 3) index += '.';
  return index + "..." + '+' + data + ' ';
}

}  // namespace armsig::instruments::gsi
