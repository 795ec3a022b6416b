#include "io/gsi_import.h"

#include <fmt/format.h>

#include <cmath>

#include "core/error.h"
#include "core/units.h"
#include "instruments/gsi_codec.h"
#include "io/atomic_file.h"
#include "io/csv.h"

namespace armsig::io {

namespace {

// A circle reading of `word` (Hz or V) in [0, full circle] in the word's own unit, else
// an InputError naming file, line, column, the value and the expected range.
void CheckCircleReading(const instruments::gsi::Word& word, double rad, const SourceLocation& where,
                        const char* what) {
  if (rad >= 0.0 && rad <= 2.0 * kPi) return;
  const char* unit = "gon";
  double per_rad = 200.0 / kPi, circle = 400.0;
  switch (word.unit) {
    case '3':
    case '4':
      unit = "deg";
      per_rad = 180.0 / kPi;
      circle = 360.0;
      break;
    case '5':
      unit = "mil";
      per_rad = 3200.0 / kPi;
      circle = 6400.0;
      break;
    default:
      break;
  }
  throw InputError(where, fmt::format("{} = {:.5f} {} is no circle reading: expected 0 to {} {}",
                                      what, rad * per_rad, unit, circle, unit));
}

}  // namespace

GsiImport ImportGsi(const std::string& path, const std::string& station) {
  namespace gsi = instruments::gsi;
  const auto file = gsi::ParseFile(ReadWholeFile(path));
  if (file.error)
    throw InputError({path, file.error->line, file.error->column, ""}, file.error->message);
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
      return SourceLocation{path, block.line, w.column, name};
    };
    if (!point)
      throw InputError({path, block.line, 1, "WI11"},
                       "block with Hz and V but no point number (word 11)");
    std::string why;
    reduction::Observation o;
    o.point = gsi::Identifier(*point);
    o.station = station;
    auto hz_rad = gsi::AngleRad(*hz, &why);
    if (!hz_rad) throw InputError(where(*hz, "WI21"), why);
    auto v_rad = gsi::AngleRad(*v, &why);
    if (!v_rad) throw InputError(where(*v, "WI22"), why);
    CheckCircleReading(*hz, *hz_rad, where(*hz, "WI21"), "Hz");
    CheckCircleReading(*v, *v_rad, where(*v, "WI22"), "V (zenith angle)");
    o.reading = {WrapTwoPi(*hz_rad), *v_rad, *v_rad > kPi ? 2 : 1};
    if (distance) {
      auto mm = gsi::LengthMm(*distance, &why);
      if (!mm) throw InputError(where(*distance, "WI31"), why);
      if (*mm > 0) o.distance_mm = *mm;  // 0 = no distance measured
    }
    o.source_line = block.line;
    out.observations.push_back(std::move(o));
  }
  if (out.observations.empty()) {
    throw InputError({path, 0, 0, ""}, "no block with both Hz (word 21) and V (word 22)");
  }
  return out;
}

std::string FormatObservationsCsv(const std::vector<reduction::Observation>& observations) {
  std::string out = "point,station,hz_gon,v_gon,face,distance_mm\n";
  for (const auto& o : observations) {
    out += fmt::format("{},{},{:.9f},{:.9f},{},{}\n", CsvEscape(o.point), CsvEscape(o.station),
                       FromRad(o.reading.hz_rad, AngleUnit::kGon),
                       FromRad(o.reading.v_rad, AngleUnit::kGon), o.reading.face,
                       o.distance_mm ? fmt::format("{:.4f}", *o.distance_mm) : "");
  }
  return out;
}

}  // namespace armsig::io
