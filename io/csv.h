// The shared CSV reader: every command reads its CSV input through it.
// Understands quoted fields ("" escapes), CRLF and CR line ends, a UTF-8 BOM, any
// single-character delimiter, decimal commas, and the SPEC's unit suffixes.
#pragma once

#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "core/error.h"
#include "core/units.h"

namespace armsig::io {

struct CsvOptions {
  char delimiter = ',';            // '\0' = guess from the header line (',', ';' or tab)
  bool decimal_comma = false;      // "1,5" is 1.5 (needs a delimiter other than ',')
  bool skip_comment_lines = true;  // lines starting with '#'
};

struct CsvRow {
  int line = 0;  // 1-based line number in the file (of the row's first line)
  std::vector<std::string> fields;
};

struct AngleColumn {
  int index = -1;
  AngleUnit unit = AngleUnit::kRad;
  std::string name;  // full column name, e.g. "q3_deg"
};

class CsvTable {
 public:
  CsvTable(std::string source, std::vector<std::string> header, std::vector<CsvRow> rows,
           CsvOptions options);

  const std::string& source() const { return source_; }
  const std::vector<std::string>& header() const { return header_; }
  const std::vector<CsvRow>& rows() const { return rows_; }

  std::optional<int> FindColumn(std::string_view name) const;
  // Throws InputError naming the file and the expected column.
  int Column(std::string_view name) const;
  // "hz" finds hz_gon, hz_deg or hz_rad.
  std::optional<AngleColumn> FindAngleColumn(std::string_view base) const;
  AngleColumn AngleColumnOf(std::string_view base) const;

  // A finite number; throws InputError(file, line, column, name) otherwise.
  double Number(const CsvRow& row, int column) const;
  // nullopt when the field is empty; throws when it is not a finite number.
  std::optional<double> OptionalNumber(const CsvRow& row, int column) const;
  double AngleRad(const CsvRow& row, const AngleColumn& column) const;
  int Integer(const CsvRow& row, int column) const;
  const std::string& Text(const CsvRow& row, int column) const;

  SourceLocation Where(const CsvRow& row, int column) const;

 private:
  std::string source_;
  std::vector<std::string> header_;
  std::vector<CsvRow> rows_;
  CsvOptions options_;
};

// Parses CSV text; `source` names it in messages. The first non-comment line is the header.
CsvTable ParseCsv(std::string_view text, std::string source, CsvOptions options = {});
// Reads and parses a file; throws InputError when it cannot be read.
CsvTable ReadCsvFile(const std::string& path, CsvOptions options = {});

// Parses a whole field as a finite double ("1.5", "-2e-3", with decimal_comma "1,5").
std::optional<double> ParseNumber(std::string_view text, bool decimal_comma = false);

// Quotes a field for CSV output when it needs it.
std::string CsvEscape(std::string_view field);

}  // namespace armsig::io
