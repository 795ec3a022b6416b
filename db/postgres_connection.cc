#include "db/postgres_connection.h"

#include <fmt/format.h>
#include <poll.h>
#include <postgresql/libpq-fe.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <optional>
#include <vector>

#include "core/error.h"
#include "core/text.h"

namespace armsig::db {

namespace {

using Clock = std::chrono::steady_clock;

// SQLSTATEs of a lost race: serialization failure, deadlock, lock not available.
bool Transient(const std::string& sqlstate) {
  return sqlstate == "40001" || sqlstate == "40P01" || sqlstate == "55P03";
}

// SQLSTATEs of a server that went away: connection exceptions (class 08), and the server
// shutting down, crashed or still starting (57P01…57P03).
bool ServerWentAway(const std::string& sqlstate) {
  return sqlstate.rfind("08", 0) == 0 || sqlstate == "57P01" || sqlstate == "57P02" ||
         sqlstate == "57P03";
}

// libpq's messages end with a line feed.
std::string Trimmed(std::string_view text) { return std::string(Trim(text, "\n ")); }

struct ResultDeleter {
  void operator()(PGresult* r) const { PQclear(r); }
};
using Result = std::unique_ptr<PGresult, ResultDeleter>;

std::string DecodeBytea(const char* text) {
  size_t length = 0;
  unsigned char* bytes = PQunescapeBytea(reinterpret_cast<const unsigned char*>(text), &length);
  if (!bytes) return {};
  std::string out(reinterpret_cast<const char*>(bytes), length);
  PQfreemem(bytes);
  return out;
}

class PostgresStatement : public Statement {
 public:
  PostgresStatement(PostgresConnection& connection, std::string sql)
      : connection_(connection), sql_(NumberedPlaceholders(sql)) {
    statement_ = &connection_.Prepared(sql_);
  }

  void BindNull(int index) override { Set(index, std::nullopt, 0); }
  void Bind(int index, int64_t value) override { Set(index, std::to_string(value), 0); }
  void Bind(int index, double value) override {
    if (!std::isfinite(value)) return BindNull(index);
    char buffer[32];
    std::snprintf(buffer, sizeof buffer, "%.17g", value);  // exact round trip
    Set(index, std::string(buffer), 0);
  }
  void Bind(int index, std::string_view text) override { Set(index, std::string(text), 0); }
  void BindBlob(int index, std::string_view bytes) override { Set(index, std::string(bytes), 1); }

  bool Step() override {
    if (!result_) Run();
    return ++row_ < PQntuples(result_.get());
  }
  int64_t Execute() override {
    Run();
    const char* changed = PQcmdTuples(result_.get());
    return changed && *changed ? std::atoll(changed) : 0;
  }

  int Columns() const override { return result_ ? PQnfields(result_.get()) : 0; }
  std::string ColumnName(int column) const override {
    const char* name = result_ ? PQfname(result_.get(), column) : nullptr;
    return name ? name : "";
  }
  Type ColumnType(int column) const override {
    if (IsNull(column)) return Type::kNull;
    switch (PQftype(result_.get(), column)) {  // pg_type OIDs
      case 16:    // bool
      case 20:    // int8
      case 21:    // int2
      case 23:    // int4
        return Type::kInteger;
      case 700:   // float4
      case 701:   // float8
      case 1700:  // numeric
        return Type::kReal;
      case 17:  // bytea
        return Type::kBlob;
      default:
        return Type::kText;
    }
  }
  bool IsNull(int column) const override { return PQgetisnull(result_.get(), row_, column); }
  int64_t Int(int column) const override {
    if (IsNull(column)) return 0;
    const char* value = PQgetvalue(result_.get(), row_, column);
    if (PQftype(result_.get(), column) == 16) return *value == 't';  // bool
    return std::atoll(value);
  }
  double Double(int column) const override {
    if (IsNull(column)) return 0.0;
    const std::string text = PQgetvalue(result_.get(), row_, column);
    if (text == "NaN") return NAN;
    if (text == "Infinity") return INFINITY;
    if (text == "-Infinity") return -INFINITY;
    return std::strtod(text.c_str(), nullptr);
  }
  std::string Text(int column) const override {
    return IsNull(column) ? std::string() : std::string(PQgetvalue(result_.get(), row_, column));
  }
  std::string Blob(int column) const override {
    if (IsNull(column)) return {};
    const char* value = PQgetvalue(result_.get(), row_, column);
    return PQftype(result_.get(), column) == 17 /* bytea */ ? DecodeBytea(value)
                                                            : std::string(value);
  }

 private:
  void Set(int index, std::optional<std::string> value, int format) {
    if (result_) {  // binding after a run starts the next run
      result_.reset();
      row_ = -1;
    }
    if (index < 1) throw DatabaseError(connection_.name() + ": parameter index < 1", "", false);
    if (static_cast<int>(values_.size()) < index) {
      values_.resize(index);
      formats_.resize(index, 0);
    }
    values_[index - 1] = std::move(value);
    formats_[index - 1] = format;
  }

  void Run() {
    result_.reset();
    row_ = -1;
    std::vector<const char*> values(values_.size());
    std::vector<int> lengths(values_.size());
    for (size_t k = 0; k < values_.size(); ++k) {
      values[k] = values_[k] ? values_[k]->data() : nullptr;
      lengths[k] = values_[k] ? static_cast<int>(values_[k]->size()) : 0;
    }
    result_.reset(connection_.ExecPrepared(*statement_, static_cast<int>(values.size()),
                                           values.data(), lengths.data(), formats_.data(), sql_));
  }

  PostgresConnection& connection_;
  std::string sql_;
  const std::string* statement_ = nullptr;
  std::vector<std::optional<std::string>> values_;
  std::vector<int> formats_;
  Result result_;
  int row_ = -1;
};

}  // namespace

PostgresConnection::PostgresConnection(const std::string& address, ServerTimeouts timeouts)
    : name_(RedactedAddress(address)) {
  CheckStoreAddress(address);
  Connect(address, timeouts);
  ApplyTimeouts(timeouts);
}

PostgresConnection::~PostgresConnection() {
  if (conn_) PQfinish(conn_);
}

void PostgresConnection::Connect(const std::string& address, const ServerTimeouts& timeouts) {
  // Armsig's defaults first, the address last: what the address sets wins (libpq takes the
  // last value of a keyword, and expands the address given as dbname into its parameters).
  const std::string connect_s = std::to_string(std::max(timeouts.connect_s, 2));
  std::vector<const char*> keys, values;
  auto add = [&](const char* key, const char* value) {
    keys.push_back(key);
    values.push_back(value);
  };
  if (!std::getenv("PGCONNECT_TIMEOUT")) add("connect_timeout", connect_s.c_str());
  add("keepalives", "1");
  add("keepalives_idle", "30");
  add("keepalives_interval", "10");
  add("keepalives_count", "3");
  add("tcp_user_timeout", "60000");
  add("dbname", address.c_str());
  add(nullptr, nullptr);
  conn_ = PQconnectdbParams(keys.data(), values.data(), /*expand_dbname=*/1);
  if (!conn_ || PQstatus(conn_) != CONNECTION_OK) {
    const std::string why = Trimmed(conn_ ? PQerrorMessage(conn_) : "out of memory");
    if (conn_) PQfinish(conn_);
    conn_ = nullptr;
    // libpq checks some values only as it connects ("invalid integer value "x" for
    // connection option "port"", "invalid sslmode value"): the address's fault, not the
    // server's.
    if (why.rfind("invalid ", 0) == 0) {
      throw InputError({"--db", 0, 0, ""},
                       "not a usable PostgreSQL connection address: " + name_ + ": " + why);
    }
    throw DatabaseError(name_ + ": cannot connect: " + why, "08001", false,
                        /*connection_lost=*/true);
  }
  // The socket in non-blocking mode: every wait is a poll() with the client's deadline.
  if (PQsetnonblocking(conn_, 1) != 0) Lost(Trimmed(PQerrorMessage(conn_)), "connect");
}

void PostgresConnection::ApplyTimeouts(const ServerTimeouts& timeouts) {
  statement_ms_ = timeouts.statement_ms;  // the client's wait for this first look
  // A timeout the user set (the address's options, PGOPTIONS, the role, the database, the
  // server's configuration) is kept; armsig sets its own where the server has its default.
  std::string set = "SET client_min_messages = warning";
  statement_timeout_ours_ = false;
  {
    auto s = Prepare(
        "SELECT name, setting, source FROM pg_settings WHERE name IN ('statement_timeout', "
        "'lock_timeout')");
    while (s->Step()) {
      const std::string name = s->Text(0);
      const bool ours = s->Text(2) == "default";
      const int wanted = name == "statement_timeout" ? timeouts.statement_ms : timeouts.lock_ms;
      if (ours) set += fmt::format("; SET {} = {}", name, std::max(wanted, 0));
      if (name == "statement_timeout") {
        statement_timeout_ours_ = ours;
        statement_ms_ = ours ? std::max(wanted, 0) : static_cast<int>(s->Int(1));
      }
    }
  }
  Exec(set);
}

void PostgresConnection::SetStatementTimeout(int ms) {
  if (!statement_timeout_ours_ || ms == statement_ms_) return;
  Exec(fmt::format("SET statement_timeout = {}", std::max(ms, 0)));
  statement_ms_ = std::max(ms, 0);
}

std::chrono::milliseconds PostgresConnection::ClientWait() const {
  if (statement_ms_ <= 0) return std::chrono::milliseconds::zero();
  const int grace = std::clamp(statement_ms_ / 4, 1000, 10000);
  return std::chrono::milliseconds(int64_t{statement_ms_} + grace);
}

void PostgresConnection::Lost(const std::string& why, std::string_view what) {
  if (conn_) PQfinish(conn_);  // the server ends the session (and its transaction) itself
  conn_ = nullptr;
  throw DatabaseError(fmt::format("{}: {} ({})", name_, why, what), "08006", false,
                      /*connection_lost=*/true);
}

void PostgresConnection::ThrowResult(pg_result* result, std::string_view what) {
  std::string state, message;
  if (result) {
    if (const char* s = PQresultErrorField(result, PG_DIAG_SQLSTATE)) state = s;
    message = PQresultErrorMessage(result);
    PQclear(result);
  }
  if (message.empty() && conn_) message = PQerrorMessage(conn_);
  message = Trimmed(message);
  const bool lost = !conn_ || PQstatus(conn_) == CONNECTION_BAD || ServerWentAway(state);
  if (lost && conn_) {
    PQfinish(conn_);
    conn_ = nullptr;
  }
  if (state == "57014")
    message += " (statement_timeout; options=-c statement_timeout=… in the address sets it)";
  throw DatabaseError(fmt::format("{}: {} ({}{})", name_, message, what,
                                  state.empty() ? "" : ", SQLSTATE " + state),
                      state, Transient(state), lost);
}

void PostgresConnection::WaitForSocket(bool write, Clock::time_point deadline,
                                       std::string_view what) {
  pollfd p{PQsocket(conn_), static_cast<short>(write ? POLLOUT : POLLIN), 0};
  for (;;) {
    int wait_ms = -1;
    if (deadline != Clock::time_point::max()) {
      const auto left =
          std::chrono::duration_cast<std::chrono::milliseconds>(deadline - Clock::now()).count();
      if (left <= 0) {
        const auto wait = ClientWait();
        Lost(fmt::format("the server did not answer within {:.0f} s (statement_timeout {:.0f} s "
                         "and {:.0f} s of grace): it is stopped, overloaded or cut off; the "
                         "connection is closed and what the statement did is unknown",
                         wait.count() / 1000.0, statement_ms_ / 1000.0,
                         (wait.count() - statement_ms_) / 1000.0),
             what);
      }
      wait_ms = static_cast<int>(std::min<int64_t>(left, 1000));
    }
    const int n = ::poll(&p, 1, wait_ms);
    if (n > 0) return;
    if (n < 0 && errno != EINTR) Lost(std::string("poll: ") + std::strerror(errno), what);
  }
}

pg_result* PostgresConnection::Await(std::string_view what) {
  const auto wait = ClientWait();
  const auto deadline = wait.count() > 0 ? Clock::now() + wait : Clock::time_point::max();
  for (int f; (f = PQflush(conn_)) != 0;) {
    if (f < 0) Lost(Trimmed(PQerrorMessage(conn_)), what);
    WaitForSocket(true, deadline, what);
    if (!PQconsumeInput(conn_)) Lost(Trimmed(PQerrorMessage(conn_)), what);
  }
  Result last, error;
  for (;;) {
    while (PQisBusy(conn_)) {
      WaitForSocket(false, deadline, what);
      if (!PQconsumeInput(conn_)) Lost(Trimmed(PQerrorMessage(conn_)), what);
    }
    PGresult* r = PQgetResult(conn_);
    if (!r) break;
    const auto status = PQresultStatus(r);
    if (status != PGRES_COMMAND_OK && status != PGRES_TUPLES_OK && status != PGRES_EMPTY_QUERY) {
      if (!error)
        error.reset(r);  // the first error; the rest of the command did not run
      else
        PQclear(r);
    } else {
      last.reset(r);
    }
  }
  if (error) ThrowResult(error.release(), what);
  if (!last) {
    if (PQstatus(conn_) == CONNECTION_BAD) Lost(Trimmed(PQerrorMessage(conn_)), what);
    ThrowResult(nullptr, what);
  }
  return last.release();
}

pg_result* PostgresConnection::ExecPrepared(const std::string& statement, int count,
                                            const char* const* values, const int* lengths,
                                            const int* formats, const std::string& sql) {
  if (!conn_) Lost("the connection to the server was lost earlier", sql);
  if (!PQsendQueryPrepared(conn_, statement.c_str(), count, values, lengths, formats, 0))
    ThrowResult(nullptr, sql);
  return Await(sql);
}

const std::string& PostgresConnection::Prepared(const std::string& numbered_sql) {
  auto it = prepared_.find(numbered_sql);
  if (it != prepared_.end()) return it->second;
  if (!conn_) Lost("the connection to the server was lost earlier", numbered_sql);
  const std::string statement = "armsig_" + std::to_string(++prepared_count_);
  if (!PQsendPrepare(conn_, statement.c_str(), numbered_sql.c_str(), 0, nullptr))
    ThrowResult(nullptr, numbered_sql);
  Result r(Await(numbered_sql));
  return prepared_.emplace(numbered_sql, statement).first->second;
}

std::unique_ptr<Statement> PostgresConnection::Prepare(std::string_view sql) {
  return std::make_unique<PostgresStatement>(*this, std::string(sql));
}

void PostgresConnection::Exec(std::string_view sql) {
  if (!conn_) Lost("the connection to the server was lost earlier", sql);
  if (!PQsendQuery(conn_, std::string(sql).c_str())) ThrowResult(nullptr, sql);
  Result r(Await(sql));
}

void PostgresConnection::Begin(TransactionKind kind) {
  Exec(kind == TransactionKind::kWrite ? "BEGIN ISOLATION LEVEL READ COMMITTED"
                                       : "BEGIN ISOLATION LEVEL REPEATABLE READ READ ONLY");
}

void PostgresConnection::Commit() { Exec("COMMIT"); }

void PostgresConnection::Rollback() {
  if (!conn_) return;  // the server rolled the transaction back when the connection ended
  Exec("ROLLBACK");
}

}  // namespace armsig::db
