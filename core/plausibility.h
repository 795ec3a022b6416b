// Physical plausibility of the numbers armsig reads: the one place that says what a
// coordinate, a length, an angle, a joint value or an a-priori sigma may be. A value
// outside is not a measurement of a robot cell but a typo, a unit mix-up or a hostile
// file, and the readers (CSV, poses, observations, control points, plans; model, lab and
// stations YAML) refuse it as an InputError naming file:line:column and the range
// expected (exit code 2), before any solver sees it.
//
//   if (auto why = plausible::Check(Quantity::kLength, value, plausible::kMm)) Fail(*why);
#pragma once

#include <cstddef>
#include <optional>
#include <string>
#include <string_view>

#include "core/units.h"

namespace armsig::plausible {

// Lengths and distances (robot links, tool offsets, DH lengths, measured distances, scale
// bars): within ±1 km. A robot cell and its instruments fit in far less.
inline constexpr double kMaxLengthMm = 1e6;
// Coordinates in a measuring or survey frame (station positions, control points, measured
// targets, a given robot base): within ±10,000 km, so that projected grid coordinates
// (UTM, Gauss–Krüger: 1e10 mm with false easting and northing) are accepted, while 1e308
// or 1e19 are not. A double still resolves 2e-6 mm there, and the solvers shift large
// coordinates to a local origin.
inline constexpr double kMaxCoordinateMm = 1e10;
// Angles (azimuths, DH twists, fixed term values): finite and within two turns.
inline constexpr double kMaxAngleRad = 4.0 * kPi;
// Circle readings of an instrument (Hz, and V as a zenith angle, face II above 200 gon): from
// 0 to one full turn, the full turn itself included (it is what a reading just below it
// rounds to, 399.99999996 gon written with four decimals). The same rule for the
// observations CSV, GSI files and every instrument driver.
inline constexpr double kFullCircleRad = 2.0 * kPi;
// Joint values: within ±720 deg (multi-turn wrist joints reach ±360 deg and more).
inline constexpr double kMaxJointRad = 4.0 * kPi;
// A-priori sigmas: no larger than the quantity's own range, and no smaller than a floor far
// below any instrument (a laser tracker's interferometer resolves 0.1 µm, the best
// theodolite 0.1 arc second): a sigma is a weight's root, 1/σ², and 1e-31 mm weighs 1e62, so
// that the adjustment overflows into a "non_finite" point that names no sigma. The same
// floor for every column and key that gives a sigma (observations, control points, tracker
// point tables, lab and stations files, --scale-bar-sigma-mm).
inline constexpr double kMinSigmaMm = 1e-6;                   // 1 nm
inline constexpr double kMinSigmaRad = 1e-4 * kRadPerArcsec;  // 0.0001 arc second
inline constexpr double kMaxSigmaMm = kMaxLengthMm;
inline constexpr double kMaxSigmaRad = 2.0 * kPi;

enum class Quantity {
  kLength,         // mm: link lengths, tool offsets, scale bars
  kDistance,       // mm, > 0: a measured distance (slope distance of a total station, tracker)
  kCoordinate,     // mm: positions in a measuring or survey frame
  kAngle,          // rad
  kCircleReading,  // rad, [0, full circle]: a horizontal circle reading Hz
  kZenithAngle,    // rad, [0, full circle]: a vertical circle reading V (zenith angle)
  kJointAngle,     // rad
  kSigmaLength,    // mm, from kMinSigmaMm
  kSigmaAngle,     // rad, from kMinSigmaRad
};

// Names (robots, models, parameter and term names, station, point and pose ids) and notes
// end up in log lines, terminals, CSV, JSON, the database and HTML reports: valid UTF-8 (a
// stray byte makes every JSON output of the name fail), no control characters (a newline
// in a robot name forges a log line; an escape sequence rewrites the terminal; also DEL,
// the C1 controls and the Unicode line separators and bidirectional overrides, core/text.h),
// not only blanks or invisible characters (a name that looks empty), and a sane length in
// bytes.
inline constexpr std::size_t kMaxNameLength = 64;
inline constexpr std::size_t kMaxNoteLength = 1000;
// nullopt when `text` is a usable name; otherwise "expected a name of 1 to 64 bytes of
// UTF-8 text without control characters, got …" with what is wrong named (the control
// character and its byte, the byte that is not UTF-8, the length).
std::optional<std::string> CheckName(std::string_view text,
                                     std::size_t max_length = kMaxNameLength);
// The same for a free-text note: may be empty or blank, ≤ kMaxNoteLength bytes.
std::optional<std::string> CheckNote(std::string_view text);

// The unit a value is given in (the column's or key's suffix), for the check and the message.
struct Unit {
  const char* name;    // "mm", "deg", "gon", "rad", "arcsec"
  double to_internal;  // factor to mm or rad
};
inline constexpr Unit kMm{"mm", 1.0};
inline constexpr Unit kArcsec{"arcsec", kRadPerArcsec};
Unit UnitOf(AngleUnit unit);

// Whether `value` (mm or rad) is a plausible value of `quantity`. NaN and ±inf never are.
bool IsPlausible(Quantity quantity, double value);

// "a finite length within ±1000000 mm (1 km)", "a finite joint angle within ±720 deg", …
// with the range in `unit`.
std::string Expected(Quantity quantity, Unit unit);

// nullopt when `given` (in `unit`) is a plausible value of `quantity`, otherwise
// "expected <range in unit>, got <given>".
std::optional<std::string> Check(Quantity quantity, double given, Unit unit);

}  // namespace armsig::plausible
