// Small binding helpers shared by the db/ table families (not part of the public API).
#pragma once

#include <SQLiteCpp/Statement.h>

#include <cmath>
#include <cstdio>
#include <string>

namespace armsig::db {

// Binds a finite value, NULL otherwise (NaN and ±inf mean "not known").
inline void BindOptional(SQLite::Statement& s, int index, double value) {
  if (std::isfinite(value))
    s.bind(index, value);
  else
    s.bind(index);
}

// A JSON array of n doubles printed exactly (%.17g).
inline std::string JsonArray(const double* v, int n) {
  std::string out = "[";
  char buffer[32];
  for (int i = 0; i < n; ++i) {
    std::snprintf(buffer, sizeof buffer, "%s%.17g", i ? "," : "", v[i]);
    out += buffer;
  }
  return out + "]";
}

}  // namespace armsig::db
