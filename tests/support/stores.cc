#include "support/stores.h"

#include "support/postgres_server.h"

namespace armsig::testing {

std::string NewStore(db::Backend backend, const TempDir& dir, const std::string& name) {
  if (backend == db::Backend::kSqlite) return dir.File(name + ".db");
  return PostgresServer::Shared().NewDatabase(name);
}

std::string BackendName(const ::testing::TestParamInfo<db::Backend>& info) {
  return info.param == db::Backend::kSqlite ? "Sqlite" : "Postgres";
}

}  // namespace armsig::testing
