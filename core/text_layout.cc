#include "core/text_layout.h"

#include <algorithm>

namespace armsig {

int DisplayWidth(std::string_view text) {
  int width = 0;
  for (unsigned char c : text) width += (c & 0xc0) != 0x80;  // not a continuation byte
  return width;
}

TextTable::TextTable(std::vector<std::string> header) : header_(std::move(header)) {}

void TextTable::AddRow(std::vector<std::string> cells) {
  cells.resize(header_.size());
  rows_.push_back(std::move(cells));
}

std::string TextTable::Render(int width, int indent, int gap) const {
  const size_t columns = header_.size();
  if (columns == 0) return "";
  std::vector<int> widths(columns, 0);
  auto measure = [&](const std::vector<std::string>& cells) {
    for (size_t c = 0; c < columns; ++c) widths[c] = std::max(widths[c], DisplayWidth(cells[c]));
  };
  measure(header_);
  for (const auto& row : rows_) measure(row);
  auto pad = [](const std::string& cell, int to, bool right) {
    const std::string fill(std::max(0, to - DisplayWidth(cell)), ' ');
    return right ? fill + cell : cell + fill;
  };
  // Blocks of value columns, each as many as fit beside the label column (at least one).
  std::string out;
  size_t first = 1;
  const int label = indent + widths[0];
  do {
    size_t last = first;
    int used = label;
    while (last < columns && (last == first || used + gap + widths[last] <= width)) {
      used += gap + widths[last];
      ++last;
    }
    if (first > 1) out += "\n";
    auto line = [&](const std::vector<std::string>& cells) {
      std::string text = std::string(indent, ' ') + pad(cells[0], widths[0], false);
      for (size_t c = first; c < last; ++c)
        text += std::string(gap, ' ') + pad(cells[c], widths[c], true);
      while (!text.empty() && text.back() == ' ') text.pop_back();
      out += text + "\n";
    };
    line(header_);
    for (const auto& row : rows_) line(row);
    first = last;
  } while (first < columns);
  return out;
}

std::string WrapLines(std::string_view text, int width, int hanging) {
  std::string out;
  size_t start = 0;
  while (true) {
    size_t end = text.find('\n', start);
    const bool last_line = end == std::string_view::npos;
    if (last_line) end = text.size();
    const std::string_view line = text.substr(start, end - start);
    if (DisplayWidth(line) <= width) {
      out += line;
    } else {
      // Words with the spaces before them; a break replaces those spaces.
      const size_t lead = std::min(line.find_first_not_of(' '), line.size());
      const std::string continuation(lead + std::max(hanging, 0), ' ');
      std::string current(line.substr(0, lead));
      int current_width = static_cast<int>(lead);
      bool empty = true;  // no word on `current` yet
      size_t at = lead;
      while (at < line.size()) {
        const size_t word_at = std::min(line.find_first_not_of(' ', at), line.size());
        if (word_at == line.size()) break;  // trailing spaces
        size_t word_end = std::min(line.find(' ', word_at), line.size());
        const std::string_view spaces = line.substr(at, word_at - at);
        const std::string_view word = line.substr(word_at, word_end - word_at);
        const int w = DisplayWidth(word);
        if (!empty && current_width + static_cast<int>(spaces.size()) + w > width) {
          out += current + "\n";
          current = continuation;
          current_width = static_cast<int>(continuation.size());
          empty = true;
        }
        if (!empty) {
          current += spaces;
          current_width += static_cast<int>(spaces.size());
        }
        current += word;
        current_width += w;
        empty = false;
        at = word_end;
      }
      out += current;
    }
    if (last_line) break;
    out += "\n";
    start = end + 1;
  }
  return out;
}

}  // namespace armsig
