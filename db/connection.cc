#include "db/connection.h"

#include <spdlog/spdlog.h>

namespace armsig::db {

int64_t Connection::QueryInt(std::string_view sql) {
  auto s = Prepare(sql);
  if (!s->Step()) throw DatabaseError(name() + ": no row from " + std::string(sql), "", false);
  return s->Int(0);
}

std::string NumberedPlaceholders(std::string_view sql) {
  std::string out;
  out.reserve(sql.size() + 16);
  int n = 0;
  char quote = 0;  // inside '…' or "…"
  for (char c : sql) {
    if (quote) {
      if (c == quote) quote = 0;
      out += c;
    } else if (c == '\'' || c == '"') {
      quote = c;
      out += c;
    } else if (c == '?') {
      out += '$' + std::to_string(++n);
    } else {
      out += c;
    }
  }
  return out;
}

Transaction::Transaction(Connection& connection, TransactionKind kind) : connection_(connection) {
  connection_.Begin(kind);
}

Transaction::~Transaction() {
  if (!open_) return;
  try {
    connection_.Rollback();
  } catch (const std::exception& e) {
    spdlog::warn("database {}: rollback failed: {}", connection_.name(), e.what());
  }
}

void Transaction::Commit() {
  connection_.Commit();
  open_ = false;
}

}  // namespace armsig::db
