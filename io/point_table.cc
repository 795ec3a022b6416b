#include "io/point_table.h"

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <array>
#include <cctype>
#include <fstream>
#include <map>
#include <regex>
#include <sstream>

#include "core/error.h"
#include "core/plausibility.h"
#include "core/text.h"
#include "io/csv.h"
#include "io/point_table_header.h"

namespace armsig::io {

double MillimetresPer(LengthUnit unit) {
  switch (unit) {
    case LengthUnit::kMm:
      return 1.0;
    case LengthUnit::kM:
      return 1000.0;
    case LengthUnit::kInch:
      return 25.4;
  }
  return 1.0;
}

const char* ToString(LengthUnit unit) {
  switch (unit) {
    case LengthUnit::kMm:
      return "mm";
    case LengthUnit::kM:
      return "m";
    case LengthUnit::kInch:
      return "inch";
  }
  return "mm";
}

std::optional<LengthUnit> LengthUnitFromText(std::string_view text) {
  const std::string t = point_table::Lower(Trim(text, point_table::kBlank));
  if (t == "mm" || t == "millimeter" || t == "millimeters" || t == "millimetre" ||
      t == "millimetres")
    return LengthUnit::kMm;
  if (t == "m" || t == "meter" || t == "meters" || t == "metre" || t == "metres")
    return LengthUnit::kM;
  if (t == "in" || t == "inch" || t == "inches" || t == "\"") return LengthUnit::kInch;
  return std::nullopt;
}

namespace {

using point_table::kBlank;
using point_table::Layout;

// ---- Lines and fields ----

struct Line {
  int number = 0;
  std::string text;  // trimmed
};

std::vector<Line> SplitLines(std::string_view text) {
  if (text.starts_with("\xEF\xBB\xBF")) text.remove_prefix(3);
  std::vector<Line> lines;
  int number = 1;
  size_t start = 0;
  for (size_t i = 0; i <= text.size(); ++i) {
    if (i == text.size() || text[i] == '\n' || text[i] == '\r') {
      // A leading tab is an empty first field (a units line under a header whose first
      // column is the name), not indentation: keep it when the line has anything else.
      std::string_view raw = text.substr(start, i - start);
      while (!raw.empty() && raw.front() == ' ') raw.remove_prefix(1);
      lines.push_back({number, Trim(raw, kBlank).empty() ? std::string() : std::string(raw)});
      while (!lines.back().text.empty() &&
             std::isspace(static_cast<unsigned char>(lines.back().text.back()))) {
        lines.back().text.pop_back();
      }
      ++number;
      if (i < text.size() && text[i] == '\r' && i + 1 < text.size() && text[i + 1] == '\n') ++i;
      start = i + 1;
    }
  }
  return lines;
}

bool IsComment(const std::string& text) {
  return text.starts_with("//") || text.starts_with("#") || text.starts_with("!");
}

enum class Delimiter { kTab, kSemicolon, kComma, kWhitespace };
constexpr std::array<Delimiter, 4> kDelimiters = {Delimiter::kTab, Delimiter::kSemicolon,
                                                  Delimiter::kComma, Delimiter::kWhitespace};

const char* NameOf(Delimiter d) {
  switch (d) {
    case Delimiter::kTab:
      return "tab";
    case Delimiter::kSemicolon:
      return "semicolon";
    case Delimiter::kComma:
      return "comma";
    case Delimiter::kWhitespace:
      return "whitespace";
  }
  return "";
}

const std::regex& DateToken() {
  static const std::regex r(R"(\d{4}-\d{2}-\d{2})");
  return r;
}
const std::regex& TimeToken() {
  static const std::regex r(R"(\d{1,2}:\d{2}(:\d{2}(\.\d+)?)?([Zz]|[+-]\d{2}(:?\d{2})?)?)");
  return r;
}

// With white space as the delimiter, a date followed by a time is one field (a time stamp).
std::vector<std::string> MergeDateAndTime(const std::vector<std::string>& fields) {
  std::vector<std::string> merged;
  for (size_t k = 0; k < fields.size(); ++k) {
    if (k + 1 < fields.size() && std::regex_match(fields[k], DateToken()) &&
        std::regex_match(fields[k + 1], TimeToken())) {
      merged.push_back(fields[k] + " " + fields[k + 1]);
      ++k;
    } else {
      merged.push_back(fields[k]);
    }
  }
  return merged;
}

// Fields of a line: quoted fields ("…", and '…' between white space) keep their spaces;
// with white space as the delimiter a date followed by a time is one field.
std::vector<std::string> Split(std::string_view line, Delimiter d) {
  std::vector<std::string> fields;
  const char sep = d == Delimiter::kTab ? '\t' : d == Delimiter::kSemicolon ? ';' : ',';
  size_t i = 0;
  auto is_sep = [&](char c) {
    return d == Delimiter::kWhitespace ? (c == ' ' || c == '\t') : c == sep;
  };
  while (i <= line.size()) {
    if (d == Delimiter::kWhitespace) {
      while (i < line.size() && is_sep(line[i])) ++i;
      if (i >= line.size()) break;
    }
    std::string field;
    while (d != Delimiter::kWhitespace && i < line.size() && line[i] == ' ') ++i;
    const char quote = i < line.size() ? line[i] : '\0';
    if (quote == '"' || (quote == '\'' && d == Delimiter::kWhitespace)) {
      ++i;
      while (i < line.size()) {
        if (line[i] == quote) {
          if (i + 1 < line.size() && line[i + 1] == quote) {
            field += quote;
            i += 2;
            continue;
          }
          ++i;
          break;
        }
        field += line[i++];
      }
      while (i < line.size() && !is_sep(line[i])) field += line[i++];  // text after the quote
    } else {
      while (i < line.size() && !is_sep(line[i])) field += line[i++];
      field = std::string(Trim(field, kBlank));
    }
    fields.push_back(std::move(field));
    if (i >= line.size()) break;
    ++i;  // the delimiter
    if (d != Delimiter::kWhitespace && i == line.size()) {
      fields.emplace_back();  // a trailing delimiter: an empty last field
      break;
    }
  }
  return d == Delimiter::kWhitespace ? MergeDateAndTime(fields) : fields;
}

bool IsNumberField(std::string_view field, bool decimal_comma) {
  return ParseNumber(field, decimal_comma).has_value();
}

// A row that carries a point: at least four fields, three of them consecutive numbers.
bool LooksLikeData(const std::vector<std::string>& fields, bool decimal_comma) {
  if (fields.size() < 4) return false;
  int run = 0;
  for (const auto& f : fields) {
    run = IsNumberField(f, decimal_comma) ? run + 1 : 0;
    if (run >= 3) return true;
  }
  return false;
}

// ---- The steps of ParsePointTable ----

// The lines that can be a header, a units line or a point row: not blank, not comments.
std::vector<const Line*> ContentLines(const std::vector<Line>& lines) {
  std::vector<const Line*> content;
  for (const auto& l : lines) {
    if (!l.text.empty() && !IsComment(l.text)) content.push_back(&l);
  }
  return content;
}

struct Dialect {
  Delimiter delimiter = Delimiter::kComma;
  size_t fields_per_row = 0;
  // A decimal comma can be told from a delimiter only when the delimiter is not ','.
  bool comma_allowed() const { return delimiter != Delimiter::kComma; }
  std::vector<std::string> Fields(const Line& line) const { return Split(line.text, delimiter); }
  bool IsPointRow(const std::vector<std::string>& fields) const {
    return fields.size() == fields_per_row && LooksLikeData(fields, comma_allowed());
  }
};

// The delimiter that makes the most rows look like points with one field count: title and
// comment lines, whatever they hold, are outvoted by the rows that carry the points.
Dialect DetectDialect(const std::vector<const Line*>& content, const std::string& source) {
  Dialect dialect;
  int best = 0;
  for (const Delimiter d : kDelimiters) {
    const bool dc = d != Delimiter::kComma;
    std::map<size_t, int> counts;
    for (const Line* l : content) {
      const auto f = Split(l->text, d);
      if (LooksLikeData(f, dc)) ++counts[f.size()];
    }
    for (const auto& [n, count] : counts) {
      if (count > best) {
        best = count;
        dialect.delimiter = d;
        dialect.fields_per_row = n;
      }
    }
  }
  if (best == 0) {
    throw InputError({source, 0, 0, ""},
                     "no point rows (expected lines with a point name and three numbers x y z, "
                     "separated by tab, ';', ',' or spaces)");
  }
  return dialect;
}

// The index in `content` of the first point row: everything before it is preamble.
size_t FirstPointRow(const std::vector<const Line*>& content, const Dialect& dialect) {
  size_t first = 0;
  while (!dialect.IsPointRow(dialect.Fields(*content[first]))) ++first;
  return first;
}

struct Header {
  Layout layout;
  size_t index = 0;  // in `content`
  int line = 0;
  std::vector<std::string> names;  // its fields, one per column (white-space words merged)
};

// The header: the last line before the first point row that has a field per column and
// names x, y and z. Without one the columns are positional (PositionalLayout).
std::optional<Header> FindHeader(const std::vector<const Line*>& content, size_t first_data,
                                 const Dialect& dialect, const std::string& source) {
  for (size_t k = first_data; k-- > 0;) {
    auto fields = dialect.Fields(*content[k]);
    if (dialect.delimiter == Delimiter::kWhitespace)
      fields = point_table::MergeHeaderWords(fields, dialect.fields_per_row);
    if (fields.size() != dialect.fields_per_row) continue;
    if (auto layout = point_table::HeaderLayout(fields, source, content[k]->number))
      return Header{*layout, k, content[k]->number, fields};
  }
  return std::nullopt;
}

// A place that says the file's length unit.
struct UnitSource {
  LengthUnit unit;
  std::string where;
  int line = 0;
};

// Units declared in the title and comment lines before the first point row ("Units:
// Meter"); the header line itself is read as a header, not here.
void AddDeclaredUnits(const std::vector<Line>& lines, int first_data_line, int header_line,
                      std::vector<UnitSource>* sources) {
  for (const auto& l : lines) {
    if (l.number >= first_data_line) break;
    if (header_line != 0 && l.number == header_line) continue;
    if (auto u = point_table::DeclaredUnit(l.text)) {
      sources->push_back({*u, fmt::format("line {} ('{}')", l.number, l.text), l.number});
    }
  }
}

// One line between the header and the first point row, which must be a units line: the
// unit it gives x, y and z (one for all three), and the sigmas' unit it sets in `layout`.
std::optional<LengthUnit> ReadUnitsLine(const Line& line, const Dialect& dialect, int header_line,
                                        const std::string& source, Layout* layout) {
  const auto fields = dialect.Fields(line);
  const auto units = point_table::UnitsLine(fields);
  if (!units) {
    throw InputError({source, line.number, 0, ""},
                     fmt::format("expected a units line (such as '[mm] [mm] [mm]') or the first "
                                 "point row after the header on line {}, got '{}'",
                                 header_line, line.text));
  }
  std::optional<LengthUnit> u;
  if (units->size() == dialect.fields_per_row) {
    for (int axis = 0; axis < 3; ++axis) {
      if (layout->sigma[axis] >= 0 && (*units)[layout->sigma[axis]])
        layout->sigma_unit = (*units)[layout->sigma[axis]];
      const auto& here = (*units)[layout->xyz[axis]];
      if (here && u && *here != *u) {
        throw InputError({source, line.number, layout->xyz[axis] + 1, ""},
                         "the units line gives x, y and z different units");
      }
      if (here) u = here;
    }
  } else {
    for (const auto& here : *units) {
      if (here && u && *here != *u) {
        throw InputError({source, line.number, 0, ""},
                         "the units line does not line up with the header's columns and "
                         "names more than one unit");
      }
      if (here) u = here;
    }
  }
  return u;
}

// The one unit all sources agree on; refused when none says one (a unit is never guessed)
// or two disagree.
UnitSource AgreedUnit(const std::vector<UnitSource>& sources, const std::string& source) {
  if (sources.empty()) {
    throw InputError({source, 0, 0, ""},
                     "no length unit: the file names none (a header such as 'X [mm]', a units "
                     "line, or 'Units: mm' in a comment); give --points-unit mm, m or inch");
  }
  for (const auto& s : sources) {
    if (s.unit != sources.front().unit) {
      throw InputError(
          {source, s.line, 0, ""},
          fmt::format("{} says {} but {} says {}: expected one length unit", sources.front().where,
                      ToString(sources.front().unit), s.where, ToString(s.unit)));
    }
  }
  return sources.front();
}

// The file's length unit from every place that may say it, in this order: title and
// comment lines, the header's column names, units lines under the header, the option. A
// units line also gives the sigmas' unit (set in the header's layout).
UnitSource FindLengthUnit(const std::vector<Line>& lines, const std::vector<const Line*>& content,
                          size_t first_data, const Dialect& dialect, Header* header,
                          const PointTableOptions& options, const std::string& source) {
  std::vector<UnitSource> sources;
  const int header_line = header ? header->line : 0;
  AddDeclaredUnits(lines, content[first_data]->number, header_line, &sources);
  if (header && header->layout.coordinate_unit) {
    sources.push_back({*header->layout.coordinate_unit,
                       fmt::format("the header on line {}", header_line), header_line});
  }
  for (size_t k = header ? header->index + 1 : first_data; k < first_data; ++k) {
    const Line& l = *content[k];
    if (auto u = ReadUnitsLine(l, dialect, header_line, source, &header->layout))
      sources.push_back({*u, fmt::format("the units line {}", l.number), l.number});
  }
  if (options.unit) sources.push_back({*options.unit, "--points-unit", 0});
  return AgreedUnit(sources, source);
}

// Without a header: leading names, then x y z, then text (codes, descriptions) ignored. Any
// other run of numbers (sigmas, normals, tolerances) needs a header to be told apart.
Layout PositionalLayout(const Line& first_row, const Dialect& dialect, const std::string& source) {
  const auto fields = dialect.Fields(first_row);
  const int count = static_cast<int>(fields.size());
  int names = 0;
  while (names < count && !IsNumberField(fields[names], dialect.comma_allowed())) ++names;
  int numbers = 0;
  while (names + numbers < count && IsNumberField(fields[names + numbers], dialect.comma_allowed()))
    ++numbers;
  Layout layout;
  int first_number = -1;
  if (names == 0 && numbers == 4) {
    layout.name = 0;  // a numeric point name ("156 20329.982 10794.929 341.850")
    first_number = 1;
  } else if (names >= 1 && names <= 3 && numbers == 3) {
    layout.name = names - 1;  // SpatialAnalyzer's Collection Group Target: the target
    first_number = names;
  }
  if (first_number < 0) {
    throw InputError(
        {source, first_row.number, 0, ""},
        fmt::format("cannot tell the columns apart without a header: this row has {} name "
                    "field(s), then {} numbers (expected a point name, then x y z); add a "
                    "header line such as 'name x y z sx sy sz'",
                    names, numbers));
  }
  for (int axis = 0; axis < 3; ++axis) layout.xyz[axis] = first_number + axis;
  return layout;
}

// Decimal commas: a coordinate with a comma in any row of the table's width (never with
// ',' as the delimiter).
bool HasDecimalComma(const std::vector<const Line*>& content, size_t first_data,
                     const Dialect& dialect, const Layout& layout) {
  if (!dialect.comma_allowed()) return false;
  bool decimal_comma = false;
  for (size_t k = first_data; k < content.size(); ++k) {
    const auto f = dialect.Fields(*content[k]);
    if (f.size() != dialect.fields_per_row) continue;
    for (int axis = 0; axis < 3; ++axis)
      decimal_comma |= f[layout.xyz[axis]].find(',') != std::string::npos;
  }
  return decimal_comma;
}

// Reads point rows under a known layout: each field converted to mm (sigmas in their own
// unit) and checked for plausibility; a refusal names file:line:column and the header's
// name of the column.
class PointRowReader {
 public:
  PointRowReader(const PointTable& table, const Layout& layout, std::vector<std::string> names,
                 bool comma_allowed)
      : source_(table.source),
        layout_(layout),
        names_(std::move(names)),
        decimal_comma_(table.decimal_comma),
        comma_allowed_(comma_allowed),
        coordinate_unit_{ToString(table.unit), MillimetresPer(table.unit)},
        sigma_unit_{
            layout.sigma_unit ? ToString(*layout.sigma_unit) : ToString(table.unit),
            layout.sigma_unit ? MillimetresPer(*layout.sigma_unit) : MillimetresPer(table.unit)} {}

  TablePoint Read(const Line& l, const std::vector<std::string>& f) const {
    TablePoint p;
    p.line = l.number;
    if (layout_.name >= 0) {
      p.name = f[layout_.name];
      if (auto why = plausible::CheckName(p.name)) throw InputError(Where(l, layout_.name), *why);
    } else {
      p.name = fmt::format("line{}", l.number);
    }
    for (int axis = 0; axis < 3; ++axis) {
      p.position_mm(axis) =
          Number(l, f, layout_.xyz[axis], plausible::Quantity::kCoordinate, coordinate_unit_);
    }
    if (layout_.sigma[0] >= 0) {
      Eigen::Vector3d s;
      for (int axis = 0; axis < 3; ++axis)
        s(axis) = Number(l, f, layout_.sigma[axis], plausible::Quantity::kSigmaLength, sigma_unit_);
      p.sigma_mm = s;
    }
    if (layout_.time >= 0) {
      p.time = ParseTimeStamp(f[layout_.time]);
      if (!p.time) {
        throw InputError(Where(l, layout_.time),
                         fmt::format("expected a time stamp (ISO 8601 such as "
                                     "2024-03-05T10:15:30.25, or seconds), got '{}'",
                                     f[layout_.time]));
      }
    }
    return p;
  }

  SourceLocation Where(const Line& l, int column) const {
    return SourceLocation{source_, l.number, column + 1, names_[column]};
  }
  // Where a row's name is (the first column when the names are line numbers).
  SourceLocation NameWhere(const Line& l) const { return Where(l, std::max(layout_.name, 0)); }

 private:
  double Number(const Line& l, const std::vector<std::string>& f, int column,
                plausible::Quantity quantity, const plausible::Unit& unit) const {
    const std::string& field = f[column];
    const auto v = ParseNumber(field, decimal_comma_);
    if (!v) {
      throw InputError(
          Where(l, column),
          fmt::format("expected a finite number, got '{}'{}", field,
                      !comma_allowed_ && ParseNumber(field, true)
                          ? " (a decimal comma needs ';', tab or spaces as the delimiter)"
                          : ""));
    }
    if (auto why = plausible::Check(quantity, *v, unit)) throw InputError(Where(l, column), *why);
    return *v * unit.to_internal;
  }

  std::string source_;
  Layout layout_;
  std::vector<std::string> names_;
  bool decimal_comma_, comma_allowed_;
  plausible::Unit coordinate_unit_, sigma_unit_;
};

// Every row from the first point row on is a point of the table's width, with a name no
// other row has.
void ReadPointRows(const std::vector<const Line*>& content, size_t first_data,
                   const Dialect& dialect, const PointRowReader& reader, PointTable* table) {
  std::map<std::string, int> seen;
  for (size_t k = first_data; k < content.size(); ++k) {
    const Line& l = *content[k];
    const auto f = dialect.Fields(l);
    if (f.size() != dialect.fields_per_row) {
      throw InputError({table->source, l.number, 0, ""},
                       fmt::format("expected {} fields ({}-separated) as in the first point row, "
                                   "line {}; found {}",
                                   dialect.fields_per_row, table->delimiter,
                                   content[first_data]->number, f.size()));
    }
    TablePoint p = reader.Read(l, f);
    if (const auto [it, fresh] = seen.emplace(p.name, l.number); !fresh) {
      throw InputError(
          reader.NameWhere(l),
          fmt::format("duplicate point name '{}' (also on line {})", p.name, it->second));
    }
    table->points.push_back(std::move(p));
  }
}

}  // namespace

PointTable ParsePointTable(std::string_view text, const std::string& source,
                           const PointTableOptions& options) {
  const std::vector<Line> lines = SplitLines(text);
  const std::vector<const Line*> content = ContentLines(lines);
  const Dialect dialect = DetectDialect(content, source);
  const size_t first_data = FirstPointRow(content, dialect);
  std::optional<Header> header = FindHeader(content, first_data, dialect, source);
  const UnitSource unit = FindLengthUnit(lines, content, first_data, dialect,
                                         header ? &*header : nullptr, options, source);
  const Layout layout =
      header ? header->layout : PositionalLayout(*content[first_data], dialect, source);

  PointTable table;
  table.source = source;
  table.delimiter = NameOf(dialect.delimiter);
  table.header_line = header ? header->line : 0;
  table.unit = unit.unit;
  table.unit_from = unit.where;
  table.decimal_comma = HasDecimalComma(content, first_data, dialect, layout);
  table.has_sigmas = layout.sigma[0] >= 0;
  table.has_times = layout.time >= 0;
  const PointRowReader reader(
      table, layout, header ? header->names : std::vector<std::string>(dialect.fields_per_row),
      dialect.comma_allowed());
  ReadPointRows(content, first_data, dialect, reader, &table);
  spdlog::debug(
      "read {}: {} points, {} delimiter{}, {}, unit {} (from {})", source, table.points.size(),
      table.delimiter, table.decimal_comma ? ", decimal comma" : "",
      table.header_line ? fmt::format("header on line {}", table.header_line) : "no header",
      ToString(table.unit), table.unit_from);
  return table;
}

PointTable ReadPointTable(const std::string& path, const PointTableOptions& options) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError({path, 0, 0, ""}, "cannot open file for reading");
  std::ostringstream buffer;
  buffer << in.rdbuf();
  return ParsePointTable(buffer.str(), path, options);
}

}  // namespace armsig::io
