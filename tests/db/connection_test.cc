// The two backends behind db::Connection, tested alike: SQLite (a temporary file) and
// PostgreSQL (the tests' own server, tests/support/postgres_server.h).
#include "db/connection.h"

#include <SQLiteCpp/Database.h>
#include <gtest/gtest.h>
#include <signal.h>

#include <chrono>
#include <cmath>
#include <filesystem>
#include <limits>

#include "core/error.h"
#include "db/database.h"
#include "db/postgres_connection.h"
#include "db/schema.h"
#include "db/sqlite_connection.h"
#include "support/postgres_server.h"
#include "test_support.h"

namespace armsig::db {
namespace {

using testing::TempDir;

class BothBackends : public ::testing::TestWithParam<Backend> {
 protected:
  void SetUp() override {
    if (GetParam() == Backend::kSqlite) {
      sqlite_.emplace(dir_.File("t.db"), SQLite::OPEN_READWRITE | SQLite::OPEN_CREATE);
      connection_ = std::make_unique<SqliteConnection>(*sqlite_, dir_.File("t.db"));
    } else {
      static int n = 0;
      const std::string uri =
          testing::PostgresServer::Shared().NewDatabase("connection_" + std::to_string(++n));
      connection_ = std::make_unique<PostgresConnection>(uri);
    }
  }
  Connection& c() { return *connection_; }
  std::string Blob() const { return GetParam() == Backend::kSqlite ? "BLOB" : "BYTEA"; }

  TempDir dir_;
  std::optional<SQLite::Database> sqlite_;
  std::unique_ptr<Connection> connection_;
};

// Every value comes back exactly: doubles to the last bit, int64 extremes, UTF-8 text,
// blobs with NUL bytes, NULL (and non-finite doubles stored as NULL).
TEST_P(BothBackends, ValuesRoundTripExactly) {
  c().Exec("CREATE TABLE v (i BIGINT, d DOUBLE PRECISION, t TEXT, b " + Blob() + ")");
  const double doubles[] = {1.0 / 3.0, -2.5e-300, 6.02214076e23, 0.1, 4.9e-324, -1e308};
  const int64_t ints[] = {std::numeric_limits<int64_t>::min(), -1, 0,
                          std::numeric_limits<int64_t>::max()};
  auto insert = c().Prepare("INSERT INTO v (i, d, t, b) VALUES (?, ?, ?, ?)");
  for (int k = 0; k < 6; ++k) {
    insert->Bind(1, ints[k % 4]);
    insert->Bind(2, doubles[k]);
    insert->Bind(3, std::string("Zürich ? 'quoted' \"x\" ") + std::to_string(k));
    insert->BindBlob(4, std::string("\0\x01\xff?", 4) + std::to_string(k));
    EXPECT_EQ(insert->Execute(), 1);
  }
  insert->BindNull(1);
  insert->Bind(2, std::numeric_limits<double>::quiet_NaN());
  insert->BindNull(3);
  insert->BindNull(4);
  insert->Execute();
  auto q = c().Prepare("SELECT i, d, t, b FROM v ORDER BY (t IS NULL), t");
  for (int k = 0; k < 6; ++k) {
    ASSERT_TRUE(q->Step()) << k;
    EXPECT_EQ(q->Int(0), ints[k % 4]);
    EXPECT_EQ(q->Double(1), doubles[k]);
    EXPECT_EQ(q->Text(2), std::string("Zürich ? 'quoted' \"x\" ") + std::to_string(k));
    EXPECT_EQ(q->Blob(3), std::string("\0\x01\xff?", 4) + std::to_string(k));
  }
  ASSERT_TRUE(q->Step());  // the row of NULLs, last
  for (int col = 0; col < 4; ++col) EXPECT_TRUE(q->IsNull(col)) << col;
  EXPECT_FALSE(q->Step());
}

TEST_P(BothBackends, PlaceholdersInsideQuotesAreText) {
  c().Exec("CREATE TABLE p (a TEXT, b TEXT)");
  auto insert = c().Prepare("INSERT INTO p (a, b) VALUES ('?', ?)");
  insert->Bind(1, "second");
  insert->Execute();
  auto q = c().Prepare("SELECT a, b FROM p WHERE b = ?");
  q->Bind(1, "second");
  ASSERT_TRUE(q->Step());
  EXPECT_EQ(q->Text(0), "?");
  EXPECT_EQ(q->Text(1), "second");
}

TEST_P(BothBackends, RebindingRunsTheStatementAgain) {
  c().Exec("CREATE TABLE r (x BIGINT)");
  auto insert = c().Prepare("INSERT INTO r (x) VALUES (?)");
  for (int k = 0; k < 5; ++k) {
    insert->Bind(1, k);
    insert->Execute();
  }
  auto q = c().Prepare("SELECT count(*), sum(x) FROM r WHERE x >= ?");
  q->Bind(1, 2);
  ASSERT_TRUE(q->Step());
  EXPECT_EQ(q->Int(0), 3);
  EXPECT_EQ(q->Int(1), 9);
  q->Bind(1, 4);
  ASSERT_TRUE(q->Step());
  EXPECT_EQ(q->Int(0), 1);
}

TEST_P(BothBackends, UncommittedTransactionRollsBack) {
  c().Exec("CREATE TABLE t (x BIGINT)");
  {
    Transaction tx(c(), TransactionKind::kWrite);
    auto s = c().Prepare("INSERT INTO t (x) VALUES (1)");
    s->Execute();
  }  // no Commit
  EXPECT_EQ(c().QueryInt("SELECT count(*) FROM t"), 0);
  {
    Transaction tx(c(), TransactionKind::kWrite);
    c().Prepare("INSERT INTO t (x) VALUES (2)")->Execute();
    tx.Commit();
  }
  EXPECT_EQ(c().QueryInt("SELECT count(*) FROM t"), 1);
}

TEST_P(BothBackends, ConstraintViolationIsADatabaseErrorNotTransient) {
  c().Exec("CREATE TABLE u (x BIGINT PRIMARY KEY)");
  c().Prepare("INSERT INTO u (x) VALUES (1)")->Execute();
  try {
    c().Prepare("INSERT INTO u (x) VALUES (1)")->Execute();
    FAIL();
  } catch (const DatabaseError& e) {
    EXPECT_FALSE(e.transient());
    EXPECT_FALSE(e.code().empty());
  }
}

TEST(NumberedPlaceholders, NumbersOnlyPlaceholdersOutsideQuotes) {
  EXPECT_EQ(NumberedPlaceholders("SELECT ? , '?', \"?\", ?"), "SELECT $1 , '?', \"?\", $2");
  EXPECT_EQ(NumberedPlaceholders("x = 'it''s ?' AND y = ?"), "x = 'it''s ?' AND y = $1");
  // SQLite's rules: ?NNN is parameter NNN; a bare ? the largest so far plus one.
  EXPECT_EQ(NumberedPlaceholders("a = ?1 OR b = ?1 OR c = ?"), "a = $1 OR b = $1 OR c = $2");
  EXPECT_EQ(NumberedPlaceholders("a = ?3, b = ?, c = ?12"), "a = $3, b = $4, c = $12");
}

// ?NNN means the same parameter on both backends (checked against what each returns).
TEST_P(BothBackends, NumberedPlaceholdersNameOneParameterInSeveralPlaces) {
  auto s = c().Prepare("SELECT CAST(?1 AS BIGINT) + CAST(?1 AS BIGINT), CAST(? AS BIGINT)");
  s->Bind(1, int64_t{20});
  s->Bind(2, int64_t{3});
  ASSERT_TRUE(s->Step());
  EXPECT_EQ(s->Int(0), 40);
  EXPECT_EQ(s->Int(1), 3);
}

// Column names and value types are read alike: integers, reals, text, NULL.
TEST_P(BothBackends, ColumnNamesAndTypes) {
  auto s = c().Prepare("SELECT CAST(7 AS BIGINT) AS i, CAST(0.5 AS DOUBLE PRECISION) AS d, "
                       "'x' AS t, NULL AS n");
  ASSERT_TRUE(s->Step());
  ASSERT_EQ(s->Columns(), 4);
  const char* names[] = {"i", "d", "t", "n"};
  const Statement::Type types[] = {Statement::Type::kInteger, Statement::Type::kReal,
                                   Statement::Type::kText, Statement::Type::kNull};
  for (int k = 0; k < 4; ++k) {
    EXPECT_EQ(s->ColumnName(k), names[k]);
    EXPECT_EQ(s->ColumnType(k), types[k]) << names[k];
  }
}

TEST(PostgresUri, PasswordsNeverStandInAUriOrAMessage) {
  EXPECT_EQ(RedactedAddress("postgresql://job:s3cret@db.plant:5432/armsig"),
            "postgresql://job@db.plant:5432/armsig");
  EXPECT_EQ(RedactedAddress("postgresql:///armsig?host=/tmp&password=s3cret&user=a"),
            "postgresql:///armsig?host=/tmp&user=a");
  EXPECT_EQ(RedactedAddress("postgresql://db/armsig?sslmode=require"),
            "postgresql://db/armsig?sslmode=require");
  try {
    PostgresConnection c("postgresql://job:s3cret@localhost/armsig");
    FAIL();
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()).find("s3cret"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("PGPASSWORD"), std::string::npos);
  }
}

TEST(PostgresUri, AMalformedUriIsAnInputErrorAndAMissingServerADatabaseError) {
  try {
    PostgresConnection c("postgresql://[::1/armsig");
    FAIL() << "an unterminated IPv6 host was accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("not a PostgreSQL connection URI"), std::string::npos)
        << e.what();
  }
  // Values libpq checks only when it connects: still the user's, not the server's.
  try {
    PostgresConnection c("postgresql://localhost:notaport/armsig");
    FAIL() << "a port that is not a number was accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("notaport"), std::string::npos) << e.what();
  }
  try {
    PostgresConnection c("postgresql:///armsig?bogus_parameter=1");
    FAIL() << "an unknown connection parameter was accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("bogus_parameter"), std::string::npos) << e.what();
  }
  // Well formed, but nothing listens there: the server's side, not a typo.
  const auto dir = std::filesystem::temp_directory_path() / "armsig-no-server-here";
  try {
    PostgresConnection c("postgresql:///armsig?host=" + dir.string() + "&connect_timeout=2");
    FAIL() << "connected to a server that does not exist";
  } catch (const InputError& e) {
    FAIL() << "a missing server reported as the user's input: " << e.what();
  } catch (const DatabaseError& e) {
    EXPECT_NE(std::string(e.what()).find("cannot connect"), std::string::npos) << e.what();
  }
}

// Every spelling of a password key that libpq reads is refused before anything connects,
// and no message shows the secret: percent-encoded keys, other cases, sslpassword, and
// key/value strings (quoted values, spaces around '=').
TEST(PostgresAddress, EveryEncodedPasswordKeyIsRefusedAndNeverEchoed) {
  const std::string secret = "Tr0ub4dor";
  for (const std::string& address :
       {"postgresql://db.plant/armsig?pass%77ord=" + secret,
        "postgresql://db.plant/armsig?%70assword=" + secret,
        "postgresql://db.plant/armsig?%70%61%73%73%77%6f%72%64=" + secret,
        "postgresql://db.plant/armsig?sslmode=require&PASSWORD=" + secret,
        "postgresql://db.plant/armsig?sslpassword=" + secret,
        "postgresql://db.plant/armsig?ssl%70assword=" + secret,
        "postgresql://job:" + secret + "@db.plant/armsig",
        "postgres://job:" + secret + "@db.plant:5432/armsig?sslmode=require",
        "host=db.plant password=" + secret + " dbname=armsig",
        "host=db.plant password = '" + secret + " x' dbname=armsig",
        "host=db.plant dbname=armsig sslpassword=" + secret,
        "  host=db.plant\tpassword=" + secret}) {
    try {
      CheckStoreAddress(address);
      ADD_FAILURE() << "accepted " << address;
    } catch (const InputError& e) {
      const std::string what = e.what();
      EXPECT_NE(what.find("password"), std::string::npos) << what;
      EXPECT_EQ(what.find(secret), std::string::npos) << what;
    }
    EXPECT_EQ(RedactedAddress(address).find(secret), std::string::npos) << address;
  }
  EXPECT_EQ(RedactedAddress("postgresql://db.plant/armsig?pass%77ord=x&sslmode=require"),
            "postgresql://db.plant/armsig?sslmode=require");
  EXPECT_EQ(RedactedAddress("host=db.plant password='a b' dbname=armsig"),
            "host=db.plant dbname=armsig");
}

// A libpq key/value string is a server address, never a file name: parsed, or refused.
// Anything else is a file; a file named like key=value is given as ./key=value.
TEST(PostgresAddress, KeyValueStringsAreServerAddressesNeverFiles) {
  EXPECT_TRUE(IsPostgresAddress("host=db.plant dbname=armsig"));
  EXPECT_TRUE(IsPostgresAddress(" dbname = armsig"));
  EXPECT_TRUE(IsPostgresAddress("postgresql:///armsig"));
  EXPECT_FALSE(IsPostgresAddress("armsig.db"));
  EXPECT_FALSE(IsPostgresAddress("./run=3.db"));
  EXPECT_FALSE(IsPostgresAddress("/data/lab 1.db"));
  EXPECT_NO_THROW(CheckStoreAddress("host=db.plant dbname=armsig sslmode=require"));
  EXPECT_NO_THROW(CheckStoreAddress("./run=3.db"));
  for (const char* bad :
       {"run=3.db", "host=db.plant dbname", "hots=db.plant dbname=x", "mysql://db.plant/armsig",
        "postgresql:/db.plant/armsig", "postgresql://[::1/armsig", "host=db port=five dbname=x"}) {
    try {
      CheckStoreAddress(bad, "--to");
      ADD_FAILURE() << "accepted " << bad;
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find("--to"), std::string::npos) << e.what();
    }
  }
}

// A key/value string connects like a URI; the store is named by it, without secrets.
TEST(PostgresAddress, AKeyValueStringOpensTheServersStore) {
  auto& server = testing::PostgresServer::Shared();
  std::string name;
  server.NewDatabase("keyvalue", &name);
  const std::string address = "host=" + server.socket_dir() +
                              " port=" + std::to_string(server.port()) + " dbname=" + name +
                              " user=" + server.superuser();
  Database store(address);
  EXPECT_EQ(store.backend(), Backend::kPostgres);
  EXPECT_EQ(store.path(), address);
  EXPECT_EQ(store.SchemaVersion(), LatestSchemaVersion());
}

// Armsig's limits when the address sets none; the address's own when it does.
TEST(PostgresTimeouts, EachConnectionRunsUnderItsCommandsLimitsUnlessTheAddressSetsThem) {
  const std::string uri = testing::PostgresServer::Shared().NewDatabase("timeouts");
  ServerTimeouts limits;
  limits.statement_ms = 45000;
  limits.lock_ms = 7000;
  PostgresConnection ours(uri, limits);
  EXPECT_FALSE(ours.timeouts_from_user());
  EXPECT_EQ(ours.statement_timeout_ms(), 45000);
  auto show = [](Connection& c, const char* name) {
    auto s = c.Prepare(std::string("SELECT setting FROM pg_settings WHERE name = '") + name + "'");
    EXPECT_TRUE(s->Step());
    return s->Text(0);
  };
  EXPECT_EQ(show(ours, "statement_timeout"), "45000");
  EXPECT_EQ(show(ours, "lock_timeout"), "7000");
  PostgresConnection theirs(
      uri + "&options=-c%20statement_timeout%3D1500%20-c%20lock_timeout%3D900", limits);
  EXPECT_TRUE(theirs.timeouts_from_user());
  EXPECT_EQ(theirs.statement_timeout_ms(), 1500);
  EXPECT_EQ(show(theirs, "statement_timeout"), "1500");
  EXPECT_EQ(show(theirs, "lock_timeout"), "900");
}

// A server process that is stopped (SIGSTOP) takes the statement and never answers: the
// client gives up at statement_timeout and its grace (1 s + 1 s here), closes the
// connection and says so (connection_lost: the work may be retried); before, it waited for
// good.
TEST(PostgresTimeouts, AFrozenServerEndsTheStatementAtTheClientsDeadline) {
  const std::string uri = testing::PostgresServer::Shared().NewDatabase("frozen") +
                          "&options=-c%20statement_timeout%3D1000";
  PostgresConnection c(uri);
  const auto backend = static_cast<pid_t>(c.QueryInt("SELECT pg_backend_pid()"));
  ASSERT_EQ(::kill(backend, SIGSTOP), 0);
  const auto start = std::chrono::steady_clock::now();
  try {
    c.QueryInt("SELECT 1");
    ADD_FAILURE() << "a frozen server answered";
  } catch (const DatabaseError& e) {
    EXPECT_TRUE(e.connection_lost()) << e.what();
    EXPECT_TRUE(IsInfrastructureFault(e));
    EXPECT_NE(std::string(e.what()).find("did not answer within 2 s"), std::string::npos)
        << e.what();
  }
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  ::kill(backend, SIGCONT);
  EXPECT_GE(seconds, 1.9);
  EXPECT_LT(seconds, 10.0);
  // The connection is closed: later statements fail at once, a rollback is a no-op.
  EXPECT_THROW(c.QueryInt("SELECT 1"), DatabaseError);
  EXPECT_NO_THROW(c.Rollback());
}

INSTANTIATE_TEST_SUITE_P(Db, BothBackends, ::testing::Values(Backend::kSqlite, Backend::kPostgres),
                         [](const auto& info) {
                           return info.param == Backend::kSqlite ? "sqlite" : "postgres";
                         });

}  // namespace
}  // namespace armsig::db
