// The armsig database schema: versioned with PRAGMA user_version, upgraded by
// forward migrations. Migration i (0-based) takes the file from version i to i+1.
#pragma once

#include <span>
#include <string_view>

namespace armsig::db {

std::span<const std::string_view> Migrations();
inline int LatestSchemaVersion() { return static_cast<int>(Migrations().size()); }

// Tables of the current schema, in dependency order (for `db info` and `db export`).
std::span<const std::string_view> TableNames();
// The tables an armsig file from before PRAGMA application_id holds (schema v1's): how
// such a file is recognised as armsig's.
std::span<const std::string_view> LegacyTableNames();

}  // namespace armsig::db
