#include <gtest/gtest.h>

#include <filesystem>

#include "test_support.h"

namespace armsig::testing {

TEST(Cli, HelpListsEveryCommandOfTheSpec) {
  const auto r = RunArmsig("--help");
  EXPECT_EQ(r.exit_code, 0);
  for (const char* command : {"demo", "orient", "triangulate", "calibrate", "capture", "reduce",
                              "recalibrate", "import", "instrument", "db"}) {
    EXPECT_NE(r.out.find(std::string("  ") + command), std::string::npos) << command;
  }
  EXPECT_NE(r.out.find("--db"), std::string::npos);
}

TEST(Cli, VersionAndUsageErrors) {
  EXPECT_EQ(RunArmsig("--version").exit_code, 0);
  EXPECT_EQ(RunArmsig("").exit_code, 2);  // a command is required
  EXPECT_EQ(RunArmsig("no-such-command").exit_code, 2);
  EXPECT_EQ(RunArmsig("calibrate --model").exit_code, 2);
}

TEST(Cli, DbInfoCreatesTheFileAndReportsTheSchema) {
  TempDir dir;
  const auto r = RunArmsig("--db '" + dir.File("lab.db") + "' db info");
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("schema        v2"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("calibration_parameters"), std::string::npos);
  EXPECT_TRUE(std::filesystem::exists(dir.File("lab.db")));
}

TEST(Cli, DbPathComesFromTheEnvironmentThenTheWorkingDirectory) {
  TempDir dir;
  EXPECT_EQ(RunArmsig("db info", dir.path().string()).exit_code, 0);
  EXPECT_TRUE(std::filesystem::exists(dir.File("armsig.db")));
  setenv("ARMSIG_DB", dir.File("env.db").c_str(), 1);
  EXPECT_EQ(RunArmsig("db info", dir.path().string()).exit_code, 0);
  unsetenv("ARMSIG_DB");
  EXPECT_TRUE(std::filesystem::exists(dir.File("env.db")));
}

TEST(Cli, DbExportWritesCsvAndRejectsUnknownTables) {
  TempDir dir;
  const std::string db = "--db '" + dir.File("lab.db") + "' ";
  const auto r = RunArmsig(db + "db export calibrations --csv");
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(r.out.rfind("id,robot_id,version,", 0), 0u) << r.out;
  const auto bad = RunArmsig(db + "db export nonsense --csv --out '" + dir.File("x.csv") + "'");
  EXPECT_EQ(bad.exit_code, 2);
  EXPECT_NE(bad.err.find("unknown table 'nonsense'"), std::string::npos);
  EXPECT_FALSE(std::filesystem::exists(dir.File("x.csv")));
}

TEST(Cli, DbThatIsNotADatabaseIsAnInputError) {
  TempDir dir;
  WriteText(dir.File("junk.db"), std::string(8192, 'j'));
  const auto r = RunArmsig("--db '" + dir.File("junk.db") + "' db info");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("junk.db"), std::string::npos);
}

}  // namespace armsig::testing

#include "workflows/builtin_models.h"

namespace armsig::testing {

TEST(BuiltinModels, DemoPumaIsTheShippedModelFile) {
  EXPECT_EQ(std::string(workflows::kPuma760Yaml), ReadText(SourcePath("models/puma760.yaml")));
}

}  // namespace armsig::testing
