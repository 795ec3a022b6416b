#include "io/point_table_header.h"

#include <fmt/format.h>

#include <array>
#include <cctype>
#include <regex>
#include <set>

#include "core/error.h"
#include "core/text.h"

namespace armsig::io::point_table {

std::string Lower(std::string_view s) {
  std::string out(s);
  for (char& c : out) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return out;
}

namespace {

// A column name with its unit annotations taken off: the name left, the length unit or
// seconds they said.
struct Annotated {
  std::string name;
  ColumnName units;  // role not set
};

// Bracketed annotations ("X [mm]", "T (s)") are a unit, or part of the name ("u(x)").
Annotated TakeBracketedUnits(const std::string& text) {
  Annotated out;
  for (size_t i = 0; i < text.size(); ++i) {
    const char open = text[i];
    if (open == '[' || open == '(') {
      const char close = open == '[' ? ']' : ')';
      const size_t end = text.find(close, i);
      if (end != std::string::npos) {
        const std::string inside(Trim(std::string_view(text).substr(i + 1, end - i - 1), kBlank));
        if (auto u = LengthUnitFromText(inside)) {
          out.units.unit = u;
        } else if (inside == "s" || inside == "sec" || inside == "seconds") {
          out.units.unit_is_seconds = true;
        } else {
          out.name += inside;
        }
        i = end;
        continue;
      }
    }
    out.name += open;
  }
  return out;
}

// A unit suffix after '_' or ' ': "x_mm", "x mm", "time_s" (a bracketed unit wins).
void TakeUnitSuffix(Annotated* a) {
  for (const char sep : {'_', ' '}) {
    const size_t at = a->name.rfind(sep);
    if (at == std::string::npos || at == 0) continue;
    const std::string suffix(Trim(std::string_view(a->name).substr(at + 1), kBlank));
    if (auto u = LengthUnitFromText(suffix); u && !a->units.unit) {
      a->units.unit = u;
      a->name.resize(at);
    } else if (suffix == "s" || suffix == "sec") {
      a->units.unit_is_seconds = true;
      a->name.resize(at);
    }
  }
}

// The role of a column by its name's letters and digits alone ("Pt. ID" → "ptid"): the
// names vendors use for the point, its coordinates, their sigmas and the time.
Role RoleOf(const std::string& key) {
  static const std::set<std::string> names = {
      "name",   "point",       "pointname", "pointid", "ptid",   "pt", "id",
      "target", "targetname",  "label",     "pose",    "poseid", "nr", "no",
      "number", "pointnumber", "ptno",      "pointno", "ptname"};
  static const std::set<std::string> times = {"time", "timestamp", "datetime",
                                              "t",    "timesec",   "times"};
  if (names.count(key)) return Role::kName;
  if (times.count(key)) return Role::kTime;
  if (key == "x" || key == "east" || key == "easting") return Role::kX;
  if (key == "y" || key == "north" || key == "northing") return Role::kY;
  if (key == "z" || key == "height" || key == "elevation" || key == "elev" || key == "h")
    return Role::kZ;
  static const std::array<std::string, 8> prefixes = {"sigma", "sd",  "std",         "stddev",
                                                      "u",     "unc", "uncertainty", "s"};
  static const std::array<std::string, 6> suffixes = {"sigma",  "sd",  "std",
                                                      "stddev", "unc", "uncertainty"};
  for (int axis = 0; axis < 3; ++axis) {
    const std::string a(1, static_cast<char>('x' + axis));
    bool sigma = false;
    for (const auto& p : prefixes) sigma |= key == p + a;
    for (const auto& s : suffixes) sigma |= key == a + s;
    if (sigma) return axis == 0 ? Role::kSx : axis == 1 ? Role::kSy : Role::kSz;
  }
  return Role::kOther;
}

}  // namespace

ColumnName Classify(std::string_view raw) {
  std::string text = Lower(Trim(raw, kBlank));
  for (size_t at = text.find("\xCF\x83"); at != std::string::npos; at = text.find("\xCF\x83"))
    text.replace(at, 2, "sigma");
  Annotated annotated = TakeBracketedUnits(text);
  TakeUnitSuffix(&annotated);
  std::string key;
  for (char c : annotated.name) {
    if (std::isalnum(static_cast<unsigned char>(c))) key += c;
  }
  ColumnName out = annotated.units;
  out.role = RoleOf(key);
  return out;
}

std::vector<std::string> MergeHeaderWords(std::vector<std::string> fields, size_t wanted) {
  bool merged = true;
  while (fields.size() > wanted && merged) {
    merged = false;
    for (size_t k = 1; k < fields.size() && fields.size() > wanted; ++k) {
      const std::string& w = fields[k];
      const bool annotation =
          (w.starts_with("[") || w.starts_with("(")) &&
          LengthUnitFromText(
              Trim(std::string_view(w).substr(1, w.size() >= 2 ? w.size() - 2 : 0), kBlank));
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

std::optional<Layout> HeaderLayout(const std::vector<std::string>& fields,
                                   const std::string& source, int line) {
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

std::optional<LengthUnit> DeclaredUnit(const std::string& text) {
  static const std::regex r(R"(\bunits?\b\s*[:=;,]?\s*([A-Za-z"]+))", std::regex::icase);
  std::smatch m;
  if (std::regex_search(text, m, r)) return LengthUnitFromText(m[1].str());
  return std::nullopt;
}

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

}  // namespace armsig::io::point_table
