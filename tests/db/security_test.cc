// Credentials and TLS with a real server (the tests' own, listening on loopback TCP with
// TLS beside its socket): a password is taken only from where libpq looks for it, never
// from the URI, and never shows in a message; the URI's sslmode is honoured.
#include <gtest/gtest.h>
#include <sys/stat.h>

#include <cstdlib>
#include <fstream>

#include "core/error.h"
#include "db/postgres_connection.h"
#include "support/postgres_server.h"
#include "test_support.h"

namespace armsig::testing {
namespace {

constexpr const char* kSecret = PostgresServer::kTlsPassword;

// A ~/.pgpass-style file for the TLS role, named by PGPASSFILE for this test.
class PasswordFile {
 public:
  PasswordFile(const TempDir& dir, int port, const std::string& password)
      : path_(dir.File("pgpass")) {
    std::ofstream(path_) << "localhost:" << port << ":*:" << PostgresServer::kTlsRole << ":"
                         << password << "\n";
    ::chmod(path_.c_str(), 0600);  // libpq ignores a password file others can read
    ::setenv("PGPASSFILE", path_.c_str(), 1);
  }
  ~PasswordFile() { ::unsetenv("PGPASSFILE"); }

 private:
  std::string path_;
};

class Security : public ::testing::Test {
 protected:
  void SetUp() override {
    auto& server = PostgresServer::Shared();
    static std::string name;  // one database per test process (the server has the role)
    if (name.empty()) {
      server.NewDatabase("security", &name);
      server.Psql(name, std::string("GRANT ALL ON SCHEMA public TO ") + PostgresServer::kTlsRole);
    }
    database_ = name;
  }
  PostgresServer& server() { return PostgresServer::Shared(); }
  std::string database_;
};

bool OverTls(db::PostgresConnection& c) {
  auto s = c.Prepare("SELECT ssl FROM pg_stat_ssl WHERE pid = pg_backend_pid()");
  return s->Step() && s->Text(0) == "t";
}

}  // namespace

// The password from the password file; the connection the URI asked for is encrypted.
TEST_F(Security, PasswordFromThePasswordFileAndTlsAsTheUriAsks) {
  TempDir dir;
  PasswordFile file(dir, server().port(), kSecret);
  db::PostgresConnection c(server().TlsUri(database_, "require"));
  EXPECT_TRUE(OverTls(c));
  EXPECT_EQ(c.name().find(kSecret), std::string::npos);
}

// verify-full checks the server's certificate against the root the URI names: the
// server's own passes, another one fails, and the message says why without the password.
TEST_F(Security, VerifyFullChecksTheCertificateAgainstTheGivenRoot) {
  TempDir dir;
  PasswordFile file(dir, server().port(), kSecret);
  db::PostgresConnection good(server().TlsUri(database_, "verify-full") +
                              "&sslrootcert=" + server().certificate_path());
  EXPECT_TRUE(OverTls(good));
  ASSERT_EQ(
      std::system(("openssl req -x509 -newkey rsa:2048 -nodes -days 1 -subj /CN=localhost "
                   "-keyout '" +
                   dir.File("other.key") + "' -out '" + dir.File("other.crt") + "' 2>/dev/null")
                      .c_str()),
      0);
  try {
    db::PostgresConnection bad(server().TlsUri(database_, "verify-full") +
                               "&sslrootcert=" + dir.File("other.crt"));
    ADD_FAILURE() << "connected with a certificate the root did not sign";
  } catch (const db::DatabaseError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("certificate verify failed"), std::string::npos) << what;
    EXPECT_EQ(what.find(kSecret), std::string::npos) << what;
  }
}

// The server admits the role only over TLS: sslmode=disable is refused, naming the URI.
TEST_F(Security, WithoutTlsTheServerRefusesTheRole) {
  TempDir dir;
  PasswordFile file(dir, server().port(), kSecret);
  try {
    db::PostgresConnection c(server().TlsUri(database_, "disable"));
    ADD_FAILURE() << "connected without TLS";
  } catch (const db::DatabaseError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("no encryption"), std::string::npos) << what;
    EXPECT_NE(what.find("sslmode=disable"), std::string::npos) << what;
    EXPECT_EQ(what.find(kSecret), std::string::npos) << what;
  }
}

// A wrong password (from the environment) fails authentication; neither password shows.
TEST_F(Security, AWrongPasswordFailsWithoutShowingIt) {
  ::setenv("PGPASSWORD", "wrong-Staple-Password", 1);
  try {
    db::PostgresConnection c(server().TlsUri(database_, "require"));
    ADD_FAILURE() << "connected with a wrong password";
  } catch (const db::DatabaseError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("password authentication failed"), std::string::npos) << what;
    EXPECT_EQ(what.find("wrong-Staple-Password"), std::string::npos) << what;
    EXPECT_EQ(what.find(kSecret), std::string::npos) << what;
  }
  ::unsetenv("PGPASSWORD");
}

// A password in the URI (user:password@ or ?password=) is refused before any connection,
// on the command line too (exit 2), and the message shows the URI without it.
TEST_F(Security, APasswordInTheUriIsRefusedAndNeverEchoed) {
  const std::string port = std::to_string(server().port());
  for (const std::string& uri :
       {"postgresql://armsig_tls:" + std::string(kSecret) + "@localhost:" + port + "/" + database_,
        "postgresql://armsig_tls@localhost:" + port + "/" + database_ +
            "?sslmode=require&password=" + kSecret}) {
    try {
      db::PostgresConnection c(uri);
      ADD_FAILURE() << "accepted a password in the URI";
    } catch (const InputError& e) {
      const std::string what = e.what();
      EXPECT_NE(what.find("carries a password"), std::string::npos) << what;
      EXPECT_EQ(what.find(kSecret), std::string::npos) << what;
      EXPECT_NE(what.find("postgresql://armsig_tls@localhost:" + port + "/" + database_),
                std::string::npos)
          << what;
    }
    const auto r = RunArmsig("--db '" + uri + "' db info");
    EXPECT_EQ(r.exit_code, 2) << r.err;
    EXPECT_EQ(r.err.find(kSecret), std::string::npos) << r.err;
    EXPECT_EQ(r.out.find(kSecret), std::string::npos) << r.out;
  }
}

}  // namespace armsig::testing
