// The three roles of a plant's server as the README gives them
// (packaging/postgresql/armsig-roles.sql), through the binary: each role does its job, and
// what it may not do is refused by the server, exit 1 naming the table, nothing written.
#include <gtest/gtest.h>

#include "db/database.h"
#include "support/postgres_server.h"
#include "test_support.h"

namespace armsig::testing {
namespace {

TEST(ServerRoles, EachRoleDoesItsJobAndWhatItMayNotDoIsRefused) {
  TempDir dir;
  auto& server = PostgresServer::Shared();
  std::string name;
  const std::string owner = server.NewDatabase("roles", &name);
  ASSERT_EQ(RunArmsig("--db '" + owner + "' db init").exit_code, 0);
  const std::string script = ReadText(SourcePath("packaging/postgresql/armsig-roles.sql"));
  ASSERT_FALSE(script.empty());
  server.Psql(name, script);
  server.Psql(name, script);  // again: it can be run after every upgrade
  auto as = [&](const std::string& role) { return "--db '" + server.Uri(name, role) + "' "; };
  auto calibrations = [&] {
    db::Database db(owner, db::OpenMode::kMustExist);
    return db.connection().QueryInt("SELECT count(*) FROM calibrations");
  };
  auto refused = [](const CommandResult& r, const std::string& table) {
    EXPECT_EQ(r.exit_code, 1) << r.err << r.out;
    EXPECT_NE(r.err.find("permission denied for table " + table), std::string::npos) << r.err;
  };
  const std::string ur10 = SourcePath("models/ur10.yaml");
  const std::string data = DataPath("ur10-ipa/series_C-measurements_random_poses.csv");
  const std::string nightly =
      "recalibrate --robot ur10 --params geometric --select 300 --residual-model off "
      "--max-validation-mean-mm 0.6";

  // The capture role registers the robot and stores its measurements...
  auto r = RunArmsig(as("armsig_capture") + "robot add ur10 --model '" + ur10 + "'");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  r = RunArmsig(as("armsig_capture") + "import poses '" + data + "' --preset ur-ipa --robot ur10");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  // ...but stores no parameter set and queues no job.
  refused(RunArmsig(as("armsig_capture") + nightly), "calibrations");
  refused(RunArmsig(as("armsig_capture") + "schedule recalibrate --robot ur10"), "jobs");
  EXPECT_EQ(calibrations(), 0);

  // The job role recalibrates (directly and through the queue) and rolls back...
  r = RunArmsig(as("armsig_job") + nightly);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  r = RunArmsig(as("armsig_job") + "schedule recalibrate --robot ur10 --params geometric --select "
                                   "300 --residual-model off --max-validation-mean-mm 0.6 --force");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  r = RunArmsig(as("armsig_job") + "worker --once");
  ASSERT_EQ(r.exit_code, 0) << r.err << r.out;
  EXPECT_EQ(calibrations(), 2);
  r = RunArmsig(as("armsig_job") + "activate --robot ur10 --version 1");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  // ...but stores no measurements.
  refused(RunArmsig(as("armsig_job") + "import poses '" + data +
                    "' --preset ur-ipa --robot ur10 --allow-duplicate"),
          "sessions");

  // The report role reads everything and writes nothing.
  r = RunArmsig(as("armsig_report") + "versions --robot ur10");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("* v1"), std::string::npos) << r.out;
  r = RunArmsig(as("armsig_report") + "export --robot ur10 --format json --out '" +
                dir.File("sig.json") + "'");
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(RunArmsig(as("armsig_report") + "sessions").exit_code, 0);
  EXPECT_EQ(RunArmsig(as("armsig_report") + "jobs").exit_code, 0);
  refused(RunArmsig(as("armsig_report") + nightly + " --force"), "calibrations");
  refused(RunArmsig(as("armsig_report") + "robot add puma --model '" +
                    SourcePath("models/puma760.yaml") + "'"),
          "robots");
  EXPECT_EQ(calibrations(), 2);
}

}  // namespace
}  // namespace armsig::testing
