// Observations files into sessions and stored sessions reduced (workflows/reduce).
#include "workflows/reduce.h"

#include <gtest/gtest.h>

#include "core/error.h"
#include "db/store.h"
#include "io/csv.h"
#include "test_support.h"

namespace armsig::workflows {
namespace {

using testing::DataPath;
using testing::TempDir;
using testing::WriteText;

// GNU Gama's barta network, imported as a session and reduced twice: the same 18 points
// (a rerun replaces them), point 25 where gama-local put it.
TEST(ReduceSessions, ImportedRealNetworkReducesIdempotentlyToGnuGama) {
  TempDir dir;
  db::Database database(dir.File("lab.db"));
  ImportObservationsOptions o;
  o.file = DataPath("networks/barta-phase_1-2TK/observations.csv");
  o.stations = DataPath("networks/barta-phase_1-2TK/stations.yaml");
  const auto imported = ImportObservations(database, o);
  EXPECT_EQ(imported.observations, 52u);
  for (int run = 0; run < 2; ++run) {
    const auto summaries = ReduceSessions(database, 0, /*reject_blunders=*/false);
    ASSERT_EQ(summaries.size(), 1u);
    EXPECT_EQ(summaries[0].reduced, 18);
    EXPECT_EQ(summaries[0].failed, 0);
  }
  EXPECT_EQ(database.sql().execAndGet("SELECT count(*) FROM points").getInt(), 18);  // not 36
  const auto points = db::LoadPoints(database, imported.session);
  const auto expected = io::ReadCsvFile(DataPath("networks/barta-phase_1-2TK/expected.csv"));
  int compared = 0;
  for (const auto& row : expected.rows()) {
    for (const auto& p : points) {
      if (p.point != expected.Text(row, 0) || !p.position_mm) continue;
      const Eigen::Vector3d published(expected.Number(row, 1), expected.Number(row, 2),
                                      expected.Number(row, 3));
      EXPECT_LT((*p.position_mm - published).norm(), 5e-4) << p.point;
      ++compared;
    }
  }
  EXPECT_GE(compared, 10);
  EXPECT_NE(FormatReduceSummaries(ReduceSessions(database, imported.session, true), database.path())
                .find("18 points reduced"),
            std::string::npos);
}

TEST(ReduceSessions, UnknownSessionIsAnInputErrorWithAWorkingHint) {
  TempDir dir;
  db::Database database(dir.File("lab.db"));
  try {
    ReduceSessions(database, 4, true);
    FAIL();
  } catch (const InputError& e) {
    EXPECT_NE(e.message().find("no session 4"), std::string::npos);
    EXPECT_NE(e.message().find("armsig --db " + database.path() + " sessions"), std::string::npos)
        << e.what();
  }
}

TEST(ImportObservations, UnknownStationIsRefusedAndNothingIsStored) {
  TempDir dir;
  WriteText(dir.File("obs.csv"), "point,station,hz_gon,v_gon\nP,1,10,100\nP,X,20,100\n");
  db::Database database(dir.File("lab.db"));
  ImportObservationsOptions o;
  o.file = dir.File("obs.csv");
  o.stations = DataPath("networks/k06/stations.yaml");
  try {
    ImportObservations(database, o);
    FAIL();
  } catch (const InputError& e) {
    EXPECT_EQ(e.where().line, 3) << e.what();
  }
  EXPECT_EQ(database.sql().execAndGet("SELECT count(*) FROM sessions").getInt(), 0);
}

}  // namespace
}  // namespace armsig::workflows
