#include "core/plausibility.h"

#include <cmath>
#include <cstdio>

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

// The first control character in `text` as "U+000A at byte 6", or nullopt.
std::optional<std::string> ControlCharacter(std::string_view text) {
  auto at = [](unsigned code, size_t byte) {
    char code_text[16];
    std::snprintf(code_text, sizeof code_text, "U+%04X", code);
    return "control character " + std::string(code_text) + " at byte " + std::to_string(byte + 1);
  };
  for (size_t i = 0; i < text.size(); ++i) {
    const auto c = static_cast<unsigned char>(text[i]);
    if (c < 0x20 || c == 0x7f) return at(c, i);
    const auto next = [&](size_t k) {
      return i + k < text.size() ? static_cast<unsigned char>(text[i + k]) : 0u;
    };
    // C1 controls U+0080–U+009F (UTF-8 C2 80–C2 9F).
    if (c == 0xc2 && next(1) >= 0x80 && next(1) <= 0x9f) return at(next(1), i);
    // U+2028/2029 line and paragraph separators, U+202A–202E and U+2066–2069 bidi controls.
    if (c == 0xe2 && next(1) == 0x80 && next(2) >= 0xa8 && next(2) <= 0xae) {
      return at(0x2000 + (next(2) - 0x80), i);
    }
    if (c == 0xe2 && next(1) == 0x81 && next(2) >= 0xa6 && next(2) <= 0xa9) {
      return at(0x2040 + (next(2) - 0x80), i);
    }
  }
  return std::nullopt;
}

}  // namespace

std::optional<std::string> CheckName(std::string_view text, std::size_t max_length) {
  const std::string expected = "expected a name of 1 to " + std::to_string(max_length) +
                               " characters without control characters";
  if (text.empty()) return expected + ", got an empty name";
  if (text.size() > max_length) {
    return expected + ", got " + std::to_string(text.size()) + " bytes";
  }
  if (auto control = ControlCharacter(text)) return expected + ", got a " + *control;
  return std::nullopt;
}

std::optional<std::string> CheckNote(std::string_view text) {
  const std::string expected = "expected a note of at most " + std::to_string(kMaxNoteLength) +
                               " characters without control characters";
  if (text.size() > kMaxNoteLength) {
    return expected + ", got " + std::to_string(text.size()) + " bytes";
  }
  if (auto control = ControlCharacter(text)) return expected + ", got a " + *control;
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
    case Quantity::kCoordinate:
      return std::abs(value) <= kMaxCoordinateMm;
    case Quantity::kAngle:
      return std::abs(value) <= kMaxAngleRad;
    case Quantity::kJointAngle:
      return std::abs(value) <= kMaxJointRad;
    case Quantity::kSigmaLength:
      return value > 0 && value <= kMaxSigmaMm;
    case Quantity::kSigmaAngle:
      return value > 0 && value <= kMaxSigmaRad;
  }
  return false;
}

std::string Expected(Quantity quantity, Unit unit) {
  switch (quantity) {
    case Quantity::kLength:
      return "a finite length within ±" + Range(kMaxLengthMm, unit) + " (1 km)";
    case Quantity::kCoordinate:
      return "a finite coordinate within ±" + Range(kMaxCoordinateMm, unit) + " (10,000 km)";
    case Quantity::kAngle:
      return "a finite angle within ±" + Range(kMaxAngleRad, unit) + " (two turns)";
    case Quantity::kJointAngle:
      return "a finite joint angle within ±" + Range(kMaxJointRad, unit) +
             (std::string_view(unit.name) == "deg" ? "" : " (±720 deg)");
    case Quantity::kSigmaLength:
      return "a sigma > 0 and ≤ " + Range(kMaxSigmaMm, unit);
    case Quantity::kSigmaAngle:
      return "an angular sigma > 0 and ≤ " + Range(kMaxSigmaRad, unit) + " (one turn)";
  }
  return "a plausible value";
}

std::optional<std::string> Check(Quantity quantity, double given, Unit unit) {
  if (IsPlausible(quantity, given * unit.to_internal)) return std::nullopt;
  return "expected " + Expected(quantity, unit) + ", got " + Number(given);
}

}  // namespace armsig::plausible
