#include "io/gsi_import.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <optional>

#include "core/error.h"
#include "core/plausibility.h"
#include "core/text.h"
#include "core/units.h"
#include "instruments/gsi_codec.h"
#include "io/atomic_file.h"
#include "io/csv.h"

namespace armsig::io {

namespace {

// The unit a GSI angle word is written in, for the message.
plausible::Unit WordUnit(const instruments::gsi::Word& word) {
  switch (word.unit) {
    case '3':
    case '4':
      return plausible::UnitOf(AngleUnit::kDeg);
    case '5':
      return {"mil", kPi / 3200.0};
    default:
      return plausible::UnitOf(AngleUnit::kGon);
  }
}

// A circle reading (Hz or V) by the one rule of core/plausibility.h, as the observations CSV
// and the drivers read them; else an InputError naming file, line, column, the value in the
// word's own unit and the range.
void CheckCircleReading(const instruments::gsi::Word& word, double rad, const SourceLocation& where,
                        plausible::Quantity quantity) {
  const plausible::Unit unit = WordUnit(word);
  if (auto why = plausible::Check(quantity, rad / unit.to_internal, unit)) {
    throw InputError(where, *why);
  }
}

}  // namespace

GsiImport ParseGsiImport(std::string_view text, const std::string& source,
                         const std::string& station) {
  namespace gsi = instruments::gsi;
  if (auto why = plausible::CheckName(station)) throw InputError({"--station", 0, 0, ""}, *why);
  const auto file = gsi::ParseFile(text);
  if (file.error)
    throw InputError({source, file.error->line, file.error->column, ""}, file.error->message);
  GsiImport out;
  for (const auto& block : file.blocks) {
    ++out.blocks;
    const gsi::Word *point = nullptr, *hz = nullptr, *v = nullptr, *distance = nullptr;
    for (const auto& w : block.words) {
      if (w.wi == 11) point = &w;
      if (w.wi == 21) hz = &w;
      if (w.wi == 22) v = &w;
      if (w.wi == 31) distance = &w;
    }
    if (!hz || !v) {
      ++out.skipped_blocks;
      continue;
    }
    auto where = [&](const gsi::Word& w, const char* name) {
      return SourceLocation{source, block.line, w.column, name};
    };
    if (!point)
      throw InputError({source, block.line, 1, "WI11"},
                       "block with Hz and V but no point number (word 11)");
    std::string why;
    reduction::Observation o;
    o.point = gsi::Identifier(*point);
    if (auto bad = plausible::CheckName(o.point)) throw InputError(where(*point, "WI11"), *bad);
    o.station = station;
    auto hz_rad = gsi::AngleRad(*hz, &why);
    if (!hz_rad) throw InputError(where(*hz, "WI21"), why);
    auto v_rad = gsi::AngleRad(*v, &why);
    if (!v_rad) throw InputError(where(*v, "WI22"), why);
    CheckCircleReading(*hz, *hz_rad, where(*hz, "WI21"), plausible::Quantity::kCircleReading);
    CheckCircleReading(*v, *v_rad, where(*v, "WI22"), plausible::Quantity::kZenithAngle);
    o.reading = {WrapTwoPi(*hz_rad), *v_rad, FaceOfZenithAngle(*v_rad)};
    if (distance) {
      auto mm = gsi::LengthMm(*distance, &why);
      if (!mm) throw InputError(where(*distance, "WI31"), why);
      // 0 is the format's "no distance measured"; anything else is a distance by the rule
      // every reader applies (a negative one is no measurement, 1e16 mm no robot cell).
      if (*mm != 0.0) {
        if (auto bad = plausible::Check(plausible::Quantity::kDistance, *mm, plausible::kMm)) {
          throw InputError(where(*distance, "WI31"), *bad);
        }
        o.distance_mm = *mm;
      }
    }
    o.source_line = block.line;
    out.observations.push_back(std::move(o));
  }
  if (out.observations.empty()) {
    throw InputError({source, 0, 0, ""}, "no block with both Hz (word 21) and V (word 22)");
  }
  return out;
}

GsiImport ImportGsi(const std::string& path, const std::string& station) {
  return ParseGsiImport(ReadWholeFile(path, kGsiFileLimit), path, station);
}

std::string FormatObservationsCsv(const std::vector<reduction::Observation>& observations) {
  // The sigma columns only when a reading carries its own; an empty cell is the station's
  // sigma, else the instrument's default, as the observations reader takes it.
  const bool sigmas = std::any_of(observations.begin(), observations.end(), [](const auto& o) {
    return o.sigma_hz_rad || o.sigma_v_rad || o.sigma_distance_mm;
  });
  auto cell = [](const std::optional<double>& value, double unit) {
    return value ? fmt::format("{:.6g}", *value / unit) : std::string();
  };
  std::string out = "point,station,hz_gon,v_gon,face,distance_mm";
  out += sigmas ? ",sigma_hz_arcsec,sigma_v_arcsec,sigma_distance_mm\n" : "\n";
  for (const auto& o : observations) {
    out += fmt::format("{},{},{:.9f},{:.9f},{},{}", CsvEscape(o.point), CsvEscape(o.station),
                       FromRad(o.reading.hz_rad, AngleUnit::kGon),
                       FromRad(o.reading.v_rad, AngleUnit::kGon), o.reading.face,
                       o.distance_mm ? fmt::format("{:.4f}", *o.distance_mm) : "");
    if (sigmas) {
      out += fmt::format(",{},{},{}", cell(o.sigma_hz_rad, kRadPerArcsec),
                         cell(o.sigma_v_rad, kRadPerArcsec), cell(o.sigma_distance_mm, 1.0));
    }
    out += "\n";
  }
  return out;
}

}  // namespace armsig::io
