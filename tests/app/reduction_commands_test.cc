// CLI smoke tests of orient, triangulate and reduce; the behaviour is tested on the library
// calls in tests/workflows/network_test.cc and reduce_test.cc.
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

TEST(TriangulateCommand, MalformedAngleNamesLineAndColumn) {
  TempDir dir;
  WriteText(dir.File("obs.csv"), "point,station,hz_gon,v_gon\nP,1,10,100\nP,2,2O,100\n");
  const auto r =
      RunArmsig("triangulate --stations " + Net("k06/stations.yaml") + " --observations '" +
                dir.File("obs.csv") + "' --out '" + dir.File("p.csv") + "'");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("obs.csv:3:3 (hz_gon)"), std::string::npos) << r.err;
}

TEST(ReduceCommand, UnknownSessionIsAnInputError) {
  TempDir dir;
  ASSERT_EQ(RunArmsig("--db '" + dir.File("lab.db") + "' db init").exit_code, 0);
  const auto r = RunArmsig("--db '" + dir.File("lab.db") + "' reduce --session 4");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("no session 4"), std::string::npos);
}

}  // namespace armsig::testing
