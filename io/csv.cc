#include "io/csv.h"

#include <charconv>
#include <cmath>
#include <fstream>
#include <sstream>

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

std::string_view Trim(std::string_view s) {
  while (!s.empty() && (s.front() == ' ' || s.front() == '\t')) s.remove_prefix(1);
  while (!s.empty() && (s.back() == ' ' || s.back() == '\t')) s.remove_suffix(1);
  return s;
}

}  // namespace

std::optional<double> ParseNumber(std::string_view text, bool decimal_comma) {
  text = Trim(text);
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

CsvTable ParseCsv(std::string_view text, std::string source, CsvOptions options) {
  if (text.starts_with("\xEF\xBB\xBF")) text.remove_prefix(3);

  // Split into records, honouring quotes (a quoted field may span lines).
  std::vector<CsvRow> records;
  int line = 1;
  size_t i = 0;
  char delimiter = options.delimiter;
  bool header_done = false;
  while (i < text.size()) {
    // Skip blank lines and comments at record start.
    if (text[i] == '\n' || text[i] == '\r') {
      if (text[i] == '\r' && i + 1 < text.size() && text[i + 1] == '\n') ++i;
      ++i;
      ++line;
      continue;
    }
    if (options.skip_comment_lines && text[i] == '#') {
      while (i < text.size() && text[i] != '\n' && text[i] != '\r') ++i;
      continue;
    }
    if (!header_done && delimiter == '\0') {
      size_t eol = text.find_first_of("\r\n", i);
      delimiter = GuessDelimiter(text.substr(i, eol == std::string_view::npos ? eol : eol - i));
    }
    CsvRow row;
    row.line = line;
    std::string field;
    bool quoted = false;
    bool field_was_quoted = false;
    for (;;) {
      if (i >= text.size()) {
        if (quoted) {
          throw InputError({source, row.line, static_cast<int>(row.fields.size()) + 1, ""},
                           "unterminated quoted field (expected a closing '\"')");
        }
        break;
      }
      const char c = text[i];
      if (quoted) {
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
      if (c == '"' && Trim(field).empty()) {
        quoted = true;
        field_was_quoted = true;
        field.clear();
        ++i;
        continue;
      }
      if (c == delimiter) {
        row.fields.push_back(field_was_quoted ? field : std::string(Trim(field)));
        field.clear();
        field_was_quoted = false;
        ++i;
        continue;
      }
      if (c == '\r' || c == '\n') break;  // end of record; the newline is consumed above
      field += c;
      ++i;
    }
    row.fields.push_back(field_was_quoted ? field : std::string(Trim(field)));
    records.push_back(std::move(row));
    header_done = true;
  }

  if (records.empty()) {
    throw InputError({source, 0, 0, ""}, "empty file (expected a header line and data rows)");
  }
  std::vector<std::string> header = std::move(records.front().fields);
  const int header_line = records.front().line;
  records.erase(records.begin());
  for (size_t c = 0; c < header.size(); ++c) {
    if (header[c].empty()) {
      throw InputError({source, header_line, static_cast<int>(c) + 1, ""},
                       "empty column name in the header");
    }
  }
  for (const CsvRow& row : records) {
    if (row.fields.size() != header.size()) {
      throw InputError({source, row.line, 0, ""}, "expected " + std::to_string(header.size()) +
                                                      " fields as in the header, found " +
                                                      std::to_string(row.fields.size()));
    }
  }
  options.delimiter = delimiter == '\0' ? ',' : delimiter;
  return CsvTable(std::move(source), std::move(header), std::move(records), options);
}

CsvTable ReadCsvFile(const std::string& path, CsvOptions options) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError({path, 0, 0, ""}, "cannot open file for reading");
  std::ostringstream buffer;
  buffer << in.rdbuf();
  return ParseCsv(buffer.str(), path, options);
}

CsvTable::CsvTable(std::string source, std::vector<std::string> header, std::vector<CsvRow> rows,
                   CsvOptions options)
    : source_(std::move(source)),
      header_(std::move(header)),
      rows_(std::move(rows)),
      options_(options) {}

std::optional<int> CsvTable::FindColumn(std::string_view name) const {
  for (size_t c = 0; c < header_.size(); ++c) {
    if (header_[c] == name) return static_cast<int>(c);
  }
  return std::nullopt;
}

int CsvTable::Column(std::string_view name) const {
  if (auto c = FindColumn(name)) return *c;
  throw InputError({source_, 1, 0, ""}, "missing column '" + std::string(name) + "' in the header");
}

std::optional<AngleColumn> CsvTable::FindAngleColumn(std::string_view base) const {
  for (AngleUnit unit : {AngleUnit::kGon, AngleUnit::kDeg, AngleUnit::kRad}) {
    std::string name = std::string(base) + std::string(AngleUnitSuffix(unit));
    if (auto c = FindColumn(name)) return AngleColumn{*c, unit, name};
  }
  return std::nullopt;
}

AngleColumn CsvTable::AngleColumnOf(std::string_view base) const {
  if (auto c = FindAngleColumn(base)) return *c;
  const std::string b(base);
  throw InputError({source_, 1, 0, ""}, "missing column '" + b + "_deg', '" + b + "_gon' or '" + b +
                                            "_rad' in the header");
}

SourceLocation CsvTable::Where(const CsvRow& row, int column) const {
  return {source_, row.line, column + 1, header_.at(column)};
}

double CsvTable::Number(const CsvRow& row, int column) const {
  const std::string& field = row.fields.at(column);
  if (auto v = ParseNumber(field, options_.decimal_comma)) return *v;
  throw InputError(Where(row, column), field.empty()
                                           ? "expected a number, the field is empty"
                                           : "expected a finite number, got '" + field + "'");
}

std::optional<double> CsvTable::OptionalNumber(const CsvRow& row, int column) const {
  if (Trim(row.fields.at(column)).empty()) return std::nullopt;
  return Number(row, column);
}

double CsvTable::AngleRad(const CsvRow& row, const AngleColumn& column) const {
  return ToRad(Number(row, column.index), column.unit);
}

int CsvTable::Integer(const CsvRow& row, int column) const {
  std::string_view field = Trim(row.fields.at(column));
  int value = 0;
  auto [ptr, ec] = std::from_chars(field.data(), field.data() + field.size(), value);
  if (field.empty() || ec != std::errc() || ptr != field.data() + field.size()) {
    throw InputError(Where(row, column), "expected an integer, got '" + std::string(field) + "'");
  }
  return value;
}

const std::string& CsvTable::Text(const CsvRow& row, int column) const {
  return row.fields.at(column);
}

}  // namespace armsig::io
