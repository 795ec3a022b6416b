// An enum's words as files, the store and the command line write them: one table of
// {value, word} pairs per enum, and the two look-ups.
#pragma once

#include <cstddef>
#include <optional>
#include <string_view>
#include <utility>

namespace armsig {

template <typename Enum>
using EnumWord = std::pair<Enum, const char*>;

// The word of `value` ("?" for a value the table does not hold).
template <typename Enum, std::size_t N>
constexpr const char* WordOf(const EnumWord<Enum> (&table)[N], Enum value) {
  for (const auto& [v, word] : table) {
    if (v == value) return word;
  }
  return "?";
}

// The value `word` names, nullopt for another word.
template <typename Enum, std::size_t N>
constexpr std::optional<Enum> ValueNamed(const EnumWord<Enum> (&table)[N], std::string_view word) {
  for (const auto& [v, w] : table) {
    if (word == w) return v;
  }
  return std::nullopt;
}

}  // namespace armsig
