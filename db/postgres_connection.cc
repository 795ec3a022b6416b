#include "db/postgres_connection.h"

#include <fmt/format.h>
#include <postgresql/libpq-fe.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <vector>

#include "core/error.h"

namespace armsig::db {

namespace {

// SQLSTATEs of a lost race: serialization failure, deadlock, lock not available.
bool Transient(const std::string& sqlstate) {
  return sqlstate == "40001" || sqlstate == "40P01" || sqlstate == "55P03";
}

[[noreturn]] void ThrowResult(const std::string& name, PGresult* result, pg_conn* conn,
                              std::string_view what) {
  std::string state, message;
  if (result) {
    if (const char* s = PQresultErrorField(result, PG_DIAG_SQLSTATE)) state = s;
    message = PQresultErrorMessage(result);
    PQclear(result);
  } else {
    message = PQerrorMessage(conn);
  }
  while (!message.empty() && (message.back() == '\n' || message.back() == ' ')) message.pop_back();
  throw DatabaseError(
      fmt::format("{}: {} ({}{})", name, message, what, state.empty() ? "" : ", SQLSTATE " + state),
      state, Transient(state));
}

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
    PGresult* r =
        PQexecPrepared(connection_.raw(), statement_->c_str(), static_cast<int>(values.size()),
                       values.data(), lengths.data(), formats_.data(), 0);
    const auto status = r ? PQresultStatus(r) : PGRES_FATAL_ERROR;
    if (status != PGRES_TUPLES_OK && status != PGRES_COMMAND_OK)
      ThrowResult(connection_.name(), r, connection_.raw(), sql_);
    result_.reset(r);
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

bool IsPostgresUri(const std::string& text) {
  return text.rfind("postgresql://", 0) == 0 || text.rfind("postgres://", 0) == 0;
}

std::string RedactedUri(const std::string& uri) {
  std::string out = uri;
  // postgresql://user:secret@host → postgresql://user@host
  const size_t scheme = out.find("://");
  if (scheme != std::string::npos) {
    const size_t at = out.find('@', scheme + 3);
    const size_t slash = out.find('/', scheme + 3);
    if (at != std::string::npos && (slash == std::string::npos || at < slash)) {
      const size_t colon = out.find(':', scheme + 3);
      if (colon != std::string::npos && colon < at) out.erase(colon, at - colon);
    }
  }
  // …?password=secret&… → …?…
  for (size_t p; (p = out.find("password=")) != std::string::npos;) {
    const size_t end = out.find('&', p);
    out.erase(p, end == std::string::npos ? std::string::npos : end - p + 1);
  }
  while (!out.empty() && (out.back() == '&' || out.back() == '?')) out.pop_back();
  return out;
}

void CheckPostgresUri(const std::string& uri) {
  const std::string name = RedactedUri(uri);
  if (name != uri) {
    throw InputError({"--db", 0, 0, ""},
                     "the database URI carries a password; armsig takes credentials only from "
                     "where libpq looks for them (PGPASSWORD, ~/.pgpass, a service file), so "
                     "none stands on a command line or in a log: " +
                         name);
  }
  // A URI libpq cannot parse is the user's typo (exit 2), not an unreachable server.
  char* parse_error = nullptr;
  PQconninfoOption* options = PQconninfoParse(uri.c_str(), &parse_error);
  if (!options) {
    std::string why = parse_error ? parse_error : "out of memory";
    if (parse_error) PQfreemem(parse_error);
    while (!why.empty() && (why.back() == '\n' || why.back() == ' ')) why.pop_back();
    throw InputError({"--db", 0, 0, ""},
                     "not a PostgreSQL connection URI (postgresql://[user@]host[:port]/database"
                     "[?param=value…]): " + name + ": " + why);
  }
  // Values libpq checks only as it connects, checked here too: a port that is no number.
  std::string bad;
  for (const PQconninfoOption* o = options; o->keyword; ++o) {
    if (o->val && std::string(o->keyword) == "port") {
      const std::string port = o->val;
      for (const char c : port) {
        if ((c < '0' || c > '9') && c != ',') bad = port;
      }
    }
  }
  PQconninfoFree(options);
  if (!bad.empty()) {
    throw InputError({"--db", 0, 0, ""},
                     "not a usable PostgreSQL connection URI: " + name + ": the port '" + bad +
                         "' is not a number");
  }
}

PostgresConnection::PostgresConnection(const std::string& uri) : name_(RedactedUri(uri)) {
  CheckPostgresUri(uri);
  conn_ = PQconnectdb(uri.c_str());
  if (!conn_ || PQstatus(conn_) != CONNECTION_OK) {
    std::string why = conn_ ? PQerrorMessage(conn_) : "out of memory";
    while (!why.empty() && (why.back() == '\n' || why.back() == ' ')) why.pop_back();
    if (conn_) PQfinish(conn_);
    conn_ = nullptr;
    // libpq checks some values only as it connects ("invalid integer value "x" for
    // connection option "port"", "invalid sslmode value"): the URI's fault, not the server's.
    if (why.rfind("invalid ", 0) == 0) {
      throw InputError({"--db", 0, 0, ""}, "not a usable PostgreSQL connection URI: " + name_ +
                                               ": " + why);
    }
    throw DatabaseError(name_ + ": cannot connect: " + why, "08000", false);
  }
  Exec("SET client_min_messages = warning");
}

PostgresConnection::~PostgresConnection() {
  if (conn_) PQfinish(conn_);
}

const std::string& PostgresConnection::Prepared(const std::string& numbered_sql) {
  auto it = prepared_.find(numbered_sql);
  if (it != prepared_.end()) return it->second;
  const std::string statement = "armsig_" + std::to_string(prepared_.size() + 1);
  Result r(PQprepare(conn_, statement.c_str(), numbered_sql.c_str(), 0, nullptr));
  if (!r || PQresultStatus(r.get()) != PGRES_COMMAND_OK)
    ThrowResult(name_, r.release(), conn_, numbered_sql);
  return prepared_.emplace(numbered_sql, statement).first->second;
}

std::unique_ptr<Statement> PostgresConnection::Prepare(std::string_view sql) {
  return std::make_unique<PostgresStatement>(*this, std::string(sql));
}

void PostgresConnection::Exec(std::string_view sql) {
  Result r(PQexec(conn_, std::string(sql).c_str()));
  const auto status = r ? PQresultStatus(r.get()) : PGRES_FATAL_ERROR;
  if (status != PGRES_COMMAND_OK && status != PGRES_TUPLES_OK)
    ThrowResult(name_, r.release(), conn_, sql);
}

void PostgresConnection::Begin(TransactionKind kind) {
  Exec(kind == TransactionKind::kWrite ? "BEGIN ISOLATION LEVEL READ COMMITTED"
                                       : "BEGIN ISOLATION LEVEL REPEATABLE READ READ ONLY");
}

void PostgresConnection::Commit() { Exec("COMMIT"); }

void PostgresConnection::Rollback() { Exec("ROLLBACK"); }

}  // namespace armsig::db
