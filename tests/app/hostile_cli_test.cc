// Issue 15 through the real binary: hostile inputs and damaged databases give exit code 2
// with file:line:column (or the option) and never a crash, a lie or a write.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "db/database.h"
#include "io/network_io.h"
#include "test_support.h"

namespace armsig::testing {
namespace {

std::string Q(const std::string& path) { return "'" + path + "'"; }
std::string Fault(const std::string& file) { return Q(DataPath("faults/" + file)); }

TEST(HostileCli, OrientWithAZenithOrNadirRayAndADistanceSolvesInsteadOfCrashing) {
  for (const std::string file : {"orient-zenith-ray.csv", "orient-nadir-ray.csv"}) {
    TempDir dir;
    const auto r =
        RunArmsig("orient --observations " + Fault(file) + " --scale-bar A:B=1000 --out " +
                  Q(dir.File("st.yaml")) + " --points " + Q(dir.File("pts.csv")));
    ASSERT_EQ(r.exit_code, 0) << file << "\n" << r.err << r.out;
    // The data are exact: the stations come back as generated (S2 at 4000, 500, 100 mm
    // relative to S1 at the origin with azimuth 0).
    const auto stations = io::ReadStationsYaml(dir.File("st.yaml"));
    ASSERT_EQ(stations.size(), 3u);
    EXPECT_LT((stations[1].pose.position_mm - Eigen::Vector3d(4000, 500, 100)).norm(), 1e-3)
        << stations[1].pose.position_mm.transpose();
    const std::string points = ReadText(dir.File("pts.csv"));
    EXPECT_NE(points.find(file == "orient-zenith-ray.csv" ? "UP," : "DOWN,"), std::string::npos);
  }
}

TEST(HostileCli, ImplausibleNumbersAreExit2WithFileLineColumn) {
  TempDir dir;
  const std::string model = Q(SourcePath("models/puma760.yaml"));
  auto r = RunArmsig("calibrate --model " + model + " --poses " +
                     Fault("poses-coordinate-1e308.csv") + " --json " + Q(dir.File("c.json")));
  EXPECT_EQ(r.exit_code, 2) << r.err;
  EXPECT_NE(r.err.find("poses-coordinate-1e308.csv:2:10 (z_mm): expected a finite coordinate"),
            std::string::npos)
      << r.err;
  EXPECT_FALSE(std::filesystem::exists(dir.File("c.json")));
  r = RunArmsig("calibrate --model " + Fault("model-link-1e19mm.yaml") + " --poses " +
                Fault("poses-coordinate-1e308.csv"));
  EXPECT_EQ(r.exit_code, 2) << r.err;
  EXPECT_NE(r.err.find("model-link-1e19mm.yaml:6:13"), std::string::npos) << r.err;
}

TEST(HostileCli, YamlOfTheWrongShapeIsExit2NamingTheFile) {
  TempDir dir;
  const auto r = RunArmsig("calibrate --model " + Fault("model-scalar-term.yaml") + " --poses " +
                           Fault("poses-coordinate-1e308.csv"));
  EXPECT_EQ(r.exit_code, 2) << r.err;
  EXPECT_NE(r.err.find("model-scalar-term.yaml:7:"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("expected a mapping"), std::string::npos) << r.err;
  const auto t = RunArmsig("triangulate --stations " + Fault("stations-map-not-list.yaml") +
                           " --observations " + Fault("orient-zenith-ray.csv") + " --out " +
                           Q(dir.File("p.csv")));
  EXPECT_EQ(t.exit_code, 2) << t.err;
  EXPECT_NE(t.err.find("stations-map-not-list.yaml:3:"), std::string::npos) << t.err;
}

TEST(HostileCli, NamesWithControlCharactersAreRefusedNamingTheOption) {
  TempDir dir;
  const std::string db = "--db " + Q(dir.File("lab.db")) + " ";
  auto r = RunArmsig(db + "robot add \"$(printf 'puma\\nERROR: forged')\" --model " +
                     Q(SourcePath("models/puma760.yaml")));
  EXPECT_EQ(r.exit_code, 2) << r.err;
  EXPECT_NE(r.err.find("control character U+000A"), std::string::npos) << r.err;
  EXPECT_EQ(r.err.find("\nERROR: forged"), std::string::npos) << r.err;
  EXPECT_FALSE(std::filesystem::exists(dir.File("lab.db")));
  r = RunArmsig(db + "import observations " + Fault("orient-zenith-ray.csv") + " --stations " +
                Q(DataPath("networks/k06/stations.yaml")) + " --note \"$(printf 'a\\033[2Jb')\"");
  EXPECT_EQ(r.exit_code, 2) << r.err;
  EXPECT_NE(r.err.find("--note"), std::string::npos) << r.err;
}

TEST(HostileCli, DbInfoOnAnotherApplicationsFileLeavesItByteIdentical) {
  TempDir dir;
  const std::string path = dir.File("app.db");
  {
    SQLite::Database raw(path, SQLite::OPEN_READWRITE | SQLite::OPEN_CREATE);
    raw.exec("CREATE TABLE invoices(id INTEGER PRIMARY KEY, total REAL)");
    raw.exec("INSERT INTO invoices(total) VALUES (12.5)");
  }
  const std::string before = ReadText(path);
  const auto r = RunArmsig("--db " + Q(path) + " db info");
  EXPECT_EQ(r.exit_code, 2) << r.err;
  EXPECT_NE(r.err.find("not an armsig database"), std::string::npos) << r.err;
  EXPECT_TRUE(ReadText(path) == before);
  EXPECT_FALSE(std::filesystem::exists(path + "-wal"));
  EXPECT_FALSE(std::filesystem::exists(path + "-shm"));
}

TEST(HostileCli, ImportIntoADamagedDatabaseIsExit2WithTheRecoveryCommand) {
  TempDir dir;
  const std::string path = dir.File("lab.db");
  const std::string db = "--db " + Q(path) + " ";
  const std::string import = "import observations " + Q(DataPath("networks/k06/observations.csv")) +
                             " --stations " + Q(DataPath("networks/k06/stations.yaml"));
  ASSERT_EQ(RunArmsig(db + import).exit_code, 0);
  int root = 0, page_size = 0;
  {
    SQLite::Database raw("file:" + path + "?immutable=1", SQLite::OPEN_READONLY | SQLite::OPEN_URI);
    root =
        raw.execAndGet("SELECT rootpage FROM sqlite_master WHERE name = 'observations'").getInt();
    page_size = raw.execAndGet("PRAGMA page_size").getInt();
  }
  {
    std::fstream file(path, std::ios::in | std::ios::out | std::ios::binary);
    file.seekp(static_cast<std::streamoff>(root - 1) * page_size);
    file.write("\xff\xff\xff\xff\xff\xff\xff\xff", 8);
  }
  const std::string before = ReadText(path);
  const auto r = RunArmsig(db + import);
  EXPECT_EQ(r.exit_code, 2) << r.err;
  EXPECT_NE(r.err.find(path + ": the database file is damaged"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("sqlite3 " + path + " \".recover\" | sqlite3 recovered.db"),
            std::string::npos)
      << r.err;
  EXPECT_TRUE(ReadText(path) == before);
  EXPECT_FALSE(std::filesystem::exists(path + "-wal"));
}

}  // namespace
}  // namespace armsig::testing
