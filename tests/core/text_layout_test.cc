// Tables and paragraphs laid out for a terminal (core/text_layout.h): no line beyond the
// width, every cell still there, in its row and under its header.
#include "core/text_layout.h"

#include <gtest/gtest.h>

#include <sstream>

#include "test_support.h"

namespace armsig {
namespace {

TEST(TextLayout, DisplayWidthCountsCodePoints) {
  EXPECT_EQ(DisplayWidth("abc"), 3);
  EXPECT_EQ(DisplayWidth("α (1e-3 rad)"), 12);
  EXPECT_EQ(DisplayWidth("—"), 1);
}

TEST(TextLayout, AFittingTableIsOneBlockWithRightAlignedValues) {
  TextTable t({"i =", "1", "2"});
  t.AddRow({"alpha_i (1e-3 rad)", "0.009", "-14.670"});
  t.AddRow({"a_i (mm)", "—"});
  EXPECT_EQ(t.Render(100),
            "i =                     1        2\n"
            "alpha_i (1e-3 rad)  0.009  -14.670\n"
            "a_i (mm)                —\n");
}

// Seven columns of nine-character numbers beside an eighteen-character label, indented by
// two, on a 70-column terminal: 20 + 4 × (2 + 9) = 64 columns take four of them, so two
// blocks, every line within 70 columns, each value once, under its header.
TEST(TextLayout, ColumnsThatDoNotFitContinueInABlockBelow) {
  std::vector<std::string> header = {"i ="};
  for (int i = 1; i <= 7; ++i) header.push_back(std::to_string(i));
  TextTable t(header);
  std::vector<std::string> row = {"gamma_i (1e-3 rad)"};
  for (int i = 1; i <= 7; ++i) row.push_back(std::to_string(-1000 - i) + ".123");
  t.AddRow(row);
  const auto lines = testing::Lines(t.Render(70, 2));
  int blocks = 1;
  for (const auto& l : lines) {
    EXPECT_LE(DisplayWidth(l), 70) << l;
    blocks += l.empty();
  }
  EXPECT_EQ(blocks, 2);
  const std::string text = t.Render(70, 2);
  for (int i = 1; i <= 7; ++i) {
    const std::string value = std::to_string(-1000 - i) + ".123";
    EXPECT_EQ(text.find(value), text.rfind(value)) << value;
    // Right-aligned under its header: both end in the same column.
    for (size_t k = 0; k + 1 < lines.size(); ++k) {
      const size_t at = lines[k + 1].find(value);
      if (at == std::string::npos) continue;
      EXPECT_EQ(lines[k].find_last_not_of(' ', at + value.size() - 1), at + value.size() - 1);
      EXPECT_EQ(lines[k][at + value.size() - 1], '0' + i) << lines[k];
    }
  }
}

TEST(TextLayout, LongLinesWrapAtSpacesWithAHangingIndent) {
  const std::string text =
      "1. stations oriented from 24 readings (mutual pointings, 3 bar set-ups): sigma0 0.942, "
      "25 degrees of freedom, no reading removed by data snooping\n   T1  x     0.000  y\n";
  const std::string wrapped = WrapLines(text, 60);
  const auto lines = testing::Lines(wrapped);
  ASSERT_EQ(lines.size(), 4u) << wrapped;
  for (const auto& l : lines) EXPECT_LE(DisplayWidth(l), 60) << l;
  EXPECT_EQ(lines[1].rfind("  ", 0), 0u);        // hanging indent
  EXPECT_EQ(lines[3], "   T1  x     0.000  y");  // a short line keeps its spacing
  EXPECT_EQ(wrapped.back(), '\n');
  // Nothing lost: the words are the same.
  auto words = [](const std::string& s) {
    std::istringstream in(s);
    std::vector<std::string> out;
    for (std::string w; in >> w;) out.push_back(w);
    return out;
  };
  EXPECT_EQ(words(wrapped), words(text));
  // A word longer than the width stays whole.
  const std::string path = "/tmp/" + std::string(80, 'x');
  EXPECT_EQ(WrapLines("in " + path + " now", 40), "in\n  " + path + "\n  now");
}

}  // namespace
}  // namespace armsig
