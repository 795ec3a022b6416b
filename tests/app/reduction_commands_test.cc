#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "db/database.h"
#include "io/csv.h"
#include "test_support.h"

namespace armsig::testing {
namespace {

std::string Net(const std::string& f) { return "'" + DataPath("networks/" + f) + "'"; }

}  // namespace

TEST(OrientCommand, K06WithScaleBarsWritesStationsAndReport) {
  TempDir dir;
  std::string bars;
  std::ifstream in(DataPath("networks/k06/scale_bars.txt"));
  for (std::string line; std::getline(in, line);) bars += " --scale-bar " + line;
  const auto r = RunArmsig("orient --observations " + Net("k06/observations.csv") + bars +
                           " --scale-bar-sigma-mm 0.005 --out '" + dir.File("st.yaml") +
                           "' --points '" + dir.File("pts.csv") + "'");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("185 degrees of freedom"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("sigma0 a posteriori 1.163"), std::string::npos);
  // The written stations triangulate the targets again.
  const auto t = RunArmsig("triangulate --stations '" + dir.File("st.yaml") + "' --observations " +
                           Net("k06/observations.csv") + " --out '" + dir.File("tri.csv") + "'");
  ASSERT_EQ(t.exit_code, 0) << t.err;
  const auto table = io::ReadCsvFile(dir.File("tri.csv"));
  EXPECT_EQ(table.rows().size(), 54u);
}

TEST(OrientCommand, UnsolvableNetworkIsRefusedAndNothingWritten) {
  TempDir dir;
  // k06's angles without its 11 slope distances and without the scale bars: no scale.
  const auto table = io::ReadCsvFile(DataPath("networks/k06/observations.csv"));
  std::string angles = "point,station,hz_gon,v_gon\n";
  for (const auto& row : table.rows()) {
    angles +=
        row.fields[0] + "," + row.fields[1] + "," + row.fields[2] + "," + row.fields[3] + "\n";
  }
  WriteText(dir.File("angles.csv"), angles);
  const auto r = RunArmsig("orient --observations '" + dir.File("angles.csv") + "' --out '" +
                           dir.File("st.yaml") + "'");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("no scale"), std::string::npos) << r.err;
  EXPECT_FALSE(std::filesystem::exists(dir.File("st.yaml")));
}

TEST(OrientCommand, BadScaleBarAndUnknownStationAreInputErrors) {
  TempDir dir;
  auto r = RunArmsig("orient --observations " + Net("k06/observations.csv") +
                     " --scale-bar 1008-1180 --out '" + dir.File("st.yaml") + "'");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("expected A:B=LEN_MM"), std::string::npos) << r.err;
  r = RunArmsig("orient --observations " + Net("k06/observations.csv") +
                " --scale-bar 1008:9999=100 --out '" + dir.File("st.yaml") + "'");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("9999 is never observed"), std::string::npos) << r.err;
  EXPECT_FALSE(std::filesystem::exists(dir.File("st.yaml")));
}

TEST(TriangulateCommand, ObservationFromAnUnknownStationNamesTheLine) {
  TempDir dir;
  WriteText(dir.File("obs.csv"), "point,station,hz_gon,v_gon\nP,1,10,100\nP,9,20,100\n");
  const auto r =
      RunArmsig("triangulate --stations " + Net("k06/stations.yaml") + " --observations '" +
                dir.File("obs.csv") + "' --out '" + dir.File("p.csv") + "'");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("obs.csv:3"), std::string::npos) << r.err;
  EXPECT_FALSE(std::filesystem::exists(dir.File("p.csv")));
}

TEST(TriangulateCommand, OneRayPointsAreReportedNotInvented) {
  TempDir dir;
  WriteText(dir.File("obs.csv"), "point,station,hz_gon,v_gon\nLONE,1,10,100\n");
  const auto r =
      RunArmsig("triangulate --stations " + Net("k06/stations.yaml") + " --observations '" +
                dir.File("obs.csv") + "' --out '" + dir.File("p.csv") + "'");
  EXPECT_EQ(r.exit_code, 1);  // no point at all could be intersected: a failure, not a result
  EXPECT_NE(r.err.find("point LONE not intersected: one ray"), std::string::npos) << r.err;
  const auto table = io::ReadCsvFile(dir.File("p.csv"));
  ASSERT_EQ(table.rows().size(), 1u);
  EXPECT_TRUE(table.Text(table.rows()[0], table.Column("x_mm")).empty());
  EXPECT_NE(table.Text(table.rows()[0], table.Column("status")).find("one_ray"), std::string::npos);
}

TEST(TriangulateCommand, MalformedAngleNamesLineAndColumn) {
  TempDir dir;
  WriteText(dir.File("obs.csv"), "point,station,hz_gon,v_gon\nP,1,10,100\nP,2,2O,100\n");
  const auto r =
      RunArmsig("triangulate --stations " + Net("k06/stations.yaml") + " --observations '" +
                dir.File("obs.csv") + "' --out '" + dir.File("p.csv") + "'");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("obs.csv:3:3 (hz_gon)"), std::string::npos) << r.err;
}

TEST(ReduceCommand, ReducesASessionIdempotentlyAndMatchesTriangulate) {
  TempDir dir;
  const std::string db = "--db '" + dir.File("lab.db") + "' ";
  ASSERT_EQ(RunArmsig(db + "import observations " + Net("barta-phase_1-2TK/observations.csv") +
                      " --stations " + Net("barta-phase_1-2TK/stations.yaml"))
                .exit_code,
            0);
  for (int run = 0; run < 2; ++run) {
    const auto r = RunArmsig(db + "reduce --no-reject");
    ASSERT_EQ(r.exit_code, 0) << r.err;
    EXPECT_NE(r.out.find("18 points reduced"), std::string::npos) << r.out;
  }
  db::Database database(dir.File("lab.db"));
  EXPECT_EQ(database.sql().execAndGet("SELECT count(*) FROM points").getInt(), 18);  // not 36
  // Point 25 as published (GNU Gama), through the database path.
  SQLite::Statement q(database.sql(),
                      "SELECT x_mm, y_mm, z_mm, sx_mm FROM points WHERE point = '25'");
  ASSERT_TRUE(q.executeStep());
  const auto expected = io::ReadCsvFile(DataPath("networks/barta-phase_1-2TK/expected.csv"));
  for (const auto& row : expected.rows()) {
    if (expected.Text(row, 0) != "25") continue;
    EXPECT_NEAR(q.getColumn(0).getDouble(), expected.Number(row, 1), 5e-4);
    EXPECT_NEAR(q.getColumn(1).getDouble(), expected.Number(row, 2), 5e-4);
    EXPECT_NEAR(q.getColumn(2).getDouble(), expected.Number(row, 3), 5e-4);
    EXPECT_GT(q.getColumn(3).getDouble(), 0.0);
  }
}

TEST(ReduceCommand, UnknownSessionIsAnInputError) {
  TempDir dir;
  ASSERT_EQ(RunArmsig("--db '" + dir.File("lab.db") + "' db init").exit_code, 0);
  const auto r = RunArmsig("--db '" + dir.File("lab.db") + "' reduce --session 4");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("no session 4"), std::string::npos);
}

TEST(ImportObservations, RefusesUnknownStationsAndWritesNoRow) {
  TempDir dir;
  WriteText(dir.File("obs.csv"), "point,station,hz_gon,v_gon\nP,1,10,100\nP,X,20,100\n");
  const std::string db = "--db '" + dir.File("lab.db") + "' ";
  const auto r = RunArmsig(db + "import observations '" + dir.File("obs.csv") + "' --stations " +
                           Net("k06/stations.yaml"));
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("obs.csv:3"), std::string::npos) << r.err;
  if (std::filesystem::exists(dir.File("lab.db"))) {
    db::Database database(dir.File("lab.db"));
    EXPECT_EQ(database.sql().execAndGet("SELECT count(*) FROM sessions").getInt(), 0);
  }
}

}  // namespace armsig::testing
