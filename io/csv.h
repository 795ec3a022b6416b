// The shared CSV reader: every command reads its CSV input through it, so every reader
// follows one dialect rule and gives the same messages:
// - the delimiter is ',', ';' or tab, detected from the header line (or given);
// - a decimal comma ("1,5") is accepted only when the delimiter is ';' or tab; in a
//   comma-separated file it is refused with file:line:column and that reason;
// - quoted fields ("" escapes, may span lines), CRLF and CR line ends, a UTF-8 BOM,
//   '#' comment lines, and the unit suffixes of docs/reference/conventions.md.
// Large inputs (poses, observations) are read row by row (CsvReader), small ones whole
// (CsvTable); both by the same record scanner.
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <initializer_list>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "core/error.h"
#include "core/plausibility.h"
#include "core/units.h"
#include "io/atomic_file.h"

namespace armsig::io {

struct CsvOptions {
  char delimiter = '\0';           // ',', ';' or '\t'; '\0' = detect from the header line
  bool skip_comment_lines = true;  // lines starting with '#'
  std::size_t read_piece_bytes = std::size_t{1} << 20;  // CsvReader: bytes read at a time
};

// Whether numbers may use a decimal comma with this delimiter (';' or tab).
bool DecimalCommaAllowed(char delimiter);

struct CsvRow {
  int line = 0;  // 1-based line number in the file (of the row's first line)
  std::vector<std::string> fields;
};

struct AngleColumn {
  int index = -1;
  AngleUnit unit = AngleUnit::kRad;
  std::string name;  // full column name, e.g. "q3_deg"
};

// A CSV input's header and what its readers ask of the fields of a row: columns by name,
// numbers, angles and names with file:line:column in every message.
class CsvColumns {
 public:
  CsvColumns(std::string source, std::vector<std::string> header, CsvOptions options,
             int header_line = 1);

  const std::string& source() const { return source_; }
  const std::vector<std::string>& header() const { return header_; }
  int header_line() const { return header_line_; }  // 1-based; after leading comment lines
  // Where a header column is: file:header_line:column (name).
  SourceLocation HeaderWhere(int column) const;
  char delimiter() const { return options_.delimiter; }
  bool decimal_comma() const { return DecimalCommaAllowed(options_.delimiter); }

  std::optional<int> FindColumn(std::string_view name) const;
  // Throws InputError naming the file and the expected column.
  int Column(std::string_view name) const;
  // "hz" finds hz_gon, hz_deg or hz_rad; two of them (the same quantity in two units) are
  // refused naming both columns.
  std::optional<AngleColumn> FindAngleColumn(std::string_view base) const;
  AngleColumn AngleColumnOf(std::string_view base) const;

  // A finite number; throws InputError(file, line, column, name) otherwise.
  double Number(const CsvRow& row, int column) const;
  // nullopt when the field is empty; throws when it is not a finite number.
  std::optional<double> OptionalNumber(const CsvRow& row, int column) const;
  // A finite number that is also a plausible `quantity` given in `unit`
  // (core/plausibility.h); throws InputError naming the range otherwise.
  double Number(const CsvRow& row, int column, plausible::Quantity quantity,
                plausible::Unit unit = plausible::kMm) const;
  std::optional<double> OptionalNumber(const CsvRow& row, int column, plausible::Quantity quantity,
                                       plausible::Unit unit = plausible::kMm) const;
  // An angle in rad from a column with a unit suffix; always a plausible angle (joint
  // angles within ±720 deg, others within two turns).
  double AngleRad(const CsvRow& row, const AngleColumn& column,
                  plausible::Quantity quantity = plausible::Quantity::kAngle) const;
  int Integer(const CsvRow& row, int column) const;
  const std::string& Text(const CsvRow& row, int column) const;
  // An id or name: ≤ 64 bytes, no control characters (plausible::CheckName).
  const std::string& Name(const CsvRow& row, int column) const;

  SourceLocation Where(const CsvRow& row, int column) const;

  // Refuses (file:1:column) a header column that gives one of the `known` quantities in a
  // unit armsig does not read, or without a unit, where the reader would otherwise leave it
  // unread and use a default: distance_m or distance next to a known distance_mm,
  // sigma_hz_mgon next to sigma_hz_arcsec, hz_grad next to an angle column given as "hz_*"
  // (any of _gon, _deg, _rad). Names without a unit ("point") are not checked; other
  // columns are the file's own (extra columns are ignored: docs/reference/file-formats.md).
  void RefuseUnreadUnits(const std::vector<std::string>& known) const;

 protected:
  CsvColumns() = default;
  void SetHeader(std::string source, std::vector<std::string> header, CsvOptions options,
                 int header_line);

 private:
  std::string source_;
  std::vector<std::string> header_;
  CsvOptions options_;
  int header_line_ = 1;
};

// A whole CSV input in memory (small files: plans, control points, joint logs).
class CsvTable : public CsvColumns {
 public:
  CsvTable(std::string source, std::vector<std::string> header, std::vector<CsvRow> rows,
           CsvOptions options, int header_line = 1);
  const std::vector<CsvRow>& rows() const { return rows_; }

 private:
  std::vector<CsvRow> rows_;
};

// The longest record a CSV reader takes (a quoted field may span lines): far beyond any row
// of armsig's formats; a longer one is an unterminated quote or not a CSV file.
inline constexpr std::size_t kMaxCsvRecordBytes = std::size_t{1} << 20;  // 1 MiB

// How far a long read has come, for a progress line (app/: on stderr when it is a terminal).
struct ReadProgress {
  std::string source;
  std::size_t bytes = 0, total_bytes = 0;  // read so far, and the file's size
  int64_t rows = 0;
};
using ReadProgressFn = std::function<void(const ReadProgress&)>;

// A CSV file read one row at a time, by the rules of ParseCsv: memory for one record (at
// most kMaxCsvRecordBytes) and a 1 MiB buffer whatever the file's size (kCsvStreamLimit).
class CsvReader : public CsvColumns {
 public:
  // Opens the file (as ReadWholeFile: a regular file) and reads its header. Throws
  // InputError as ParseCsv does.
  explicit CsvReader(const std::string& path, CsvOptions options = {},
                     ReadProgressFn progress = nullptr);
  ~CsvReader();
  // The next data row, its field count checked against the header; false at the end.
  bool Next(CsvRow& row);
  int64_t rows_read() const { return rows_; }

 private:
  bool NextRecord(CsvRow& row, bool header_done);
  bool Fill();  // reads more of the file; false at its end

  std::unique_ptr<InputFile> file_;
  CsvOptions requested_;
  std::string buffer_;
  std::size_t at_ = 0;        // the next record's first byte in buffer_
  std::size_t consumed_ = 0;  // bytes of the file before buffer_
  int line_ = 1;
  char delimiter_ = '\0';
  bool eof_ = false;
  bool bom_checked_ = false;
  int64_t rows_ = 0;
  ReadProgressFn progress_;
};

// Parses CSV text; `source` names it in messages. The first non-comment line is the header.
// Throws InputError for a delimiter other than ',', ';' or tab, a header naming a column
// twice, and for a row whose field count differs from the header's (naming the column
// where it departs, and the likely decimal comma in a comma-separated file).
CsvTable ParseCsv(std::string_view text, std::string source, CsvOptions options = {});
// Reads (io::ReadWholeFile: a regular file of at most kCsvFileLimit) and parses a file;
// throws InputError when it cannot be read.
CsvTable ReadCsvFile(const std::string& path, CsvOptions options = {});

// Parses a whole field as a finite double ("1.5", "-2e-3", with decimal_comma "1,5").
std::optional<double> ParseNumber(std::string_view text, bool decimal_comma = false);

// Quotes a field for CSV output when it needs it.
std::string CsvEscape(std::string_view field);

}  // namespace armsig::io
