// Monospace text laid out for a terminal of a given width (100 columns for every table and
// narrative line armsig prints): tables whose columns continue in a further block instead
// of wrapping mid-row, and paragraphs wrapped at word boundaries.
#pragma once

#include <string>
#include <string_view>
#include <vector>

namespace armsig {

// Columns a text takes on a terminal: one per code point (armsig prints no wide
// characters); bytes that are not UTF-8 count one each.
int DisplayWidth(std::string_view text);

// A table with a label column (left-aligned) and value columns (right-aligned), each as
// wide as its widest cell:
//
//   TextTable t({"i =", "1", "2"});
//   t.AddRow({"a_i (mm)", "0.078", "0.102"});
//   std::cout << t.Render(100);
class TextTable {
 public:
  explicit TextTable(std::vector<std::string> header);
  // Cells beyond the header's count are dropped, missing ones are blank.
  void AddRow(std::vector<std::string> cells);
  // The table in lines of at most `width` columns (`indent` spaces before each line, `gap`
  // between columns): the value columns that do not fit beside the label column continue
  // in a further block below, with the label column and their headers again, after a
  // blank line. Only a label column wider than `width` itself makes a longer line.
  std::string Render(int width = 100, int indent = 0, int gap = 2) const;

 private:
  std::vector<std::string> header_;
  std::vector<std::vector<std::string>> rows_;
};

// Each line of `text` wrapped at spaces to at most `width` columns; a continuation line
// starts with the line's own leading spaces plus `hanging` more. A word longer than the
// width (a path) stays whole on its own line.
std::string WrapLines(std::string_view text, int width = 100, int hanging = 2);

}  // namespace armsig
