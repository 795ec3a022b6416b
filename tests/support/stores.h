// Tests that run on both store backends (TEST_P over db::Backend): a new, empty store of
// the backend (a file in the test's directory, or a new database on the tests' PostgreSQL
// server), and the backends' names for the test names (".../Sqlite", ".../Postgres").
#pragma once

#include <gtest/gtest.h>

#include <string>

#include "db/connection.h"
#include "test_support.h"

namespace armsig::testing {

// A store location `db::Database` opens: for SQLite `dir`'s file `name`.db (not created),
// for PostgreSQL a new empty database (its URI).
std::string NewStore(db::Backend backend, const TempDir& dir, const std::string& name);

std::string BackendName(const ::testing::TestParamInfo<db::Backend>& info);

// INSTANTIATE_TEST_SUITE_P over both backends.
#define ARMSIG_BOTH_BACKENDS(suite)                                                     \
  INSTANTIATE_TEST_SUITE_P(Store, suite,                                                \
                           ::testing::Values(::armsig::db::Backend::kSqlite,            \
                                             ::armsig::db::Backend::kPostgres),         \
                           ::armsig::testing::BackendName)

}  // namespace armsig::testing
