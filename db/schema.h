// The armsig database schema: versioned with PRAGMA user_version, upgraded by
// forward migrations. Migration i (0-based) takes the file from version i to i+1.
#pragma once

#include <span>
#include <string>
#include <string_view>

#include "db/connection.h"

namespace armsig::db {

// SQLite's text of each migration.
std::span<const std::string_view> Migrations();
inline int LatestSchemaVersion() { return static_cast<int>(Migrations().size()); }
// The migration from version `from` to from + 1 in `backend`'s SQL: SQLite's text, or
// PostgreSQL's (SQLite's DDL translated by PostgresDdl, or written apart where SQLite's
// statements use what only SQLite has).
std::string MigrationSql(int from, Backend backend);
// SQLite DDL as PostgreSQL's: the rowid key an identity column, INTEGER as BIGINT, REAL as
// DOUBLE PRECISION (PostgreSQL's REAL has 24 bits), the time-stamp default by the server's
// clock; quoted text and comments as they are.
std::string PostgresDdl(std::string_view sqlite_ddl);
// SQL for the current time as armsig stores it (ISO 8601 UTC with milliseconds, TEXT:
// "2026-11-26T16:29:32.123Z"), in `backend`'s dialect.
std::string_view NowIsoSql(Backend backend);

// Tables of the current schema, in dependency order (for `db info` and `db export`).
std::span<const std::string_view> TableNames();
// The tables an armsig file from before PRAGMA application_id holds (schema v1's): how
// such a file is recognised as armsig's.
std::span<const std::string_view> LegacyTableNames();

}  // namespace armsig::db
