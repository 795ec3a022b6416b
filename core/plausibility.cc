#include "core/plausibility.h"

#include <cmath>
#include <cstdio>

#include "core/text.h"

namespace armsig::plausible {

namespace {

std::string Number(double value) {
  char buffer[40];
  std::snprintf(buffer, sizeof buffer, "%.10g", value);
  return buffer;
}

std::string Range(double internal, Unit unit) {
  return Number(internal / unit.to_internal) + " " + unit.name;
}

// What makes `text` unusable as a name or note, or nullopt: "a control character U+000A
// at byte 6", "a byte 0xff at byte 2 that is not UTF-8".
std::optional<std::string> BadCharacter(std::string_view text) {
  for (size_t pos = 0; pos < text.size();) {
    const size_t at = pos;
    const auto c = NextCodePoint(text, &pos);
    char buffer[64];
    if (!c) {
      std::snprintf(buffer, sizeof buffer, "a byte 0x%02x at byte %zu that is not UTF-8",
                    static_cast<unsigned>(static_cast<unsigned char>(text[at])), at + 1);
      return buffer;
    }
    if (IsControlCharacter(*c)) {
      std::snprintf(buffer, sizeof buffer, "a control character U+%04X at byte %zu",
                    static_cast<unsigned>(*c), at + 1);
      return buffer;
    }
  }
  return std::nullopt;
}

bool OnlyInvisible(std::string_view text) {
  for (size_t pos = 0; pos < text.size();) {
    const auto c = NextCodePoint(text, &pos);
    if (!c || !IsInvisible(*c)) return false;
  }
  return true;
}

}  // namespace

std::optional<std::string> CheckName(std::string_view text, std::size_t max_length) {
  const std::string expected = "expected a name of 1 to " + std::to_string(max_length) +
                               " bytes of UTF-8 text without control characters";
  if (text.empty()) return expected + ", got an empty name";
  if (text.size() > max_length) {
    return expected + ", got " + std::to_string(text.size()) + " bytes";
  }
  if (auto bad = BadCharacter(text)) return expected + ", got " + *bad;
  if (OnlyInvisible(text)) {
    return expected + ", got " + Quoted(text) + ": only blanks or invisible characters";
  }
  return std::nullopt;
}

std::optional<std::string> CheckNote(std::string_view text) {
  const std::string expected = "expected a note of at most " + std::to_string(kMaxNoteLength) +
                               " bytes of UTF-8 text without control characters";
  if (text.size() > kMaxNoteLength) {
    return expected + ", got " + std::to_string(text.size()) + " bytes";
  }
  if (auto bad = BadCharacter(text)) return expected + ", got " + *bad;
  return std::nullopt;
}

Unit UnitOf(AngleUnit unit) {
  switch (unit) {
    case AngleUnit::kDeg:
      return {"deg", kRadPerDeg};
    case AngleUnit::kGon:
      return {"gon", kRadPerGon};
    case AngleUnit::kRad:
      break;
  }
  return {"rad", 1.0};
}

bool IsPlausible(Quantity quantity, double value) {
  if (!std::isfinite(value)) return false;
  switch (quantity) {
    case Quantity::kLength:
      return std::abs(value) <= kMaxLengthMm;
    case Quantity::kDistance:
      return value > 0 && value <= kMaxLengthMm;
    case Quantity::kCoordinate:
      return std::abs(value) <= kMaxCoordinateMm;
    case Quantity::kAngle:
      return std::abs(value) <= kMaxAngleRad;
    case Quantity::kCircleReading:
    case Quantity::kZenithAngle:
      // The full turn given in gon or deg converts to 2π plus a rounding ulp or two.
      return value >= 0 && value <= kFullCircleRad * (1 + 1e-14);
    case Quantity::kJointAngle:
      return std::abs(value) <= kMaxJointRad;
    case Quantity::kSigmaLength:
      return value >= kMinSigmaMm && value <= kMaxSigmaMm;
    case Quantity::kSigmaAngle:
      // The floor given in arc seconds converts to it less a rounding ulp.
      return value >= kMinSigmaRad * (1 - 1e-14) && value <= kMaxSigmaRad;
  }
  return false;
}

std::string Expected(Quantity quantity, Unit unit) {
  switch (quantity) {
    case Quantity::kLength:
      return "a finite length within ±" + Range(kMaxLengthMm, unit) + " (1 km)";
    case Quantity::kDistance:
      return "a distance > 0 and ≤ " + Range(kMaxLengthMm, unit) + " (1 km)";
    case Quantity::kCoordinate:
      return "a finite coordinate within ±" + Range(kMaxCoordinateMm, unit) + " (10,000 km)";
    case Quantity::kAngle:
      return "a finite angle within ±" + Range(kMaxAngleRad, unit) + " (two turns)";
    case Quantity::kCircleReading:
      return "a horizontal circle reading from 0 to " + Range(kFullCircleRad, unit);
    case Quantity::kZenithAngle:
      return "a zenith angle from 0 to " + Range(kFullCircleRad, unit) +
             " (face II above the half circle)";
    case Quantity::kJointAngle:
      return "a finite joint angle within ±" + Range(kMaxJointRad, unit) +
             (std::string_view(unit.name) == "deg" ? "" : " (±720 deg)");
    case Quantity::kSigmaLength:
      return "a sigma from " + Range(kMinSigmaMm, unit) + " to " + Range(kMaxSigmaMm, unit);
    case Quantity::kSigmaAngle:
      return "an angular sigma from " + Range(kMinSigmaRad, unit) + " to " +
             Range(kMaxSigmaRad, unit) + " (one turn)";
  }
  return "a plausible value";
}

std::optional<std::string> Check(Quantity quantity, double given, Unit unit) {
  if (IsPlausible(quantity, given * unit.to_internal)) return std::nullopt;
  return "expected " + Expected(quantity, unit) + ", got " + Number(given);
}

}  // namespace armsig::plausible
