#include "db/connection.h"

#include <spdlog/spdlog.h>

#include <algorithm>

namespace armsig::db {

bool IsInfrastructureFault(const std::exception& error) {
  const auto* e = dynamic_cast<const DatabaseError*>(&error);
  return e && (e->connection_lost() || e->transient());
}

int64_t Connection::QueryInt(std::string_view sql) {
  auto s = Prepare(sql);
  if (!s->Step()) throw DatabaseError(name() + ": no row from " + std::string(sql), "", false);
  return s->Int(0);
}

std::string NumberedPlaceholders(std::string_view sql) {
  std::string out;
  out.reserve(sql.size() + 16);
  int largest = 0;
  char quote = 0;  // inside '…' or "…"
  for (size_t k = 0; k < sql.size(); ++k) {
    const char c = sql[k];
    if (quote) {
      if (c == quote) quote = 0;
      out += c;
    } else if (c == '\'' || c == '"') {
      quote = c;
      out += c;
    } else if (c == '?') {
      size_t end = k + 1;
      while (end < sql.size() && sql[end] >= '0' && sql[end] <= '9') ++end;
      const int number =
          end > k + 1 ? std::stoi(std::string(sql.substr(k + 1, end - k - 1))) : largest + 1;
      largest = std::max(largest, number);
      out += '$' + std::to_string(number);
      k = end - 1;
    } else {
      out += c;
    }
  }
  return out;
}

int64_t InsertedId(Statement& insert, const std::string& what) {
  if (!insert.Step()) throw DatabaseError("no id returned for " + what, "", false);
  const int64_t id = insert.Int(0);
  while (insert.Step()) {
  }
  return id;
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
