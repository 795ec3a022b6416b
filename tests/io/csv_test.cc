#include "io/csv.h"

#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <vector>

#include "core/error.h"
#include "test_support.h"

namespace armsig::io {

TEST(Csv, ReadsQuotedFieldsCrlfAndBom) {
  const auto t = ParseCsv(
      "\xEF\xBB\xBFpoint,note,x_mm\r\n"
      "P1,\"a, b\",1.5\r\n"
      "\"P2\",\"say \"\"hi\"\"\",-2e-3\r\n",
      "mem.csv");
  ASSERT_EQ(t.rows().size(), 2u);
  EXPECT_EQ(t.header()[0], "point");
  EXPECT_EQ(t.Text(t.rows()[0], 1), "a, b");
  EXPECT_EQ(t.Text(t.rows()[1], 1), "say \"hi\"");
  EXPECT_DOUBLE_EQ(t.Number(t.rows()[1], t.Column("x_mm")), -2e-3);
  EXPECT_EQ(t.rows()[1].line, 3);
}

TEST(Csv, QuotedFieldMaySpanLinesAndLineNumbersFollow) {
  const auto t = ParseCsv("a,b\n1,\"two\nlines\"\n3,4\n", "mem.csv");
  ASSERT_EQ(t.rows().size(), 2u);
  EXPECT_EQ(t.Text(t.rows()[0], 1), "two\nlines");
  EXPECT_EQ(t.rows()[1].line, 4);
}

TEST(Csv, FindsAngleColumnsByAnySuffix) {
  const auto t = ParseCsv("point,hz_gon,v_deg,q1_rad\nA,100,90,0.5\n", "mem.csv");
  const AngleColumn hz = t.AngleColumnOf("hz");
  EXPECT_NEAR(t.AngleRad(t.rows()[0], hz), M_PI / 2, 1e-15);
  EXPECT_NEAR(t.AngleRad(t.rows()[0], t.AngleColumnOf("v")), M_PI / 2, 1e-15);
  EXPECT_NEAR(t.AngleRad(t.rows()[0], t.AngleColumnOf("q1")), 0.5, 1e-15);
}

TEST(Csv, SemicolonsAndDecimalCommas) {
  const auto t = ParseCsv("a;b\n1,5;-2,25E-1\n", "mem.csv");
  EXPECT_EQ(t.delimiter(), ';');
  EXPECT_TRUE(t.decimal_comma());
  EXPECT_DOUBLE_EQ(t.Number(t.rows()[0], 0), 1.5);
  EXPECT_DOUBLE_EQ(t.Number(t.rows()[0], 1), -0.225);
}

TEST(Csv, TabsAndDecimalCommas) {
  const auto t = ParseCsv("pose\tx_mm\ty_mm\nP1\t12,5\t3.25\n", "mem.tsv");
  EXPECT_EQ(t.delimiter(), '\t');
  EXPECT_DOUBLE_EQ(t.Number(t.rows()[0], 1), 12.5);
  EXPECT_DOUBLE_EQ(t.Number(t.rows()[0], 2), 3.25);  // a decimal point stays one
}

TEST(Csv, CommaFileDetectedAndNoDecimalComma) {
  const auto t = ParseCsv("pose,x_mm\nP1,1.5\n", "mem.csv");
  EXPECT_EQ(t.delimiter(), ',');
  EXPECT_FALSE(t.decimal_comma());
  EXPECT_FALSE(DecimalCommaAllowed(','));
  EXPECT_TRUE(DecimalCommaAllowed(';'));
  EXPECT_TRUE(DecimalCommaAllowed('\t'));
}

// A decimal comma in a comma-separated file, quoted so the row still has its fields:
// refused at its line and column, saying why.
TEST(Csv, QuotedDecimalCommaInCommaFileNamesLineAndColumn) {
  const auto t = ParseCsv("pose,x_mm,y_mm\nP1,1.0,2.0\nP2,\"1,5\",2.0\n", "poses.csv");
  try {
    t.Number(t.rows()[1], 1);
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_EQ(e.where().file, "poses.csv");
    EXPECT_EQ(e.where().line, 3);
    EXPECT_EQ(e.where().column, 2);
    EXPECT_EQ(e.where().column_name, "x_mm");
    EXPECT_NE(std::string(e.what()).find("'1,5'"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("a decimal comma needs ';' or tab"), std::string::npos)
        << e.what();
  }
}

// Unquoted, the decimal comma splits the number into two fields: the row has one field
// too many, and the split is named at its column.
TEST(Csv, SplitDecimalCommaInCommaFileNamesLineAndColumn) {
  try {
    ParseCsv("pose,x_mm,y_mm\nP1,1.0,2.0\nP2,4.0,-2,5\n", "poses.csv");
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_EQ(e.where().file, "poses.csv");
    EXPECT_EQ(e.where().line, 3);
    EXPECT_EQ(e.where().column, 3);
    EXPECT_NE(std::string(e.what()).find("'-2,5' looks like a decimal comma"), std::string::npos)
        << e.what();
  }
  // Several candidates for one extra field: no guessed split, but the line, the first
  // column beyond the header (the one too many) and the hint.
  try {
    ParseCsv("a,b,c\n1,2,3,4\n", "f.csv");
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_EQ(e.where().line, 2);
    EXPECT_EQ(e.where().column, 4);
    EXPECT_NE(std::string(e.what()).find("a decimal comma?"), std::string::npos) << e.what();
  }
}

TEST(Csv, OtherDelimitersAreRefused) {
  CsvOptions options;
  options.delimiter = '|';
  EXPECT_THROW(ParseCsv("a|b\n1|2\n", "f.csv", options), InputError);
}

TEST(Csv, BadNumberNamesFileLineColumn) {
  const auto t = ParseCsv("pose,x_mm\nP1,1.0\nP2,abc\n", "poses.csv");
  try {
    t.Number(t.rows()[1], 1);
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_EQ(e.where().file, "poses.csv");
    EXPECT_EQ(e.where().line, 3);
    EXPECT_EQ(e.where().column, 2);
    EXPECT_EQ(e.where().column_name, "x_mm");
    EXPECT_NE(std::string(e.what()).find("'abc'"), std::string::npos);
  }
}

TEST(Csv, RejectsNanInfinityAndPartialNumbers) {
  EXPECT_FALSE(ParseNumber("nan").has_value());
  EXPECT_FALSE(ParseNumber("inf").has_value());
  EXPECT_FALSE(ParseNumber("1.5mm").has_value());
  EXPECT_FALSE(ParseNumber("").has_value());
  EXPECT_EQ(ParseNumber(" +2.5 ").value(), 2.5);
}

TEST(Csv, WrongFieldCountNamesTheLine) {
  try {
    ParseCsv("a,b\n1,2\n3\n", "f.csv");
    FAIL();
  } catch (const InputError& e) {
    EXPECT_EQ(e.where().line, 3);
  }
}

TEST(Csv, UnterminatedQuoteIsAnError) {
  EXPECT_THROW(ParseCsv("a,b\n1,\"open\n", "f.csv"), InputError);
}

TEST(Csv, MissingColumnIsNamed) {
  const auto t = ParseCsv("a,b\n1,2\n", "f.csv");
  try {
    t.AngleColumnOf("q1");
    FAIL();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("q1_deg"), std::string::npos);
  }
}

TEST(Csv, MissingFileIsAnInputError) {
  EXPECT_THROW(ReadCsvFile("/nonexistent/file.csv"), InputError);
}

namespace {

// Every row of `path` read by CsvReader with `piece` bytes at a time.
std::vector<CsvRow> ReadRows(const std::string& path, std::size_t piece, CsvOptions options = {}) {
  options.read_piece_bytes = piece;
  CsvReader reader(path, options);
  std::vector<CsvRow> rows;
  for (CsvRow row; reader.Next(row);) rows.push_back(row);
  return rows;
}

std::string Message(const std::function<void()>& f) {
  try {
    f();
  } catch (const InputError& e) {
    return e.what();
  }
  return "no error";
}

}  // namespace

// The row-by-row reader is ParseCsv, whatever the pieces it reads the file in: a BOM, quoted
// fields over lines with "" escapes, CRLF, a lone CR, comments, blank lines; the same
// fields, the same line numbers, the same header and delimiter.
TEST(CsvReader, ReadsWhatParseCsvReadsWhateverThePieces) {
  const std::string text =
      "\xEF\xBB\xBF# a comment\r\n\r\n"
      "point;note;x_mm\r\n"
      "P1;\"a; b\";1,5\r\n"
      "\"P2\";\"say \"\"hi\"\"\r\nover lines\";-2e-3\r"
      "P3;\"\";7\n"
      "# between\n\n"
      "P4;  spaced  ;8";
  testing::TempDir dir;
  const std::string path = dir.File("t.csv");
  testing::WriteText(path, text);
  const CsvTable whole = ParseCsv(text, path);
  ASSERT_EQ(whole.rows().size(), 4u);
  for (std::size_t piece : {1, 2, 3, 5, 7, 64, 1 << 20}) {
    const auto rows = ReadRows(path, piece);
    ASSERT_EQ(rows.size(), whole.rows().size()) << piece;
    for (std::size_t k = 0; k < rows.size(); ++k) {
      EXPECT_EQ(rows[k].fields, whole.rows()[k].fields) << piece << " row " << k;
      EXPECT_EQ(rows[k].line, whole.rows()[k].line) << piece << " row " << k;
    }
    CsvOptions o;
    o.read_piece_bytes = piece;
    const CsvReader reader(path, o);
    EXPECT_EQ(reader.header(), whole.header());
    EXPECT_EQ(reader.header_line(), whole.header_line());
    EXPECT_EQ(reader.delimiter(), ';');
  }
}

// Its refusals are ParseCsv's, at the same file:line:column.
TEST(CsvReader, RefusesWhatParseCsvRefusesAtTheSamePlace) {
  testing::TempDir dir;
  for (const std::string text : {"a,b\n1,2\n3\n", "a,b\n1,\"open\n", "a,a\n1,2\n", "",
                                 "# only a comment\n", "a,b\n1,2,5\n"}) {
    const std::string path = dir.File("bad.csv");
    testing::WriteText(path, text);
    const std::string whole = Message([&] { ParseCsv(text, path); });
    for (std::size_t piece : {1, 3, 1 << 20}) {
      EXPECT_EQ(Message([&] { ReadRows(path, piece); }), whole) << text << " piece " << piece;
    }
    EXPECT_NE(whole, "no error") << text;
  }
}

// A record longer than 1 MiB (an unterminated quote in a large file) is refused naming its
// line, having read no more than the limit into memory.
TEST(CsvReader, ARecordLongerThanTheLimitIsRefused) {
  testing::TempDir dir;
  const std::string path = dir.File("long.csv");
  testing::WriteText(path, "a,b\n1,2\n3,\"" + std::string(kMaxCsvRecordBytes + 10, 'x'));
  const std::string what = Message([&] { ReadRows(path, 1 << 16); });
  EXPECT_NE(what.find("long.csv:3"), std::string::npos) << what.substr(0, 200);
  EXPECT_NE(what.find("longer than 1 MiB"), std::string::npos) << what.substr(0, 200);
}

// Issue 38: a header of a million columns (10 MB on one line) kept every whole-file reader
// (predict --joints, compensate --targets, …) busy for minutes: each column name was compared
// with every earlier one. The whole-file reader takes records of at most 1 MiB, as the
// streaming one does, and finds a repeated name in one pass.
TEST(ParseCsv, AHeaderLongerThanTheRecordLimitIsRefusedAsTheStreamingReaderDoes) {
  std::string header = "q1_deg";
  for (int c = 0; header.size() <= kMaxCsvRecordBytes; ++c) header += ",c" + std::to_string(c);
  const std::string text = "# a comment\n" + header + "\n1\n";
  const std::string what = Message([&] { ParseCsv(text, "wide.csv"); });
  EXPECT_EQ(what.substr(0, 29), "wide.csv:2: a record longer t") << what.substr(0, 200);
  testing::TempDir dir;
  testing::WriteText(dir.File("wide.csv"), text);
  const std::string streamed = Message([&] { ReadRows(dir.File("wide.csv"), 1 << 16); });
  EXPECT_NE(streamed.find("longer than 1 MiB"), std::string::npos) << streamed.substr(0, 200);
  // 90,000 distinct names under the bound, the last one repeating the first: found at once.
  std::string names = "c0";
  for (int c = 1; c < 90000; ++c) names += ",c" + std::to_string(c);
  names += ",c0";
  EXPECT_EQ(Message([&] { ParseCsv(names + "\n", "dup.csv"); }),
            "dup.csv:1:90001 (c0): duplicate column 'c0' (also column 1): expected each column "
            "once");
}

}  // namespace armsig::io
