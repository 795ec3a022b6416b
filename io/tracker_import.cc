#include "io/tracker_import.h"

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <array>
#include <cctype>
#include <charconv>
#include <cmath>
#include <fstream>
#include <limits>
#include <map>
#include <regex>
#include <set>
#include <sstream>

#include "core/error.h"
#include "core/plausibility.h"
#include "io/csv.h"
#include "core/text.h"

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

namespace {

// What std::isspace calls white space: a tracker export's fields and lines are trimmed of it.
constexpr std::string_view kBlank = " \t\n\v\f\r";

std::string Lower(std::string_view s) {
  std::string out(s);
  for (char& c : out) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return out;
}

}  // namespace

std::optional<LengthUnit> LengthUnitFromText(std::string_view text) {
  const std::string t = Lower(Trim(text, kBlank));
  if (t == "mm" || t == "millimeter" || t == "millimeters" || t == "millimetre" ||
      t == "millimetres")
    return LengthUnit::kMm;
  if (t == "m" || t == "meter" || t == "meters" || t == "metre" || t == "metres")
    return LengthUnit::kM;
  if (t == "in" || t == "inch" || t == "inches" || t == "\"") return LengthUnit::kInch;
  return std::nullopt;
}

namespace {

// Days since 1970-01-01 of a civil date (H. Hinnant, "chrono-compatible low-level date
// algorithms", days_from_civil).
int64_t DaysFromCivil(int64_t y, unsigned m, unsigned d) {
  y -= m <= 2;
  const int64_t era = (y >= 0 ? y : y - 399) / 400;
  const unsigned yoe = static_cast<unsigned>(y - era * 400);
  const unsigned doy = (153 * (m + (m > 2 ? -3 : 9)) + 2) / 5 + d - 1;
  const unsigned doe = yoe * 365 + yoe / 4 - yoe / 100 + doy;
  return era * 146097 + static_cast<int64_t>(doe) - 719468;
}

bool ParseDigits(std::string_view s, int& value) {
  if (s.empty()) return false;
  const auto [end, ec] = std::from_chars(s.data(), s.data() + s.size(), value);
  return ec == std::errc() && end == s.data() + s.size();
}

}  // namespace

std::optional<TimeStamp> ParseTimeStamp(std::string_view text) {
  text = Trim(text, kBlank);
  if (text.empty()) return std::nullopt;
  if (auto v = ParseNumber(text, false)) return TimeStamp{*v, false};
  if (auto v = ParseNumber(text, true)) return TimeStamp{*v, false};
  // YYYY-MM-DD[T ]hh:mm[:ss[.fff]][Z|±hh[:mm]]
  if (text.size() < 16 || text[4] != '-' || text[7] != '-' || (text[10] != 'T' && text[10] != ' '))
    return std::nullopt;
  int year = 0, month = 0, day = 0, hour = 0, minute = 0;
  if (!ParseDigits(text.substr(0, 4), year) || !ParseDigits(text.substr(5, 2), month) ||
      !ParseDigits(text.substr(8, 2), day) || !ParseDigits(text.substr(11, 2), hour) ||
      text[13] != ':' || !ParseDigits(text.substr(14, 2), minute))
    return std::nullopt;
  std::string_view rest = text.substr(16);
  double second = 0.0;
  if (!rest.empty() && rest.front() == ':') {
    rest.remove_prefix(1);
    size_t n = 0;
    while (n < rest.size() && (std::isdigit(static_cast<unsigned char>(rest[n])) || rest[n] == '.'))
      ++n;
    const auto s = ParseNumber(rest.substr(0, n), false);
    if (!s || n < 2) return std::nullopt;
    second = *s;
    rest.remove_prefix(n);
  }
  double offset_s = 0.0;
  if (rest == "Z" || rest == "z") {
    rest = {};
  } else if (!rest.empty() && (rest.front() == '+' || rest.front() == '-')) {
    const int sign = rest.front() == '-' ? -1 : 1;
    rest.remove_prefix(1);
    int oh = 0, om = 0;
    if (rest.size() == 5 && rest[2] == ':' && ParseDigits(rest.substr(0, 2), oh) &&
        ParseDigits(rest.substr(3, 2), om)) {
    } else if (rest.size() == 4 && ParseDigits(rest.substr(0, 2), oh) &&
               ParseDigits(rest.substr(2, 2), om)) {
    } else if (rest.size() == 2 && ParseDigits(rest, oh)) {
    } else {
      return std::nullopt;
    }
    if (oh > 23 || om > 59) return std::nullopt;
    offset_s = sign * (oh * 3600.0 + om * 60.0);
    rest = {};
  }
  if (!rest.empty()) return std::nullopt;
  if (month < 1 || month > 12 || day < 1 || day > 31 || hour > 23 || minute > 59 ||
      !(second >= 0.0 && second < 61.0))
    return std::nullopt;
  const double seconds =
      static_cast<double>(DaysFromCivil(year, static_cast<unsigned>(month),
                                        static_cast<unsigned>(day))) *
          86400.0 +
      hour * 3600.0 + minute * 60.0 + second - offset_s;
  return TimeStamp{seconds, true};
}

namespace {

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
  if (d == Delimiter::kWhitespace) {
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
    fields = std::move(merged);
  }
  return fields;
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

// ---- Column names ----

enum class Role { kOther, kName, kX, kY, kZ, kSx, kSy, kSz, kTime };

struct ColumnName {
  Role role = Role::kOther;
  std::optional<LengthUnit> unit;
  bool unit_is_seconds = false;
};

// "X [mm]" → x, mm; "x_m" → x, m; "Sigma X (mm)" → sigmax, mm; "σX" → sigmax; "Point Name" →
// pointname; "Date/Time" → datetime.
ColumnName Classify(std::string_view raw) {
  std::string text = Lower(Trim(raw, kBlank));
  for (size_t at = text.find("\xCF\x83"); at != std::string::npos; at = text.find("\xCF\x83"))
    text.replace(at, 2, "sigma");
  ColumnName out;
  // A bracketed annotation: a unit, or part of the name ("u(x)").
  std::string name;
  for (size_t i = 0; i < text.size(); ++i) {
    const char open = text[i];
    if (open == '[' || open == '(') {
      const char close = open == '[' ? ']' : ')';
      const size_t end = text.find(close, i);
      if (end != std::string::npos) {
        const std::string inside(Trim(std::string_view(text).substr(i + 1, end - i - 1), kBlank));
        if (auto u = LengthUnitFromText(inside)) {
          out.unit = u;
        } else if (inside == "s" || inside == "sec" || inside == "seconds") {
          out.unit_is_seconds = true;
        } else {
          name += inside;
        }
        i = end;
        continue;
      }
    }
    name += open;
  }
  // A unit suffix after '_' or ' ': "x_mm", "x mm", "time_s".
  for (const char sep : {'_', ' '}) {
    const size_t at = name.rfind(sep);
    if (at == std::string::npos || at == 0) continue;
    const std::string suffix(Trim(std::string_view(name).substr(at + 1), kBlank));
    if (auto u = LengthUnitFromText(suffix); u && !out.unit) {
      out.unit = u;
      name.resize(at);
    } else if (suffix == "s" || suffix == "sec") {
      out.unit_is_seconds = true;
      name.resize(at);
    }
  }
  std::string key;
  for (char c : name) {
    if (std::isalnum(static_cast<unsigned char>(c))) key += c;
  }
  static const std::set<std::string> names = {
      "name",   "point",   "pointname", "pointid", "ptid",   "pt",         "id",
      "target", "targetname", "label",  "pose",    "poseid", "nr",         "no",
      "number", "pointnumber", "ptno",  "pointno", "ptname"};
  static const std::set<std::string> times = {"time", "timestamp", "datetime", "t", "timesec",
                                              "times"};
  if (names.count(key)) {
    out.role = Role::kName;
  } else if (times.count(key)) {
    out.role = Role::kTime;
  } else if (key == "x" || key == "east" || key == "easting") {
    out.role = Role::kX;
  } else if (key == "y" || key == "north" || key == "northing") {
    out.role = Role::kY;
  } else if (key == "z" || key == "height" || key == "elevation" || key == "elev" || key == "h") {
    out.role = Role::kZ;
  } else {
    static const std::array<std::string, 8> prefixes = {"sigma", "sd",  "std", "stddev",
                                                        "u",     "unc", "uncertainty", "s"};
    static const std::array<std::string, 6> suffixes = {"sigma", "sd", "std", "stddev",
                                                        "unc",   "uncertainty"};
    for (int axis = 0; axis < 3 && out.role == Role::kOther; ++axis) {
      const std::string a(1, static_cast<char>('x' + axis));
      bool sigma = false;
      for (const auto& p : prefixes) sigma |= key == p + a;
      for (const auto& s : suffixes) sigma |= key == a + s;
      if (sigma) out.role = axis == 0 ? Role::kSx : axis == 1 ? Role::kSy : Role::kSz;
    }
  }
  return out;
}

// Header words white space split apart: a unit annotation ("X", "[mm]") and two-word names
// ("Point", "Name"; "Time", "Stamp") become one field while the count exceeds `wanted`.
std::vector<std::string> MergeHeaderWords(std::vector<std::string> fields, size_t wanted) {
  bool merged = true;
  while (fields.size() > wanted && merged) {
    merged = false;
    for (size_t k = 1; k < fields.size() && fields.size() > wanted; ++k) {
      const std::string& w = fields[k];
      const bool annotation =
          (w.starts_with("[") || w.starts_with("(")) && LengthUnitFromText(Trim(
                                                            std::string_view(w).substr(
                                                                1, w.size() >= 2 ? w.size() - 2
                                                                                 : 0), kBlank));
      const std::string joined = fields[k - 1] + " " + w;
      if (annotation || Classify(joined).role != Role::kOther) {
        fields[k - 1] = joined;
        fields.erase(fields.begin() + static_cast<std::ptrdiff_t>(k));
        merged = true;
        break;
      }
    }
  }
  return fields;
}

struct Layout {
  int name = -1, time = -1;
  int xyz[3] = {-1, -1, -1};
  int sigma[3] = {-1, -1, -1};
  std::optional<LengthUnit> coordinate_unit, sigma_unit;
  bool time_in_seconds = false;
};

// The roles of a header's fields; nullopt when x, y and z are not all named.
std::optional<Layout> HeaderLayout(const std::vector<std::string>& fields, const std::string& source,
                                   int line) {
  Layout layout;
  std::optional<LengthUnit> xyz_unit;
  int xyz_unit_column = -1;
  for (int c = 0; c < static_cast<int>(fields.size()); ++c) {
    const ColumnName n = Classify(fields[c]);
    auto take = [&](int& slot) {
      if (slot < 0) slot = c;
    };
    switch (n.role) {
      case Role::kName:
        take(layout.name);
        break;
      case Role::kTime:
        take(layout.time);
        layout.time_in_seconds |= n.unit_is_seconds;
        break;
      case Role::kX:
      case Role::kY:
      case Role::kZ: {
        const int axis = n.role == Role::kX ? 0 : n.role == Role::kY ? 1 : 2;
        take(layout.xyz[axis]);
        if (n.unit) {
          if (xyz_unit && *xyz_unit != *n.unit) {
            throw InputError({source, line, c + 1, fields[c]},
                             fmt::format("the header gives column {} in {} but column {} in {}; "
                                         "expected one length unit for x, y and z",
                                         fields[xyz_unit_column], ToString(*xyz_unit), fields[c],
                                         ToString(*n.unit)));
          }
          xyz_unit = n.unit;
          xyz_unit_column = c;
        }
        break;
      }
      case Role::kSx:
      case Role::kSy:
      case Role::kSz: {
        const int axis = n.role == Role::kSx ? 0 : n.role == Role::kSy ? 1 : 2;
        take(layout.sigma[axis]);
        if (n.unit) layout.sigma_unit = n.unit;
        break;
      }
      case Role::kOther:
        break;
    }
  }
  if (layout.xyz[0] < 0 || layout.xyz[1] < 0 || layout.xyz[2] < 0) return std::nullopt;
  layout.coordinate_unit = xyz_unit;
  const int sigmas = (layout.sigma[0] >= 0) + (layout.sigma[1] >= 0) + (layout.sigma[2] >= 0);
  if (sigmas != 0 && sigmas != 3) {
    throw InputError({source, line, 0, ""},
                     "the header names sigmas for some of x, y, z but not all three");
  }
  return layout;
}

// "Units: Millimeters", "// Length unit = m", "UNITS mm" in a title or comment line.
std::optional<LengthUnit> DeclaredUnit(const std::string& text) {
  static const std::regex r(R"(\bunits?\b\s*[:=;,]?\s*([A-Za-z"]+))", std::regex::icase);
  std::smatch m;
  if (std::regex_search(text, m, r)) return LengthUnitFromText(m[1].str());
  return std::nullopt;
}

// A units line: every field a length unit (bracketed or not), "s", "-" or empty.
std::optional<std::vector<std::optional<LengthUnit>>> UnitsLine(
    const std::vector<std::string>& fields) {
  std::vector<std::optional<LengthUnit>> units;
  bool any = false;
  for (const auto& raw : fields) {
    std::string f(Trim(raw, kBlank));
    if (f.size() >= 2 && (f.front() == '[' || f.front() == '(')) f = f.substr(1, f.size() - 2);
    f = std::string(Trim(f, kBlank));
    if (auto u = LengthUnitFromText(f)) {
      units.push_back(u);
      any = true;
    } else if (f.empty() || f == "-" || f == "s" || f == "sec") {
      units.emplace_back();
    } else {
      return std::nullopt;
    }
  }
  if (!any) return std::nullopt;
  return units;
}

}  // namespace

PointTable ParsePointTable(std::string_view text, const std::string& source,
                           const PointTableOptions& options) {
  const std::vector<Line> lines = SplitLines(text);
  std::vector<const Line*> content;  // not blank, not comments
  for (const auto& l : lines) {
    if (!l.text.empty() && !IsComment(l.text)) content.push_back(&l);
  }

  // The delimiter that makes the most rows look like points with one field count.
  Delimiter delimiter = Delimiter::kComma;
  size_t fields_per_row = 0;
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
        delimiter = d;
        fields_per_row = n;
      }
    }
  }
  if (best == 0) {
    throw InputError({source, 0, 0, ""},
                     "no point rows (expected lines with a point name and three numbers x y z, "
                     "separated by tab, ';', ',' or spaces)");
  }
  const bool comma_allowed = delimiter != Delimiter::kComma;
  auto is_data = [&](const std::vector<std::string>& f) {
    return f.size() == fields_per_row && LooksLikeData(f, comma_allowed);
  };
  size_t first_data = 0;
  while (!is_data(Split(content[first_data]->text, delimiter))) ++first_data;

  PointTable table;
  table.source = source;
  table.delimiter = NameOf(delimiter);

  // The header: the last line before the first data row that names x, y and z.
  std::optional<Layout> layout;
  size_t header_index = first_data;
  for (size_t k = first_data; k-- > 0;) {
    auto fields = Split(content[k]->text, delimiter);
    if (delimiter == Delimiter::kWhitespace) fields = MergeHeaderWords(fields, fields_per_row);
    if (fields.size() != fields_per_row) continue;
    if (auto l = HeaderLayout(fields, source, content[k]->number)) {
      layout = l;
      header_index = k;
      table.header_line = content[k]->number;
      break;
    }
  }

  // Units: declared in a title or comment line, in the header, on a units line.
  struct UnitSource {
    LengthUnit unit;
    std::string where;
    int line = 0;
  };
  std::vector<UnitSource> unit_sources;
  const int last_preamble_line = content[first_data]->number;
  for (const auto& l : lines) {
    if (l.number >= last_preamble_line) break;
    if (table.header_line != 0 && l.number == table.header_line) continue;
    if (auto u = DeclaredUnit(l.text)) {
      unit_sources.push_back({*u, fmt::format("line {} ('{}')", l.number, l.text), l.number});
    }
  }
  if (layout && layout->coordinate_unit) {
    unit_sources.push_back({*layout->coordinate_unit,
                            fmt::format("the header on line {}", table.header_line),
                            table.header_line});
  }
  // Between the header and the data: a units line only.
  for (size_t k = header_index + 1; layout && k < first_data; ++k) {
    const auto fields = Split(content[k]->text, delimiter);
    const auto units = UnitsLine(fields);
    if (!units) {
      throw InputError({source, content[k]->number, 0, ""},
                       fmt::format("expected a units line (such as '[mm] [mm] [mm]') or the first "
                                   "point row after the header on line {}, got '{}'",
                                   table.header_line, content[k]->text));
    }
    std::optional<LengthUnit> u;
    if (units->size() == fields_per_row) {
      for (int axis = 0; axis < 3; ++axis) {
        if (layout->sigma[axis] >= 0 && (*units)[layout->sigma[axis]])
          layout->sigma_unit = (*units)[layout->sigma[axis]];
        const auto& here = (*units)[layout->xyz[axis]];
        if (here && u && *here != *u) {
          throw InputError({source, content[k]->number, layout->xyz[axis] + 1, ""},
                           "the units line gives x, y and z different units");
        }
        if (here) u = here;
      }
    } else {
      for (const auto& here : *units) {
        if (here && u && *here != *u) {
          throw InputError({source, content[k]->number, 0, ""},
                           "the units line does not line up with the header's columns and "
                           "names more than one unit");
        }
        if (here) u = here;
      }
    }
    if (u) {
      unit_sources.push_back(
          {*u, fmt::format("the units line {}", content[k]->number), content[k]->number});
    }
  }
  if (options.unit) unit_sources.push_back({*options.unit, "--points-unit", 0});
  if (unit_sources.empty()) {
    throw InputError({source, 0, 0, ""},
                     "no length unit: the file names none (a header such as 'X [mm]', a units "
                     "line, or 'Units: mm' in a comment); give --points-unit mm, m or inch");
  }
  for (const auto& s : unit_sources) {
    if (s.unit != unit_sources.front().unit) {
      throw InputError({source, s.line, 0, ""},
                       fmt::format("{} says {} but {} says {}: expected one length unit",
                                   unit_sources.front().where, ToString(unit_sources.front().unit),
                                   s.where, ToString(s.unit)));
    }
  }
  table.unit = unit_sources.front().unit;
  table.unit_from = unit_sources.front().where;

  // Decimal commas: a number column with a comma (never with ',' as the delimiter).
  const auto first_fields = Split(content[first_data]->text, delimiter);
  if (!layout) {
    // Positional: leading names, then x y z, then text (codes, descriptions) ignored. Any
    // other run of numbers (sigmas, normals, tolerances) needs a header to be told apart.
    Layout l;
    int names = 0;
    while (names < static_cast<int>(first_fields.size()) &&
           !IsNumberField(first_fields[names], comma_allowed))
      ++names;
    int numbers = 0;
    while (names + numbers < static_cast<int>(first_fields.size()) &&
           IsNumberField(first_fields[names + numbers], comma_allowed))
      ++numbers;
    int first_number = -1;
    if (names == 0 && numbers == 4) {
      l.name = 0;  // a numeric point name ("156 20329.982 10794.929 341.850")
      first_number = 1;
    } else if (names >= 1 && names <= 3 && numbers == 3) {
      l.name = names - 1;  // SpatialAnalyzer's Collection Group Target: the target
      first_number = names;
    }
    if (first_number < 0) {
      throw InputError(
          {source, content[first_data]->number, 0, ""},
          fmt::format("cannot tell the columns apart without a header: this row has {} name "
                      "field(s), then {} numbers (expected a point name, then x y z); add a "
                      "header line such as 'name x y z sx sy sz'",
                      names, numbers));
    }
    for (int axis = 0; axis < 3; ++axis) l.xyz[axis] = first_number + axis;
    layout = l;
  }
  bool decimal_comma = false;
  if (comma_allowed) {
    for (size_t k = first_data; k < content.size(); ++k) {
      const auto f = Split(content[k]->text, delimiter);
      if (f.size() != fields_per_row) continue;
      for (int axis = 0; axis < 3; ++axis)
        decimal_comma |= f[layout->xyz[axis]].find(',') != std::string::npos;
    }
  }
  table.decimal_comma = decimal_comma;
  table.has_sigmas = layout->sigma[0] >= 0;
  table.has_times = layout->time >= 0;

  const double mm_per_unit = MillimetresPer(table.unit);
  const double sigma_mm_per_unit =
      layout->sigma_unit ? MillimetresPer(*layout->sigma_unit) : mm_per_unit;
  const plausible::Unit coordinate_unit{ToString(table.unit), mm_per_unit};
  const plausible::Unit sigma_unit{
      layout->sigma_unit ? ToString(*layout->sigma_unit) : ToString(table.unit), sigma_mm_per_unit};
  std::vector<std::string> header_names(fields_per_row);
  if (table.header_line != 0) {
    auto fields = Split(content[header_index]->text, delimiter);
    if (delimiter == Delimiter::kWhitespace) fields = MergeHeaderWords(fields, fields_per_row);
    header_names = fields;
  }
  std::map<std::string, int> seen;
  for (size_t k = first_data; k < content.size(); ++k) {
    const Line& l = *content[k];
    const auto f = Split(l.text, delimiter);
    if (f.size() != fields_per_row) {
      throw InputError({source, l.number, 0, ""},
                       fmt::format("expected {} fields ({}-separated) as in the first point row, "
                                   "line {}; found {}",
                                   fields_per_row, table.delimiter, content[first_data]->number,
                                   f.size()));
    }
    auto where = [&](int column) {
      return SourceLocation{source, l.number, column + 1, header_names[column]};
    };
    auto number = [&](int column, plausible::Quantity quantity, const plausible::Unit& unit) {
      const std::string& field = f[column];
      const auto v = ParseNumber(field, decimal_comma);
      if (!v) {
        throw InputError(
            where(column),
            fmt::format("expected a finite number, got '{}'{}", field,
                        !comma_allowed && ParseNumber(field, true)
                            ? " (a decimal comma needs ';', tab or spaces as the delimiter)"
                            : ""));
      }
      if (auto why = plausible::Check(quantity, *v, unit)) throw InputError(where(column), *why);
      return *v * unit.to_internal;
    };
    TablePoint p;
    p.line = l.number;
    if (layout->name >= 0) {
      p.name = f[layout->name];
      if (auto why = plausible::CheckName(p.name)) throw InputError(where(layout->name), *why);
    } else {
      p.name = fmt::format("line{}", l.number);
    }
    for (int axis = 0; axis < 3; ++axis) {
      p.position_mm(axis) =
          number(layout->xyz[axis], plausible::Quantity::kCoordinate, coordinate_unit);
    }
    if (layout->sigma[0] >= 0) {
      Eigen::Vector3d s;
      for (int axis = 0; axis < 3; ++axis)
        s(axis) = number(layout->sigma[axis], plausible::Quantity::kSigmaLength, sigma_unit);
      p.sigma_mm = s;
    }
    if (layout->time >= 0) {
      p.time = ParseTimeStamp(f[layout->time]);
      if (!p.time) {
        throw InputError(where(layout->time),
                         fmt::format("expected a time stamp (ISO 8601 such as "
                                     "2024-03-05T10:15:30.25, or seconds), got '{}'",
                                     f[layout->time]));
      }
    }
    if (const auto [it, fresh] = seen.emplace(p.name, l.number); !fresh) {
      throw InputError(where(std::max(layout->name, 0)),
                       fmt::format("duplicate point name '{}' (also on line {})", p.name,
                                   it->second));
    }
    table.points.push_back(std::move(p));
  }
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

JointLog ReadJointLog(const std::string& path, const JointLogOptions& options) {
  const CsvTable table = ReadCsvFile(path);
  JointLog log;
  log.source = path;
  std::optional<int> id_col, time_col;
  for (const char* name : {"pose", "point", "id", "name", "label", "pose_id", "point_id"}) {
    if ((id_col = table.FindColumn(name))) break;
  }
  for (const char* name : {"time", "timestamp", "time_stamp", "datetime", "time_s", "t_s"}) {
    if ((time_col = table.FindColumn(name))) break;
  }
  if (!id_col && !time_col) {
    throw InputError({path, 1, 0, ""},
                     "expected a pose id column (pose, point, id, name or label) or a time "
                     "column (time, timestamp, time_s) in the header");
  }
  log.has_ids = id_col.has_value();
  log.has_times = time_col.has_value();
  struct JointColumn {
    int index;
    plausible::Unit unit;
  };
  std::vector<JointColumn> joints;
  if (!options.joint_columns.empty()) {
    for (const auto& name : options.joint_columns)
      joints.push_back({table.Column(name), plausible::UnitOf(options.joint_unit)});
  } else {
    for (int i = 1;; ++i) {
      const std::string base = "q" + std::to_string(i);
      if (options.num_joints > 0 && i > options.num_joints) {
        if (table.FindAngleColumn(base)) {
          throw InputError({path, 1, 0, ""},
                           fmt::format("has a column {} but the robot model has {} joints",
                                       table.FindAngleColumn(base)->name, options.num_joints));
        }
        break;
      }
      const auto column = options.num_joints > 0 ? std::optional(table.AngleColumnOf(base))
                                                 : table.FindAngleColumn(base);
      if (!column) break;
      joints.push_back({column->index, plausible::UnitOf(column->unit)});
    }
    if (joints.empty()) {
      throw InputError({path, 1, 0, ""},
                       "no joint columns: expected q1_deg, q2_deg, … (any of _deg, _gon, _rad) or "
                       "--joint-columns");
    }
  }
  for (const CsvRow& row : table.rows()) {
    JointLogRow r;
    r.line = row.line;
    if (id_col) {
      const std::string& id = table.Text(row, *id_col);
      if (!id.empty()) r.id = table.Name(row, *id_col);
    }
    if (time_col) {
      r.time = ParseTimeStamp(table.Text(row, *time_col));
      if (!r.time) {
        throw InputError(table.Where(row, *time_col),
                         fmt::format("expected a time stamp (ISO 8601 such as "
                                     "2024-03-05T10:15:30.25, or seconds), got '{}'",
                                     table.Text(row, *time_col)));
      }
    }
    if (!r.id && !r.time) {
      throw InputError({path, row.line, 0, ""}, "a joint reading without an id or a time");
    }
    r.joints_rad.resize(static_cast<int>(joints.size()));
    for (size_t i = 0; i < joints.size(); ++i) {
      r.joints_rad(static_cast<int>(i)) = table.Number(row, joints[i].index,
                                                       plausible::Quantity::kJointAngle,
                                                       joints[i].unit);
    }
    log.rows.push_back(std::move(r));
  }
  if (log.rows.empty()) throw InputError({path, 0, 0, ""}, "no joint readings after the header");
  return log;
}

JoinedPoses JoinPointsAndJoints(const PointTable& points, const JointLog& joints,
                                const JoinOptions& options) {
  struct Problem {
    SourceLocation where;
    std::string message;
    std::string brief;
  };
  std::vector<Problem> problems;
  auto at_point = [&](const TablePoint& p) { return SourceLocation{points.source, p.line, 0, ""}; };
  std::vector<int> match(points.points.size(), -1);

  if (options.by == JoinBy::kId) {
    if (!joints.has_ids) {
      throw InputError({joints.source, 1, 0, ""},
                       "joining by id needs a pose id column (pose, point, id, name or label); "
                       "this log has only times: join by time (--match time)");
    }
    std::map<std::string, std::vector<int>> by_id;
    for (size_t j = 0; j < joints.rows.size(); ++j) {
      if (joints.rows[j].id) by_id[*joints.rows[j].id].push_back(static_cast<int>(j));
    }
    for (size_t k = 0; k < points.points.size(); ++k) {
      const TablePoint& p = points.points[k];
      const auto it = by_id.find(p.name);
      if (it == by_id.end()) {
        problems.push_back({at_point(p),
                            fmt::format("point '{}' has no joint reading with that id in {}",
                                        p.name, joints.source),
                            fmt::format("line {} ({}): no joint reading", p.line, p.name)});
      } else if (it->second.size() > 1) {
        problems.push_back(
            {at_point(p),
             fmt::format("point '{}' is ambiguous: {} has it on lines {} and {}", p.name,
                         joints.source, joints.rows[it->second[0]].line,
                         joints.rows[it->second[1]].line),
             fmt::format("line {} ({}): two joint readings", p.line, p.name)});
      } else {
        match[k] = it->second.front();
      }
    }
  } else {
    if (!points.has_times) {
      throw InputError({points.source, points.header_line, 0, ""},
                       "joining by time needs a time column in the point table (Time, "
                       "Timestamp, …)");
    }
    if (!joints.has_times) {
      throw InputError({joints.source, 1, 0, ""},
                       "joining by time needs a time column in the joint log (time, timestamp, "
                       "time_s)");
    }
    std::vector<int> order;
    for (size_t j = 0; j < joints.rows.size(); ++j) {
      if (joints.rows[j].time) order.push_back(static_cast<int>(j));
    }
    const bool absolute = joints.rows[order.front()].time->absolute;
    for (int j : order) {
      if (joints.rows[j].time->absolute != absolute) {
        throw InputError({joints.source, joints.rows[j].line, 0, "time"},
                         "mixes date-times and plain seconds: expected one kind of time stamp");
      }
    }
    std::stable_sort(order.begin(), order.end(), [&](int a, int b) {
      return joints.rows[a].time->seconds < joints.rows[b].time->seconds;
    });
    for (size_t k = 0; k < points.points.size(); ++k) {
      const TablePoint& p = points.points[k];
      if (p.time->absolute != absolute) {
        throw InputError(at_point(p),
                         fmt::format("the point table's time stamps are {} and the joint log's "
                                     "are {}: expected the same kind (both ISO date-times or "
                                     "both seconds)",
                                     p.time->absolute ? "date-times" : "plain seconds",
                                     absolute ? "date-times" : "plain seconds"));
      }
      const double t = p.time->seconds;
      const auto it = std::lower_bound(order.begin(), order.end(), t, [&](int j, double value) {
        return joints.rows[j].time->seconds < value;
      });
      int nearest = -1;
      double gap = std::numeric_limits<double>::infinity();
      for (auto c : {it, it == order.begin() ? order.end() : it - 1}) {
        if (c == order.end()) continue;
        const double g = std::abs(joints.rows[*c].time->seconds - t);
        if (g < gap) {
          gap = g;
          nearest = *c;
        }
      }
      if (gap > options.time_tolerance_s) {
        problems.push_back(
            {at_point(p),
             fmt::format("point '{}' has no joint reading within {:g} s (the nearest, {} line "
                         "{}, is {:.3f} s away)",
                         p.name, options.time_tolerance_s, joints.source,
                         joints.rows[nearest].line, gap),
             fmt::format("line {} ({}): nearest {:.3f} s away", p.line, p.name, gap)});
        continue;
      }
      // Every reading within the tolerance must be the same configuration.
      std::optional<std::string> ambiguity;
      const auto window = std::lower_bound(
          order.begin(), order.end(), t - options.time_tolerance_s,
          [&](int j, double value) { return joints.rows[j].time->seconds < value; });
      for (auto c = window; c != order.end(); ++c) {
        const int j = *c;
        const JointLogRow& r = joints.rows[j];
        if (r.time->seconds > t + options.time_tolerance_s) break;
        if (j == nearest) continue;
        const Eigen::VectorXd d = (r.joints_rad - joints.rows[nearest].joints_rad).cwiseAbs();
        Eigen::Index worst = 0;
        if (d.maxCoeff(&worst) > options.moving_rad) {
          ambiguity = fmt::format(
              "point '{}' is ambiguous: joint readings on lines {} and {} of {} are both within "
              "{:g} s and differ by {:.3f} deg in joint {} (the robot moved, or two "
              "configurations fall in the window; a smaller --time-tolerance-s?)",
              p.name, joints.rows[nearest].line, r.line, joints.source, options.time_tolerance_s,
              d(worst) / kRadPerDeg, worst + 1);
          break;
        }
      }
      if (ambiguity) {
        problems.push_back({at_point(p), *ambiguity,
                            fmt::format("line {} ({}): ambiguous", p.line, p.name)});
        continue;
      }
      match[k] = nearest;
    }
  }
  // One joint reading serves one point.
  std::map<int, size_t> used;
  for (size_t k = 0; k < match.size(); ++k) {
    if (match[k] < 0) continue;
    const auto [it, fresh] = used.emplace(match[k], k);
    if (!fresh) {
      const TablePoint& p = points.points[k];
      const TablePoint& other = points.points[it->second];
      problems.push_back(
          {at_point(p),
           fmt::format("point '{}' and point '{}' (line {}) both take the joint reading on line "
                       "{} of {}: expected one joint reading per point",
                       p.name, other.name, other.line, joints.rows[match[k]].line, joints.source),
           fmt::format("line {} ({}): shares a joint reading", p.line, p.name)});
    }
  }
  if (!problems.empty()) {
    std::string message = problems.front().message;
    if (problems.size() > 1) {
      message += fmt::format("; {} more:", problems.size() - 1);
      for (size_t k = 1; k < problems.size() && k <= 5; ++k) message += " " + problems[k].brief + ";";
      if (problems.size() > 6) message += " …";
    }
    throw InputError(problems.front().where, message);
  }
  JoinedPoses out;
  const int n = static_cast<int>(joints.rows.front().joints_rad.size());
  for (size_t k = 0; k < points.points.size(); ++k) {
    const TablePoint& p = points.points[k];
    const JointLogRow& r = joints.rows[match[k]];
    if (r.joints_rad.size() != n) throw std::logic_error("joint log rows of different sizes");
    MeasuredPose pose;
    pose.id = p.name;
    pose.joints_rad = r.joints_rad;
    pose.target_in_world = p.position_mm;
    out.poses.push_back(std::move(pose));
    Eigen::Matrix3d c = Eigen::Matrix3d::Constant(std::numeric_limits<double>::quiet_NaN());
    if (p.sigma_mm) c = p.sigma_mm->cwiseAbs2().asDiagonal();
    out.covariances_mm2.push_back(c);
    if (p.time && r.time)
      out.max_time_gap_s = std::max(out.max_time_gap_s, std::abs(p.time->seconds - r.time->seconds));
  }
  out.unused_joint_rows = static_cast<int>(joints.rows.size() - used.size());
  return out;
}

}  // namespace armsig::io
