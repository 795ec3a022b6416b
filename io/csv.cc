#include "io/csv.h"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <charconv>
#include <cmath>
#include <set>
#include <string_view>
#include <unordered_map>

#include "core/text.h"
#include "io/atomic_file.h"

namespace armsig::io {

namespace {

char GuessDelimiter(std::string_view header_line) {
  size_t commas = 0, semicolons = 0, tabs = 0;
  bool quoted = false;
  for (char c : header_line) {
    if (c == '"') quoted = !quoted;
    if (quoted) continue;
    commas += c == ',';
    semicolons += c == ';';
    tabs += c == '\t';
  }
  if (semicolons > commas && semicolons >= tabs) return ';';
  if (tabs > commas) return '\t';
  return ',';
}

bool AllDigits(std::string_view s) {
  return !s.empty() && s.find_first_not_of("0123456789") == std::string_view::npos;
}

// "12" or "-12": what is left before the comma of a split "12,5".
bool IntegerPart(std::string_view s) {
  if (!s.empty() && (s.front() == '-' || s.front() == '+')) s.remove_prefix(1);
  return AllDigits(s);
}

// "5" or "5e-3": what is left after the comma of a split "12,5".
bool FractionPart(std::string_view s) {
  const size_t e = s.find_first_of("eE");
  if (e == std::string_view::npos) return AllDigits(s);
  std::string_view exponent = s.substr(e + 1);
  if (!exponent.empty() && (exponent.front() == '-' || exponent.front() == '+'))
    exponent.remove_prefix(1);
  return AllDigits(s.substr(0, e)) && AllDigits(exponent);
}

constexpr const char* kDecimalCommaHint =
    "a decimal comma needs ';' or tab as the delimiter; with ',' numbers use a decimal point";

// A comma-separated row with more fields than the header: when exactly as many field
// pairs look like a number split at its decimal comma ("12" then "5") as there are
// extra fields, the first such pair is named.
[[noreturn]] void ThrowFieldCount(const std::string& source, const CsvRow& row, size_t expected,
                                  char delimiter) {
  const std::string counts = "expected " + std::to_string(expected) +
                             " fields as in the header, found " + std::to_string(row.fields.size());
  // The column where the row departs from the header: its first missing or extra field.
  const int departs = static_cast<int>(std::min(row.fields.size(), expected)) + 1;
  if (delimiter != ',' || row.fields.size() <= expected) {
    throw InputError({source, row.line, departs, ""},
                     counts + (row.fields.size() < expected ? " (the row ends before this column)"
                                                            : " (this field is one too many)"));
  }
  std::vector<size_t> splits;
  for (size_t c = 0; c + 1 < row.fields.size(); ++c) {
    if (IntegerPart(row.fields[c]) && FractionPart(row.fields[c + 1])) {
      splits.push_back(c);
      ++c;  // "1,5,2,5": pairs do not overlap
    }
  }
  if (splits.size() == row.fields.size() - expected) {
    const int column = static_cast<int>(splits.front()) + 1;
    throw InputError({source, row.line, column, ""},
                     counts + ": " +
                         Quoted(row.fields[splits.front()] + "," + row.fields[splits.front() + 1]) +
                         " looks like a decimal comma (" + kDecimalCommaHint + ")");
  }
  throw InputError({source, row.line, departs, ""},
                   counts + " (a decimal comma? " + std::string(kDecimalCommaHint) + ")");
}

}  // namespace

bool DecimalCommaAllowed(char delimiter) { return delimiter == ';' || delimiter == '\t'; }

std::optional<double> ParseNumber(std::string_view text, bool decimal_comma) {
  text = Trim(text, " \t");
  if (text.empty()) return std::nullopt;
  std::string buffer;
  if (decimal_comma && text.find(',') != std::string_view::npos) {
    buffer.assign(text);
    for (char& c : buffer) {
      if (c == ',') c = '.';
    }
    text = buffer;
  }
  if (text.front() == '+') text.remove_prefix(1);
  double value = 0.0;
  const char* end = text.data() + text.size();
  auto [ptr, ec] = std::from_chars(text.data(), end, value);
  if (ec != std::errc() || ptr != end || !std::isfinite(value)) return std::nullopt;
  return value;
}

std::string CsvEscape(std::string_view field) {
  if (field.find_first_of(",\"\r\n;") == std::string_view::npos) return std::string(field);
  std::string out = "\"";
  for (char c : field) {
    if (c == '"') out += '"';
    out += c;
  }
  out += '"';
  return out;
}

namespace {

void CheckDelimiterOption(const CsvOptions& options, const std::string& source) {
  if (options.delimiter != '\0' && options.delimiter != ',' && options.delimiter != ';' &&
      options.delimiter != '\t') {
    throw InputError({source, 0, 0, ""}, std::string("unsupported delimiter '") +
                                             options.delimiter + "' (expected ',', ';' or tab)");
  }
}

enum class Scan { kRecord, kEnd, kMore };

// The next record of `text` from `pos` (blank lines and comment lines skipped): kRecord with
// `row` filled and `pos`, `line` moved past it; kEnd at the end of the text; kMore when the
// record runs into the end of `text` and more may follow (`at_eof` false): nothing moved,
// the caller appends more text and scans again from the same place. `delimiter` '\0' is
// guessed from the header line (the first record).
Scan ScanRecord(std::string_view text, bool at_eof, std::size_t& pos, int& line_no, char& delimiter,
                const CsvOptions& options, const std::string& source, CsvRow& row) {
  std::size_t i = pos;
  int line = line_no;
  // Blank lines and comments at record start.
  for (;;) {
    if (i >= text.size()) {
      if (!at_eof) return Scan::kMore;
      pos = i;
      line_no = line;
      return Scan::kEnd;
    }
    const char c = text[i];
    if (c == '\n' || c == '\r') {
      if (c == '\r' && i + 1 >= text.size() && !at_eof) return Scan::kMore;
      if (c == '\r' && i + 1 < text.size() && text[i + 1] == '\n') ++i;
      ++i;
      ++line;
      continue;
    }
    if (options.skip_comment_lines && c == '#') {
      const std::size_t eol = text.find_first_of("\r\n", i);
      if (eol == std::string_view::npos && !at_eof) return Scan::kMore;
      i = eol == std::string_view::npos ? text.size() : eol;
      continue;
    }
    break;
  }
  if (delimiter == '\0') {  // the header line tells
    const std::size_t eol = text.find_first_of("\r\n", i);
    if (eol == std::string_view::npos && !at_eof) return Scan::kMore;
    delimiter = GuessDelimiter(text.substr(i, eol == std::string_view::npos ? eol : eol - i));
  }
  row.line = line;
  row.fields.clear();
  std::string field;
  bool quoted = false;
  bool field_was_quoted = false;
  for (;;) {
    if (i >= text.size()) {
      if (!at_eof) return Scan::kMore;
      if (quoted) {
        throw InputError({source, row.line, static_cast<int>(row.fields.size()) + 1, ""},
                         "unterminated quoted field (expected a closing '\"')");
      }
      break;
    }
    const char c = text[i];
    if (quoted) {
      // '"' and '\r' look one character ahead.
      if ((c == '"' || c == '\r') && i + 1 >= text.size() && !at_eof) return Scan::kMore;
      if (c == '"') {
        if (i + 1 < text.size() && text[i + 1] == '"') {
          field += '"';
          i += 2;
          continue;
        }
        quoted = false;
        ++i;
        continue;
      }
      if (c == '\n') ++line;
      if (c == '\r' && !(i + 1 < text.size() && text[i + 1] == '\n')) ++line;
      field += c;
      ++i;
      continue;
    }
    if (c == '"' && Trim(field, " \t").empty()) {
      quoted = true;
      field_was_quoted = true;
      field.clear();
      ++i;
      continue;
    }
    if (c == delimiter) {
      row.fields.push_back(field_was_quoted ? field : std::string(Trim(field, " \t")));
      field.clear();
      field_was_quoted = false;
      ++i;
      continue;
    }
    if (c == '\r' || c == '\n') break;  // end of record; the newline is consumed above
    field += c;
    ++i;
  }
  row.fields.push_back(field_was_quoted ? field : std::string(Trim(field, " \t")));
  pos = i;
  line_no = line;
  return Scan::kRecord;
}

void CheckHeader(const std::string& source, const std::vector<std::string>& header,
                 int header_line) {
  // Each name's first column: one look-up a column (a header of 200,000 columns took 556 s
  // when each name was compared with every earlier one).
  std::unordered_map<std::string_view, size_t> first_of;
  first_of.reserve(header.size());
  for (size_t c = 0; c < header.size(); ++c) {
    if (header[c].empty()) {
      throw InputError({source, header_line, static_cast<int>(c) + 1, ""},
                       "empty column name in the header");
    }
    // Two columns of one name: which one a reader takes would be a guess.
    if (const auto [it, fresh] = first_of.emplace(header[c], c); !fresh) {
      throw InputError({source, header_line, static_cast<int>(c) + 1, header[c]},
                       "duplicate column " + Quoted(header[c]) + " (also column " +
                           std::to_string(it->second + 1) + "): expected each column once");
    }
  }
}

// Both readers' bound on a record, with the blank and comment lines before it: the same files
// are refused by either, at the record's line.
void CheckRecordLength(std::size_t bytes, const std::string& source, int line) {
  if (bytes <= kMaxCsvRecordBytes) return;
  throw InputError({source, line, 0, ""},
                   "a record longer than 1 MiB (an unterminated quoted field, or not a CSV "
                   "file): armsig reads records of at most 1 MiB");
}

constexpr const char* kEmptyFile = "empty file (expected a header line and data rows)";

}  // namespace

CsvTable ParseCsv(std::string_view text, std::string source, CsvOptions options) {
  if (text.starts_with("\xEF\xBB\xBF")) text.remove_prefix(3);
  CheckDelimiterOption(options, source);
  std::vector<CsvRow> records;
  std::size_t i = 0;
  int line = 1;
  char delimiter = options.delimiter;
  for (CsvRow row;;) {
    const std::size_t start = i;
    if (ScanRecord(text, true, i, line, delimiter, options, source, row) != Scan::kRecord) break;
    CheckRecordLength(i - start, source, row.line);
    records.push_back(std::move(row));
  }
  if (records.empty()) throw InputError({source, 0, 0, ""}, kEmptyFile);
  std::vector<std::string> header = std::move(records.front().fields);
  const int header_line = records.front().line;
  records.erase(records.begin());
  CheckHeader(source, header, header_line);
  if (delimiter == '\0') delimiter = ',';
  for (const CsvRow& row : records) {
    if (row.fields.size() != header.size()) ThrowFieldCount(source, row, header.size(), delimiter);
  }
  options.delimiter = delimiter;
  return CsvTable(std::move(source), std::move(header), std::move(records), options, header_line);
}

CsvTable ReadCsvFile(const std::string& path, CsvOptions options) {
  CsvTable table = ParseCsv(ReadWholeFile(path, kCsvFileLimit), path, options);
  spdlog::debug("read {}: {} rows, {} columns", Printable(path), table.rows().size(),
                table.header().size());
  return table;
}

CsvReader::CsvReader(const std::string& path, CsvOptions options, ReadProgressFn progress)
    : file_(std::make_unique<InputFile>(path, kCsvStreamLimit)),
      requested_(options),
      delimiter_(options.delimiter),
      progress_(std::move(progress)) {
  CheckDelimiterOption(options, path);
  CsvRow header;
  if (!NextRecord(header, false)) throw InputError({path, 0, 0, ""}, kEmptyFile);
  CheckHeader(path, header.fields, header.line);
  if (delimiter_ == '\0') delimiter_ = ',';
  options.delimiter = delimiter_;
  SetHeader(path, std::move(header.fields), options, header.line);
}

CsvReader::~CsvReader() = default;

bool CsvReader::Fill() {
  if (eof_) return false;
  // Keep only the record being read, then append the next piece of the file.
  consumed_ += at_;
  buffer_.erase(0, at_);
  at_ = 0;
  if (buffer_.size() > kMaxCsvRecordBytes) {
    int line = line_;  // the record's: past the line ends before it
    for (std::size_t k = 0; k < buffer_.size() && (buffer_[k] == '\n' || buffer_[k] == '\r'); ++k) {
      if (buffer_[k] == '\n' || k + 1 >= buffer_.size() || buffer_[k + 1] != '\n') ++line;
    }
    CheckRecordLength(buffer_.size(), file_->path(), line);
  }
  const std::size_t kPiece = std::max<std::size_t>(requested_.read_piece_bytes, 1);
  const std::size_t before = buffer_.size();
  buffer_.resize(before + kPiece);
  const std::size_t n = file_->Read(buffer_.data() + before, kPiece);
  buffer_.resize(before + n);
  if (n == 0) eof_ = true;
  if (!bom_checked_ && (buffer_.size() >= 3 || eof_)) {  // a UTF-8 BOM before the header
    bom_checked_ = true;
    if (buffer_.starts_with("\xEF\xBB\xBF")) at_ = 3;
  }
  if (progress_) progress_({file_->path(), consumed_ + at_, file_->size(), rows_});
  return true;
}

bool CsvReader::NextRecord(CsvRow& row, bool header_done) {
  for (;;) {
    std::size_t i = at_;
    int line = line_;
    char delimiter = delimiter_;
    const Scan scan = ScanRecord(buffer_, eof_, i, line, delimiter, requested_, file_->path(), row);
    if (scan == Scan::kMore) {
      Fill();
      continue;
    }
    if (scan == Scan::kRecord) CheckRecordLength(i - at_, file_->path(), row.line);
    if (!header_done) delimiter_ = delimiter;
    at_ = i;
    line_ = line;
    return scan == Scan::kRecord;
  }
}

bool CsvReader::Next(CsvRow& row) {
  if (!NextRecord(row, true)) {
    if (progress_) progress_({file_->path(), file_->size(), file_->size(), rows_});
    return false;
  }
  if (row.fields.size() != header().size())
    ThrowFieldCount(source(), row, header().size(), delimiter());
  ++rows_;
  return true;
}

CsvColumns::CsvColumns(std::string source, std::vector<std::string> header, CsvOptions options,
                       int header_line) {
  SetHeader(std::move(source), std::move(header), options, header_line);
}

void CsvColumns::SetHeader(std::string source, std::vector<std::string> header, CsvOptions options,
                           int header_line) {
  source_ = std::move(source);
  header_ = std::move(header);
  options_ = options;
  header_line_ = header_line;
}

CsvTable::CsvTable(std::string source, std::vector<std::string> header, std::vector<CsvRow> rows,
                   CsvOptions options, int header_line)
    : CsvColumns(std::move(source), std::move(header), options, header_line),
      rows_(std::move(rows)) {}

SourceLocation CsvColumns::HeaderWhere(int column) const {
  return {source_, header_line_, column + 1, header_.at(column)};
}

std::optional<int> CsvColumns::FindColumn(std::string_view name) const {
  for (size_t c = 0; c < header_.size(); ++c) {
    if (header_[c] == name) return static_cast<int>(c);
  }
  return std::nullopt;
}

int CsvColumns::Column(std::string_view name) const {
  if (auto c = FindColumn(name)) return *c;
  throw InputError({source_, header_line_, 0, ""},
                   "missing column " + Quoted(std::string(name)) + " in the header");
}

std::optional<AngleColumn> CsvColumns::FindAngleColumn(std::string_view base) const {
  std::optional<AngleColumn> found;
  for (AngleUnit unit : {AngleUnit::kGon, AngleUnit::kDeg, AngleUnit::kRad}) {
    std::string name = std::string(base) + std::string(AngleUnitSuffix(unit));
    if (auto c = FindColumn(name)) {
      if (found) {
        // hz_gon and hz_deg: the same quantity twice, and no telling which one is meant.
        const int later = std::max(found->index, *c), earlier = std::min(found->index, *c);
        throw InputError(HeaderWhere(later), "column " + Quoted(header_[later]) +
                                                 " gives the same quantity as column " +
                                                 std::to_string(earlier + 1) + " " +
                                                 Quoted(header_[earlier]) +
                                                 " in another unit: expected one of them");
      }
      found = AngleColumn{*c, unit, name};
    }
  }
  return found;
}

namespace {

// "sigma_hz_arcsec" -> "sigma_hz": the quantity without its unit.
std::string_view QuantityOf(std::string_view name) {
  const size_t underscore = name.rfind('_');
  return underscore == std::string_view::npos ? name : name.substr(0, underscore);
}

}  // namespace

void CsvColumns::RefuseUnreadUnits(const std::vector<std::string>& known) const {
  for (size_t c = 0; c < header_.size(); ++c) {
    const std::string& column = header_[c];
    bool is_known = false;
    for (const std::string& k : known) {
      is_known |= k == column || (k.ends_with("_*") && AngleUnitFromSuffix(column) &&
                                  StripUnitSuffix(column) == k.substr(0, k.size() - 2));
    }
    if (is_known) continue;
    for (const std::string& k : known) {
      if (k.find('_') == std::string_view::npos) continue;  // a name, not a quantity with a unit
      const std::string_view quantity = QuantityOf(k);
      if (column != quantity && QuantityOf(column) != quantity) continue;
      const std::string expected = k.ends_with("_*")
                                       ? std::string(quantity) + "_gon, " + std::string(quantity) +
                                             "_deg or " + std::string(quantity) + "_rad"
                                       : std::string(k);
      throw InputError(
          HeaderWhere(static_cast<int>(c)),
          "column " + Quoted(column) +
              (column == quantity ? " has no unit" : " is in a unit armsig does not read") +
              ": expected " + expected +
              " (armsig would otherwise leave it unread and use a default)");
    }
  }
}

AngleColumn CsvColumns::AngleColumnOf(std::string_view base) const {
  if (auto c = FindAngleColumn(base)) return *c;
  const std::string b(base);
  throw InputError({source_, header_line_, 0, ""}, "missing column '" + b + "_deg', '" + b +
                                                       "_gon' or '" + b + "_rad' in the header");
}

SourceLocation CsvColumns::Where(const CsvRow& row, int column) const {
  return {source_, row.line, column + 1, header_.at(column)};
}

double CsvColumns::Number(const CsvRow& row, int column) const {
  const std::string& field = row.fields.at(column);
  if (auto v = ParseNumber(field, decimal_comma())) return *v;
  if (field.empty()) throw InputError(Where(row, column), "expected a number, the field is empty");
  if (!decimal_comma() && ParseNumber(field, true)) {
    throw InputError(Where(row, column), "expected a finite number, got " + Quoted(field) + " (" +
                                             kDecimalCommaHint + ")");
  }
  throw InputError(Where(row, column), "expected a finite number, got " + Quoted(field));
}

std::optional<double> CsvColumns::OptionalNumber(const CsvRow& row, int column) const {
  if (Trim(row.fields.at(column), " \t").empty()) return std::nullopt;
  return Number(row, column);
}

double CsvColumns::Number(const CsvRow& row, int column, plausible::Quantity quantity,
                          plausible::Unit unit) const {
  const double value = Number(row, column);
  if (auto why = plausible::Check(quantity, value, unit))
    throw InputError(Where(row, column), *why);
  return value * unit.to_internal;
}

std::optional<double> CsvColumns::OptionalNumber(const CsvRow& row, int column,
                                                 plausible::Quantity quantity,
                                                 plausible::Unit unit) const {
  if (Trim(row.fields.at(column), " \t").empty()) return std::nullopt;
  return Number(row, column, quantity, unit);
}

double CsvColumns::AngleRad(const CsvRow& row, const AngleColumn& column,
                            plausible::Quantity quantity) const {
  return Number(row, column.index, quantity, plausible::UnitOf(column.unit));
}

int CsvColumns::Integer(const CsvRow& row, int column) const {
  std::string_view field = Trim(row.fields.at(column), " \t");
  int value = 0;
  auto [ptr, ec] = std::from_chars(field.data(), field.data() + field.size(), value);
  if (field.empty() || ec != std::errc() || ptr != field.data() + field.size()) {
    throw InputError(Where(row, column), "expected an integer, got " + Quoted(field));
  }
  return value;
}

const std::string& CsvColumns::Text(const CsvRow& row, int column) const {
  return row.fields.at(column);
}

const std::string& CsvColumns::Name(const CsvRow& row, int column) const {
  const std::string& text = row.fields.at(column);
  if (auto why = plausible::CheckName(text)) throw InputError(Where(row, column), *why);
  return text;
}

}  // namespace armsig::io
