// A controller's login: from the lab's credentials file (its owner's alone) or from the
// environment, refused with the file, line or variable named and never the secret itself.
#include "io/credentials.h"

#include <gtest/gtest.h>
#include <sys/stat.h>

#include <cstdlib>

#include "core/error.h"
#include "test_support.h"

namespace armsig::io {
namespace {

constexpr const char* kSecret = "s3cr3t-Pa55";

class CredentialsFile : public ::testing::Test {
 protected:
  void SetUp() override {
    ::unsetenv(kUserVariable);
    ::unsetenv(kPasswordVariable);
  }
  void TearDown() override { SetUp(); }
  std::string Write(const std::string& text, mode_t mode = 0600) {
    const std::string path = dir_.File("credentials.yaml");
    testing::WriteText(path, text);
    ::chmod(path.c_str(), mode);
    return path;
  }
  std::string Refusal(const ControllerConfig& c) {
    try {
      LoadCredentials(c);
    } catch (const InputError& e) {
      EXPECT_EQ(std::string(e.what()).find(kSecret), std::string::npos) << e.what();
      return e.what();
    }
    ADD_FAILURE() << "accepted";
    return "";
  }
  testing::TempDir dir_;
};

TEST_F(CredentialsFile, TheFileGivesUserAndPassword) {
  ControllerConfig c;
  c.credentials_path = Write(std::string("user: armsig\npassword: ") + kSecret + "\n");
  const auto login = LoadCredentials(c);
  ASSERT_TRUE(login);
  EXPECT_EQ(login->user(), "armsig");
  EXPECT_EQ(login->password(), kSecret);
  EXPECT_EQ(login->Describe(), "user armsig (password from " + c.credentials_path + ")");
  EXPECT_EQ(login->Describe().find(kSecret), std::string::npos);
}

TEST_F(CredentialsFile, AFileOthersCanReadIsRefused) {
  ControllerConfig c;
  c.credentials_path = Write(std::string("user: armsig\npassword: ") + kSecret + "\n", 0644);
  const std::string e = Refusal(c);
  EXPECT_NE(e.find("can be read by others (mode 0644)"), std::string::npos) << e;
  EXPECT_NE(e.find("chmod 600"), std::string::npos) << e;
}

TEST_F(CredentialsFile, AMalformedFileIsNamedWithoutItsSecret) {
  ControllerConfig c;
  c.credentials_path = Write(std::string("user: armsig\npassword: [") + kSecret + "\n");
  EXPECT_NE(Refusal(c).find(c.credentials_path), std::string::npos);
  c.credentials_path = Write(std::string("user: armsig\npasword: ") + kSecret + "\n");
  EXPECT_NE(Refusal(c).find("unknown key 'pasword'"), std::string::npos);
  c.credentials_path = Write(std::string("user: armsig\npassword: {a: ") + kSecret + "}\n");
  EXPECT_NE(Refusal(c).find("expected 'password: TEXT'"), std::string::npos);
}

TEST_F(CredentialsFile, TheEnvironmentGivesBothOrNeither) {
  ControllerConfig c;
  EXPECT_FALSE(LoadCredentials(c));
  ::setenv(kUserVariable, "operator", 1);
  EXPECT_NE(Refusal(c).find("ARMSIG_CONTROLLER_USER is set but ARMSIG_CONTROLLER_PASSWORD is not"),
            std::string::npos);
  ::setenv(kPasswordVariable, kSecret, 1);
  const auto login = LoadCredentials(c);
  ASSERT_TRUE(login);
  EXPECT_EQ(login->user(), "operator");
  EXPECT_EQ(login->Describe(), "user operator (password from the environment)");
}

}  // namespace
}  // namespace armsig::io
