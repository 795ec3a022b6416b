// Through the real binary: hostile inputs and damaged databases give exit code 2
// with file:line:column (or the option) and never a crash, a lie or a write.
#include <fmt/format.h>
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <sys/wait.h>

#include <CLI/CLI.hpp>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <functional>
#include <nlohmann/json.hpp>
#include <numbers>
#include <random>
#include <set>
#include <sstream>

#include "app/command.h"
#include "calibration/synthetic.h"
#include "db/database.h"
#include "io/network_files.h"
#include "support/simulated_sessions.h"
#include "test_support.h"

namespace armsig::testing {
namespace {

std::string Fault(const std::string& file) { return Quoted(DataPath("faults/" + file)); }

TEST(HostileCli, OrientWithAZenithOrNadirRayAndADistanceSolvesInsteadOfCrashing) {
  for (const std::string file : {"orient-zenith-ray.csv", "orient-nadir-ray.csv"}) {
    TempDir dir;
    const auto r =
        RunArmsig("orient --observations " + Fault(file) + " --scale-bar A:B=1000 --out " +
                  Quoted(dir.File("st.yaml")) + " --points " + Quoted(dir.File("pts.csv")));
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
  const std::string model = Quoted(SourcePath("models/puma760.yaml"));
  auto r = RunArmsig("calibrate --model " + model + " --poses " +
                     Fault("poses-coordinate-1e308.csv") + " --json " + Quoted(dir.File("c.json")));
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
                           Quoted(dir.File("p.csv")));
  EXPECT_EQ(t.exit_code, 2) << t.err;
  EXPECT_NE(t.err.find("stations-map-not-list.yaml:3:"), std::string::npos) << t.err;
}

TEST(HostileCli, NamesWithControlCharactersAreRefusedNamingTheOption) {
  TempDir dir;
  const std::string db = "--db " + Quoted(dir.File("lab.db")) + " ";
  auto r = RunArmsig(db + "robot add \"$(printf 'puma\\nERROR: forged')\" --model " +
                     Quoted(SourcePath("models/puma760.yaml")));
  EXPECT_EQ(r.exit_code, 2) << r.err;
  EXPECT_NE(r.err.find("control character U+000A"), std::string::npos) << r.err;
  EXPECT_EQ(r.err.find("\nERROR: forged"), std::string::npos) << r.err;
  EXPECT_FALSE(std::filesystem::exists(dir.File("lab.db")));
  r = RunArmsig(db + "import observations " + Fault("orient-zenith-ray.csv") + " --stations " +
                Quoted(DataPath("networks/k06/stations.yaml")) +
                " --note \"$(printf 'a\\033[2Jb')\"");
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
  const auto r = RunArmsig("--db " + Quoted(path) + " db info");
  EXPECT_EQ(r.exit_code, 2) << r.err;
  EXPECT_NE(r.err.find("not an armsig database"), std::string::npos) << r.err;
  EXPECT_TRUE(ReadText(path) == before);
  EXPECT_FALSE(std::filesystem::exists(path + "-wal"));
  EXPECT_FALSE(std::filesystem::exists(path + "-shm"));
}

TEST(HostileCli, ImportIntoADamagedDatabaseIsExit2WithTheRecoveryCommand) {
  TempDir dir;
  const std::string path = dir.File("lab.db");
  const std::string db = "--db " + Quoted(path) + " ";
  const std::string import = "import observations " +
                             Quoted(DataPath("networks/k06/observations.csv")) + " --stations " +
                             Quoted(DataPath("networks/k06/stations.yaml"));
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

// --- Hostile inputs, a second audit.

// Lines of `err` that start like one of armsig's own log lines.
std::vector<std::string> LogLines(const std::string& err) {
  std::vector<std::string> lines;
  std::istringstream in(err);
  for (std::string line; std::getline(in, line);) {
    if (line.rfind("armsig: ", 0) == 0) lines.push_back(line);
  }
  return lines;
}

void ExpectNoCeresLog(const CommandResult& r) {
  for (const char* ceres : {"ResidualBlock", "Logging before InitGoogleLogging", ".cc:", "F2"}) {
    EXPECT_EQ(r.err.find(ceres), std::string::npos) << "Ceres log on stderr:\n" << r.err;
  }
}

TEST(HostileCli, AScaleBarFromAPointToItselfIsExit2NamingTheOption) {
  TempDir dir;
  const auto r = RunArmsig("orient --observations " + Fault("orient-zenith-ray.csv") +
                           " --scale-bar A:A=1000 --out " + Quoted(dir.File("s.yaml")));
  EXPECT_EQ(r.exit_code, 2) << r.err;  // was SIGABRT: Ceres "Duplicate parameter blocks"
  EXPECT_NE(r.err.find("--scale-bar: 'A:A=1000': both ends are point 'A'"), std::string::npos)
      << r.err;
  ExpectNoCeresLog(r);
  EXPECT_FALSE(std::filesystem::exists(dir.File("s.yaml")));
}

TEST(HostileCli, OrientAdjustsRepeatedSightingsAndPoleBlundersWithoutNaN) {
  for (const std::string file : {"orient-duplicate-datum-sighting.csv", "orient-zenith-blunder.csv",
                                 "orient-nadir-blunder.csv"}) {
    TempDir dir;
    const bool blunder = file != "orient-duplicate-datum-sighting.csv";
    if (blunder) {
      // Tested only (--no-reject): σ0 in the thousands, the gate refuses to write stations a
      // blunder distorts, and names the blunder (the largest standardised residual).
      const auto refused =
          RunArmsig("orient --observations " + Fault(file) +
                    " --scale-bar A:B=1000 --no-reject --out " + Quoted(dir.File("st.yaml")));
      EXPECT_EQ(refused.exit_code, 3) << file << "\n" << refused.err << refused.out;
      EXPECT_NE(refused.err.find("sigma0 a posteriori"), std::string::npos) << refused.err;
      EXPECT_NE(refused.err.find("S2->T1"), std::string::npos) << refused.err;
      EXPECT_NE(refused.err.find("nothing was written"), std::string::npos) << refused.err;
      EXPECT_FALSE(std::filesystem::exists(dir.File("st.yaml")));
      ExpectNoCeresLog(refused);
      // Snooping sets the reading (Hz, V at the pole) aside and names it. At the zenith the
      // distance goes too; at the nadir it cannot be told from the one scale bar (the only
      // other scale), so it is said and nothing is written.
      const auto snooped = RunArmsig("orient --observations " + Fault(file) +
                                     " --scale-bar A:B=1000 --out " + Quoted(dir.File("st.yaml")));
      EXPECT_NE(snooped.out.find("removed as blunders"), std::string::npos) << snooped.out;
      EXPECT_NE(snooped.out.find("Hz S2->T1"), std::string::npos) << snooped.out;
      EXPECT_NE(snooped.out.find("V S2->T1"), std::string::npos) << snooped.out;
      if (snooped.exit_code == 3) {
        EXPECT_NE(snooped.err.find("could not be removed"), std::string::npos) << snooped.err;
        EXPECT_NE(snooped.err.find("distance S2->T1"), std::string::npos) << snooped.err;
        EXPECT_FALSE(std::filesystem::exists(dir.File("st.yaml")));
      } else {
        EXPECT_EQ(snooped.exit_code, 0) << file << "\n" << snooped.err;
        EXPECT_NE(snooped.out.find("distance S2->T1"), std::string::npos) << snooped.out;
      }
      ExpectNoCeresLog(snooped);
    }
    // Accepted as it is (--no-reject --max-sigma0 0: no gate), it is adjusted without NaN.
    const auto r = RunArmsig("orient --observations " + Fault(file) + " --scale-bar A:B=1000 " +
                             (blunder ? "--no-reject --max-sigma0 0 " : "") + "--out " +
                             Quoted(dir.File("st.yaml")));
    ASSERT_EQ(r.exit_code, 0) << file << "\n" << r.err << r.out;
    ExpectNoCeresLog(r);
    if (blunder) {  // written as asked, not silently
      EXPECT_NE(r.err.find("the stations are written as asked"), std::string::npos) << r.err;
    }
    const auto stations = io::ReadStationsYaml(dir.File("st.yaml"));
    ASSERT_EQ(stations.size(), 3u);
    if (file == "orient-duplicate-datum-sighting.csv") {
      // Exact data: S2 as generated (4000, 500, 100 mm from S1).
      EXPECT_LT((stations[1].pose.position_mm - Eigen::Vector3d(4000, 500, 100)).norm(), 1e-3)
          << stations[1].pose.position_mm.transpose();
    } else {
      // The blunder (T1 from S2 at V = 0 or 200 gon, 1500 mm) is named, not hidden in NaN.
      EXPECT_NE(r.out.find("S2->T1"), std::string::npos) << r.out;
      EXPECT_NE(r.out.find("BLUNDER?"), std::string::npos) << r.out;
    }
  }
}

TEST(HostileCli, ControlPointsInOnePlaceAreExit2AtTheirLine) {
  TempDir dir;
  const auto r =
      RunArmsig("orient --observations " + Fault("orient-zenith-ray.csv") + " --control " +
                Fault("control-one-position.csv") + " --out " + Quoted(dir.File("s.yaml")));
  EXPECT_EQ(r.exit_code, 2) << r.err;
  EXPECT_NE(r.err.find("control-one-position.csv:4:2 (x_mm): control point 'T2' has the "
                       "position of control point 'T1'"),
            std::string::npos)
      << r.err;
  ExpectNoCeresLog(r);
}

TEST(HostileCli, NamesThatAreNotUtf8AreRefusedAndJsonNeverThrowsOnStoredText) {
  TempDir dir;
  const std::string path = dir.File("lab.db");
  const std::string db = "--db " + Quoted(path) + " ";
  const std::string model = Quoted(SourcePath("models/puma760.yaml"));
  auto r = RunArmsig(db + "robot add \"$(printf 'r\\377')\" --model " + model);
  EXPECT_EQ(r.exit_code, 2) << r.err;
  EXPECT_NE(r.err.find("0xff at byte 2 that is not UTF-8"), std::string::npos) << r.err;
  r = RunArmsig(db + "robot add \"$(printf '\\342\\200\\213')\" --model " + model);  // U+200B
  EXPECT_EQ(r.exit_code, 2) << r.err;
  r = RunArmsig(db + "recalibrate --robot \"$(printf 'r\\377')\" --json " +
                Quoted(dir.File("j.json")));
  EXPECT_EQ(r.exit_code, 2) << r.err;
  EXPECT_FALSE(std::filesystem::exists(dir.File("j.json")));
  EXPECT_FALSE(std::filesystem::exists(path));  // nothing stored, not even a database

  // A name that is not UTF-8 already in the file (written by another tool or an older
  // armsig): every JSON output writes it with U+FFFD instead of failing.
  ASSERT_EQ(RunArmsig(db + "robot add r1 --model " + model).exit_code, 0);
  {
    db::Database database(path);
    database.sql().exec("UPDATE robots SET name = CAST(X'72FF' AS TEXT)");
    database.sql().exec(
        "INSERT INTO sessions(robot_id, state, note) SELECT id, 'completed', CAST(X'6EFF' AS "
        "TEXT) FROM robots");
  }
  for (const std::string command : {"robot list --json", "sessions --json"}) {
    r = RunArmsig(db + command);
    ASSERT_EQ(r.exit_code, 0) << command << ": " << r.err;
    const auto json = nlohmann::json::parse(r.out);
    ASSERT_EQ(json.size(), 1u) << r.out;
    EXPECT_NE(r.out.find("\xef\xbf\xbd"), std::string::npos) << r.out;
  }
}

// Every numeric option of every command refuses nan, inf, 1e999 (which CLI11's Range let
// through) and, unless a negative value means something, -1: at parse time, naming it.
TEST(HostileCli, EveryNumericOptionOfEveryCommandIsRangeChecked) {
  struct Numeric {
    std::vector<std::string> path;  // subcommands
    std::string name;               // "--alpha", or a positional's name
    bool positional;
  };
  std::vector<Numeric> numeric;
  std::function<void(CLI::App*, std::vector<std::string>)> walk = [&](CLI::App* app,
                                                                      std::vector<std::string> at) {
    for (const CLI::Option* opt : app->get_options()) {
      const std::string type = opt->get_type_name();
      // NumberOption names its value N (integers) or NUMBER; a number option that missed it
      // keeps CLI11's FLOAT / INT / UINT.
      const bool number = type == "N" || type == "NUMBER" || type.rfind("FLOAT", 0) == 0 ||
                          type.rfind("INT", 0) == 0 || type.rfind("UINT", 0) == 0;
      if (!number || opt->get_type_size_max() == 0) continue;  // flags count, take no value
      numeric.push_back({at, opt->get_name(), opt->nonpositional() == false});
    }
    for (CLI::App* sub : app->get_subcommands([](CLI::App*) { return true; })) {
      auto next = at;
      next.push_back(sub->get_name());
      walk(sub, next);
    }
  };
  {
    CLI::App app;
    app::GlobalOptions global;
    app::Runner run;
    app::SetupAll(app, global, run);
    walk(&app, {});
  }
  ASSERT_GT(numeric.size(), 20u);  // calibrate, recalibrate, orient, triangulate, demo, …
  // Joint angles, coordinates and orientation angles may be negative; so may a virtual
  // tracker's clock offset and drift.
  const std::set<std::string> negative_allowed = {"--seed-deg", "--cube", "--centre",
                                                  "--orientation", "--clock-offset-ms",
                                                  "--clock-drift-ppm"};
  for (const auto& option : numeric) {
    std::vector<std::string> values = {"nan", "inf", "1e999", "1e300", "-1"};
    if (!option.positional) values.push_back("-inf");
    for (const auto& value : values) {
      if (value == "-1" && negative_allowed.count(option.name)) continue;
      CLI::App app;
      app::GlobalOptions global;
      app::Runner run;
      app::SetupAll(app, global, run);
      std::vector<std::string> args = {"armsig"};
      args.insert(args.end(), option.path.begin(), option.path.end());
      args.push_back(option.positional ? value : option.name + "=" + value);
      std::vector<const char*> argv;
      for (const auto& a : args) argv.push_back(a.c_str());
      std::string what = "accepted";
      try {
        app.parse(static_cast<int>(argv.size()), argv.data());
      } catch (const CLI::ValidationError& e) {
        what = e.what();
        EXPECT_NE(what.find(option.name), std::string::npos) << what;
        continue;
      } catch (const CLI::ConversionError& e) {
        continue;  // an integer option: "nan" is no integer
      } catch (const CLI::ParseError& e) {
        what = std::string(e.get_name()) + ": " + e.what();
      }
      ADD_FAILURE() << ::testing::PrintToString(args) << ": " << what;
    }
  }
}

TEST(HostileCli, EchoedInputCannotForgeALogLine) {
  TempDir dir;
  auto r = RunArmsig("orient --observations " + Fault("observations-forged-log-line.csv") +
                     " --scale-bar A:B=1000 --out " + Quoted(dir.File("s.yaml")));
  EXPECT_EQ(r.exit_code, 2) << r.err;
  for (const auto& line : LogLines(r.err)) {
    EXPECT_EQ(line.rfind("armsig: info: orientation accepted", 0), std::string::npos) << r.err;
  }
  EXPECT_NE(r.err.find("\\narmsig: info: orientation accepted"), std::string::npos) << r.err;
  // A file name with a line break: in log lines and in the stored session note.
  const std::string forged = dir.File("obs\narmsig: info: forged.csv");
  std::filesystem::copy_file(DataPath("networks/k06/observations.csv"), forged);
  const std::string db = "--db " + Quoted(dir.File("lab.db")) + " ";
  r = RunArmsig(db + "import observations " + Quoted(forged) + " --stations " +
                Quoted(DataPath("networks/k06/stations.yaml")));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  r = RunArmsig(db + "sessions");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("obs\\narmsig: info: forged.csv"), std::string::npos) << r.out;
  EXPECT_EQ(r.out.find("\narmsig: info: forged"), std::string::npos) << r.out;
  r = RunArmsig(db + "import observations " + Quoted(forged) + " --stations " + Quoted(forged));
  EXPECT_EQ(r.exit_code, 2);
  for (const auto& line : LogLines(r.err)) {
    EXPECT_EQ(line.rfind("armsig: info: forged", 0), std::string::npos) << r.err;
  }
}

TEST(HostileCli, NonRegularInputFilesAreExit2WithoutReadingOrWaiting) {
  TempDir dir;
  const std::string model = Quoted(SourcePath("models/puma760.yaml"));
  auto r = RunArmsig("calibrate --model /dev/zero --poses " + Fault("poses-all-joints-zero.csv"));
  EXPECT_EQ(r.exit_code, 2) << r.err;
  EXPECT_NE(r.err.find("/dev/zero: is a character device, not a regular file"), std::string::npos)
      << r.err;
  r = RunArmsig("calibrate --model " + model + " --poses /dev/zero");
  EXPECT_EQ(r.exit_code, 2) << r.err;
  const std::string fifo = dir.File("stations.yaml");
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  const auto start = std::chrono::steady_clock::now();
  // Under timeout(1): a reader that blocks on the FIFO ends with 124 instead of hanging.
  const std::string err = dir.File("err");
  const int status =
      std::system(("timeout 20 '" + std::string(ARMSIG_BINARY) + "' triangulate --stations " +
                   Quoted(fifo) + " --observations " + Fault("orient-zenith-ray.csv") + " --out " +
                   Quoted(dir.File("p.csv")) + " 2>" + Quoted(err))
                      .c_str());
  EXPECT_EQ(WIFEXITED(status) ? WEXITSTATUS(status) : -1, 2) << ReadText(err);
  EXPECT_NE(ReadText(err).find("is a FIFO, not a regular file"), std::string::npos)
      << ReadText(err);
  EXPECT_LT(std::chrono::steady_clock::now() - start, std::chrono::seconds(5));
}

TEST(HostileCli, PosesThatNeverMoveTheRobotAreExit2WithTheReason) {
  TempDir dir;
  const auto r =
      RunArmsig("calibrate --model " + Quoted(SourcePath("models/puma760.yaml")) + " --poses " +
                Fault("poses-all-joints-zero.csv") + " --json " + Quoted(dir.File("c.json")));
  EXPECT_EQ(r.exit_code, 2) << r.out << r.err;  // was exit 0, "converged", σ0 563 mm
  EXPECT_NE(r.err.find("all 40 poses have the same joint angles"), std::string::npos) << r.err;
  EXPECT_FALSE(std::filesystem::exists(dir.File("c.json")));
}

TEST(HostileCli, ReadOnlyCommandsLeaveAnEmptyFileAndRefuseFutureWalFiles) {
  TempDir dir;
  const std::string empty = dir.File("empty.db");
  WriteText(empty, "");
  for (const std::string command :
       {"robot list", "sessions --json", "db info", "versions --robot r"}) {
    const auto r = RunArmsig("--db " + Quoted(empty) + " " + command);
    EXPECT_EQ(r.exit_code, 2) << command << ": " << r.err;
    EXPECT_NE(r.err.find("an empty file, not an armsig database yet"), std::string::npos) << r.err;
    EXPECT_EQ(std::filesystem::file_size(empty), 0u) << command;
    EXPECT_FALSE(std::filesystem::exists(empty + "-wal"));
    EXPECT_FALSE(std::filesystem::exists(empty + "-shm"));
  }
}

TEST(HostileCli, AStoredParameterThatIsNotFiniteIsExit2NamingTheVersion) {
  TempDir dir;
  const std::string path = dir.File("lab.db");
  {
    db::Database database(path);
    AddSession(database, calibration::PaperTable3Parameters(), 150, 3);
  }
  ASSERT_EQ(RunArmsig("--db " + Quoted(path) + " recalibrate --robot puma").exit_code, 0);
  {
    db::Database database(path);
    database.sql().exec("UPDATE calibration_parameters SET value = 1e999 WHERE name = 'a3'");
  }
  WriteText(dir.File("j.csv"), "pose,q1_deg,q2_deg,q3_deg,q4_deg,q5_deg,q6_deg\np,0,0,0,0,0,0\n");
  const auto r = RunArmsig("--db " + Quoted(path) + " predict --robot puma --joints " +
                           Quoted(dir.File("j.csv")));
  EXPECT_EQ(r.exit_code, 2) << r.out << r.err;  // was exit 0, printing inf
  EXPECT_EQ(r.out.find("inf"), std::string::npos) << r.out;
  EXPECT_NE(r.err.find("robot 'puma', parameter set version 1: parameter 'a3'"), std::string::npos)
      << r.err;
}

// File names are input too: a database, an output file and an imported file whose names
// hold an escape sequence and a newline are echoed on standard output escaped, on one line.
TEST(HostileCli, FileNamesWithControlCharactersAreEscapedOnStandardOutput) {
  TempDir dir;
  const std::string odd = "\"$(printf 'a\\033[2Jb\\nc')\"";  // a, ESC [2J, b, newline, c
  const std::string db = "--db " + Quoted(dir.path().string()) + "/" + odd + ".db ";
  auto r = RunArmsig(db + "db init", dir.path().string());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("a\\x1b[2Jb\\nc.db: new armsig database"), std::string::npos) << r.out;
  EXPECT_EQ(r.out.find('\x1b'), std::string::npos) << r.out;
  EXPECT_EQ(std::count(r.out.begin(), r.out.end(), '\n'), 1) << r.out;
  ASSERT_EQ(RunArmsig(db + "robot add r --model " + Quoted(SourcePath("models/puma760.yaml")),
                      dir.path().string())
                .exit_code,
            0);
  const std::string poses = dir.File("p.csv");
  {  // three configurations where the nominal robot puts its tool (the door's model check)
    const auto model = Puma();
    std::mt19937 rng(7);
    const auto simulated = calibration::SimulatePoses(
        model, Eigen::Isometry3d::Identity(), Eigen::VectorXd::Zero(model.num_parameters()),
        calibration::RandomConfigurations(model, 3, rng), 0.0, rng);
    std::string text = "pose,q1_deg,q2_deg,q3_deg,q4_deg,q5_deg,q6_deg,x_mm,y_mm,z_mm\n";
    for (size_t k = 0; k < simulated.size(); ++k) {
      text += std::to_string(k + 1);
      for (int i = 0; i < 6; ++i)
        text += fmt::format(",{:.9f}", simulated[k].joints_rad(i) * 180 / std::numbers::pi);
      for (int i = 0; i < 3; ++i) text += fmt::format(",{:.6f}", simulated[k].target_in_world(i));
      text += "\n";
    }
    WriteText(poses, text);
  }
  r = RunArmsig(db +
                    "import poses p.csv --joint-columns q1_deg,q2_deg,q3_deg,q4_deg,q5_deg,"
                    "q6_deg --joint-unit deg --xyz-columns x_mm,y_mm,z_mm --id pose --robot r "
                    "--out " +
                    odd + ".csv",
                dir.path().string());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(r.out.find('\x1b'), std::string::npos) << r.out;
  EXPECT_EQ(std::count(r.out.begin(), r.out.end(), '\n'), 1) << r.out;
  r = RunArmsig(db + "session export 1 --poses " + odd + "-back.csv", dir.path().string());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("-> a\\x1b[2Jb\\nc-back.csv"), std::string::npos) << r.out;
  EXPECT_EQ(std::count(r.out.begin(), r.out.end(), '\n'), 1) << r.out;
}

}  // namespace
}  // namespace armsig::testing
