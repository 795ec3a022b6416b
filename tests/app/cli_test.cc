#include <SQLiteCpp/SQLiteCpp.h>
#include <fmt/format.h>
#include <fcntl.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <random>
#include <regex>
#include <thread>

#include "calibration/model.h"
#include "db/database.h"
#include "db/schema.h"
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
  const auto version = RunArmsig("--version");
  EXPECT_EQ(version.exit_code, 0);
  // The version, the git commit it was built from and the database schema it writes.
  EXPECT_TRUE(std::regex_search(
      version.out, std::regex(R"(^armsig \d+\.\d+\.\d+ \(git ([0-9a-f]{7,}(-modified)?|unknown), )"
                              R"(database schema v\d+\)\n$)")))
      << version.out;
  EXPECT_EQ(RunArmsig("").exit_code, 2);  // a command is required
  EXPECT_EQ(RunArmsig("no-such-command").exit_code, 2);
  EXPECT_EQ(RunArmsig("calibrate --model").exit_code, 2);
}

TEST(Cli, DbInitCreatesTheFileAndInfoReportsTheSchema) {
  TempDir dir;
  const auto missing = RunArmsig("--db '" + dir.File("lab.db") + "' db info");
  EXPECT_EQ(missing.exit_code, 2);  // info only reads: it creates nothing
  EXPECT_NE(missing.err.find("no such database file"), std::string::npos) << missing.err;
  EXPECT_FALSE(std::filesystem::exists(dir.File("lab.db")));
  const auto init = RunArmsig("--db '" + dir.File("lab.db") + "' db init");
  EXPECT_EQ(init.exit_code, 0) << init.err;
  EXPECT_NE(init.out.find("new armsig database"), std::string::npos) << init.out;
  const auto again = RunArmsig("--db '" + dir.File("lab.db") + "' db init");
  EXPECT_NE(again.out.find("already an armsig database"), std::string::npos) << again.out;
  const auto r = RunArmsig("--db '" + dir.File("lab.db") + "' db info");
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("schema        v" + std::to_string(db::LatestSchemaVersion())),
            std::string::npos)
      << r.out;
  for (const auto table : db::TableNames())
    EXPECT_NE(r.out.find(std::string(table)), std::string::npos) << table;
  EXPECT_TRUE(std::filesystem::exists(dir.File("lab.db")));
}

TEST(Cli, DbPathComesFromTheEnvironmentThenTheWorkingDirectory) {
  TempDir dir;
  EXPECT_EQ(RunArmsig("db init", dir.path().string()).exit_code, 0);
  EXPECT_TRUE(std::filesystem::exists(dir.File("armsig.db")));
  setenv("ARMSIG_DB", dir.File("env.db").c_str(), 1);
  EXPECT_EQ(RunArmsig("db init", dir.path().string()).exit_code, 0);
  unsetenv("ARMSIG_DB");
  EXPECT_TRUE(std::filesystem::exists(dir.File("env.db")));
}

TEST(Cli, DbExportWritesCsvAndRejectsUnknownTables) {
  TempDir dir;
  const std::string db = "--db '" + dir.File("lab.db") + "' ";
  ASSERT_EQ(RunArmsig(db + "db init").exit_code, 0);
  const auto r = RunArmsig(db + "db export calibrations --csv");
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(r.out.rfind("id,robot_id,version,", 0), 0u) << r.out;
  const auto bad = RunArmsig(db + "db export nonsense --csv --out '" + dir.File("x.csv") + "'");
  EXPECT_EQ(bad.exit_code, 2);
  EXPECT_NE(bad.err.find("unknown table 'nonsense'"), std::string::npos);
  EXPECT_FALSE(std::filesystem::exists(dir.File("x.csv")));
}

// A misspelt key in any YAML file is refused with exit 2, naming the file, line and key
// and the nearest valid key; nothing is written.
TEST(Cli, MisspeltYamlKeysAreRefusedWithExitTwo) {
  TempDir dir;
  std::string model = ReadText(SourcePath("models/puma760.yaml"));
  const size_t tool = model.find("tool_mm:");
  ASSERT_NE(tool, std::string::npos);
  model.replace(tool, 8, "tool_m:");
  WriteText(dir.File("m.yaml"), model);
  WriteText(dir.File("poses.csv"),
            "pose,q1_deg,q2_deg,q3_deg,q4_deg,q5_deg,q6_deg,x_mm,y_mm,z_mm\n");
  const auto m = RunArmsig("calibrate --model '" + dir.File("m.yaml") + "' --poses '" +
                           dir.File("poses.csv") + "' --json '" + dir.File("out.json") + "'");
  EXPECT_EQ(m.exit_code, 2) << m.err;
  EXPECT_NE(m.err.find("m.yaml:"), std::string::npos) << m.err;
  EXPECT_NE(m.err.find("'tool_m' (did you mean 'tool_mm'?)"), std::string::npos) << m.err;
  EXPECT_FALSE(std::filesystem::exists(dir.File("out.json")));

  WriteText(dir.File("st.yaml"),
            "stations:\n  - {id: T1, position_mm: [0, 0, 0], azimut_gon: 0}\n");
  WriteText(dir.File("obs.csv"), "point,station,hz_gon,v_gon\nP1,T1,10,100\n");
  const auto s = RunArmsig("triangulate --stations '" + dir.File("st.yaml") + "' --observations '" +
                           dir.File("obs.csv") + "' --out '" + dir.File("p.csv") + "'");
  EXPECT_EQ(s.exit_code, 2) << s.err;
  EXPECT_NE(s.err.find("st.yaml:2:"), std::string::npos) << s.err;
  EXPECT_NE(s.err.find("'azimut_gon' (did you mean 'azimuth_gon'?)"), std::string::npos) << s.err;
  EXPECT_FALSE(std::filesystem::exists(dir.File("p.csv")));

  WriteText(dir.File("lab.yaml"),
            "robot:\n  model: " + SourcePath("models/puma760.yaml") +
                "\n  controller: {protocol: as, port: /dev/null}\n"
                "instruments:\n  - {station: T1, protocol: geocom, port: /dev/null}\n"
                "stations: st.yaml\ntolerance: {max_miss_mm: 0.1}\n");
  const auto l = RunArmsig("--db '" + dir.File("lab.db") + "' capture --lab '" +
                           dir.File("lab.yaml") + "' --plan auto:10 --robot r1");
  EXPECT_EQ(l.exit_code, 2) << l.err;
  EXPECT_NE(l.err.find("lab.yaml:7:"), std::string::npos) << l.err;
  EXPECT_NE(l.err.find("'tolerance' (did you mean 'tolerances'?)"), std::string::npos) << l.err;
}

TEST(Cli, DbThatIsNotADatabaseIsAnInputError) {
  TempDir dir;
  WriteText(dir.File("junk.db"), std::string(8192, 'j'));
  const auto r = RunArmsig("--db '" + dir.File("junk.db") + "' db info");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("junk.db"), std::string::npos);
}

// --db, -v and -q before or after the command name, and after nested subcommands.
TEST(Cli, GlobalOptionsAnywhere) {
  TempDir dir;
  const std::string db = "'" + dir.File("x.db") + "'";
  ASSERT_EQ(RunArmsig("db init --db " + db).exit_code, 0);  // after a nested subcommand
  EXPECT_TRUE(std::filesystem::exists(dir.File("x.db")));
  const auto before = RunArmsig("--db " + db + " db export robots --csv");
  EXPECT_EQ(before.exit_code, 0) << before.err;
  const auto after = RunArmsig("db export robots --csv --db " + db + " -q");
  EXPECT_EQ(after.exit_code, 0) << after.err;
  EXPECT_EQ(after.out, before.out);
  // The interface reference's form: `armsig demo --db x.db` (a refused option set: fails
  // fast, after parsing, naming the demo's minimum; nothing is created).
  const auto demo = RunArmsig("demo --db '" + dir.File("d.db") + "' --configurations 3");
  EXPECT_EQ(demo.exit_code, 2) << demo.err;
  EXPECT_NE(demo.err.find("--configurations"), std::string::npos) << demo.err;
  EXPECT_FALSE(std::filesystem::exists(dir.File("d.db")));
  // --db after the command is the one used: a reading command names the missing file.
  const auto predict =
      RunArmsig("predict --robot r --joints j.csv --db '" + dir.File("typo.db") + "'");
  EXPECT_EQ(predict.exit_code, 2);
  EXPECT_NE(predict.err.find("typo.db"), std::string::npos) << predict.err;
  // -q and -v after a nested subcommand: import poses logs its decision at info level.
  WriteText(dir.File("t.csv"), "j1,j2,X,Y,Z\n10,20,1,2,3\n");
  const std::string import = "import poses '" + dir.File("t.csv") +
                             "' --joint-columns j1,j2 --joint-unit deg --xyz-columns X,Y,Z --out '" +
                             dir.File("o.csv") + "'";
  const auto normal = RunArmsig(import);
  ASSERT_EQ(normal.exit_code, 0) << normal.err;
  EXPECT_NE(normal.err.find("import poses: 1 poses"), std::string::npos) << normal.err;
  const auto quiet = RunArmsig(import + " -q");
  ASSERT_EQ(quiet.exit_code, 0) << quiet.err;
  EXPECT_EQ(quiet.err, "");
  const auto verbose = RunArmsig(import + " -v");
  EXPECT_EQ(verbose.exit_code, 0) << verbose.err;
  EXPECT_EQ(RunArmsig(import + " --no-such-option").exit_code, 2);
}

// Commands that only read refuse a database file that does not exist (exit 2, naming the
// path and --db / $ARMSIG_DB) and create nothing.
TEST(Cli, ReadingCommandsRefuseAMissingDatabase) {
  TempDir dir;
  WriteText(dir.File("j.csv"), "pose,q1_deg\nP1,0\n");
  WriteText(dir.File("lab.yaml"), "robot: {}\n");
  const std::string typo = dir.File("lab-typo.db");
  const std::string j = "'" + dir.File("j.csv") + "'";
  for (const std::string& command : std::vector<std::string>{
           "predict --robot r --joints " + j,
           "compensate --robot r --targets " + j + " --out x.csv",
           "export --robot r --format json --out x.json", "reduce", "reduce --session 1",
           "db export robots --csv", "capture --lab '" + dir.File("lab.yaml") + "' --resume 1"}) {
    const auto r = RunArmsig("--db '" + typo + "' " + command, dir.path().string());
    EXPECT_EQ(r.exit_code, 2) << command << ": " << r.err;
    EXPECT_NE(r.err.find(typo + ": no such database file"), std::string::npos)
        << command << ": " << r.err;
    EXPECT_NE(r.err.find("check --db or $ARMSIG_DB"), std::string::npos) << r.err;
    EXPECT_FALSE(std::filesystem::exists(typo)) << command;
  }
  EXPECT_FALSE(std::filesystem::exists(dir.File("x.csv")));
  EXPECT_FALSE(std::filesystem::exists(dir.File("x.json")));
}

// Every option that names an output is checked when the command line is parsed: a
// missing folder is refused with exit 2, naming the option and the path, before any work
// is done, so no database is created and nothing is stored.
TEST(Cli, OutputPathsAreCheckedBeforeAnyWork) {
  TempDir dir;
  const std::string db = dir.File("lab.db");
  const std::string missing = dir.File("no-such-folder");
  WriteText(dir.File("j.csv"), "pose,q1_deg\nP1,0\n");
  const std::string j = "'" + dir.File("j.csv") + "'";
  for (const std::string& command : std::vector<std::string>{
           "demo --configurations 60 --json '" + missing + "/demo.json'",
           "recalibrate --robot r --json '" + missing + "/r.json'",
           "recalibrate --robot r --report '" + missing + "/deep/report'",
           "calibrate --model m.yaml --poses " + j + " --json '" + missing + "/c.json'",
           "predict --robot r --joints " + j + " --out '" + missing + "/p.csv'",
           "session export 1 --poses '" + missing + "/s.csv'",
           "db export robots --csv --out '" + missing + "/r.csv'"}) {
    const auto r = RunArmsig("--db '" + db + "' " + command, dir.path().string());
    EXPECT_EQ(r.exit_code, 2) << command << ": " << r.err;
    EXPECT_NE(r.err.find(missing), std::string::npos) << command << ": " << r.err;
    EXPECT_FALSE(std::filesystem::exists(db)) << command;
  }
  const auto folder =
      RunArmsig("--db '" + db + "' demo --json '" + dir.path().string() + "'", dir.path().string());
  EXPECT_EQ(folder.exit_code, 2) << folder.err;
  EXPECT_NE(folder.err.find("is a folder; expected a file name"), std::string::npos) << folder.err;
  EXPECT_FALSE(std::filesystem::exists(db));
}

namespace {

// The same table with ';' as the delimiter and decimal commas (as a German or French
// spreadsheet writes it).
std::string SemicolonDecimalComma(std::string text) {
  for (char& c : text) {
    if (c == ',')
      c = ';';
    else if (c == '.')
      c = ',';
  }
  return text;
}

}  // namespace

// One CSV dialect for every reader: ';'/decimal-comma files give the same results as the
// comma/decimal-point originals through calibrate, triangulate and orient.
TEST(Cli, SemicolonDecimalCommaFilesThroughEveryReader) {
  TempDir dir;
  const std::string k06 = DataPath("networks/k06/");
  WriteText(dir.File("obs.csv"), SemicolonDecimalComma(ReadText(k06 + "observations.csv")));
  const auto comma =
      RunArmsig("triangulate --stations '" + k06 + "stations.yaml' --observations '" + k06 +
                "observations.csv' --out '" + dir.File("a.csv") + "'");
  ASSERT_EQ(comma.exit_code, 0) << comma.err;
  const auto semi = RunArmsig("triangulate --stations '" + k06 + "stations.yaml' --observations '" +
                              dir.File("obs.csv") + "' --out '" + dir.File("b.csv") + "'");
  ASSERT_EQ(semi.exit_code, 0) << semi.err;
  EXPECT_EQ(ReadText(dir.File("a.csv")), ReadText(dir.File("b.csv")));

  std::string bars;
  std::ifstream in(k06 + "scale_bars.txt");
  for (std::string line; std::getline(in, line);) bars += " --scale-bar " + line;
  const auto orient = RunArmsig("orient --observations '" + dir.File("obs.csv") + "'" + bars +
                                " --scale-bar-sigma-mm 0.005 --out '" + dir.File("st.yaml") + "'");
  ASSERT_EQ(orient.exit_code, 0) << orient.err;
  EXPECT_NE(orient.out.find("185 degrees of freedom"), std::string::npos) << orient.out;

  // Poses: the poses CSV of a simulated PUMA, as written by `import poses`.
  std::string poses = "pose,q1_deg,q2_deg,q3_deg,q4_deg,q5_deg,q6_deg,x_mm,y_mm,z_mm\n";
  const auto model = Puma();
  calibration::Kinematics kin(model);
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> angle(-2.0, 2.0);
  for (int i = 0; i < 60; ++i) {
    double q[6];
    for (double& v : q) v = angle(rng);
    const Eigen::Vector3d x = kin.Position(Eigen::Isometry3d::Identity(),
                                           Eigen::VectorXd::Zero(model.num_parameters()), q);
    poses += "P" + std::to_string(i + 1);
    for (double v : q) poses += "," + std::to_string(v * 180.0 / M_PI);
    poses += "," + std::to_string(x.x()) + "," + std::to_string(x.y()) + "," +
             std::to_string(x.z()) + "\n";
  }
  WriteText(dir.File("poses.csv"), poses);
  WriteText(dir.File("poses-semi.csv"), SemicolonDecimalComma(poses));
  const std::string model_arg = " --model '" + SourcePath("models/puma760.yaml") + "'";
  const auto a = RunArmsig("calibrate" + model_arg + " --params geometric --poses '" +
                           dir.File("poses.csv") + "' --json '" + dir.File("a.json") + "'");
  ASSERT_EQ(a.exit_code, 0) << a.err;
  const auto b = RunArmsig("calibrate" + model_arg + " --params geometric --poses '" +
                           dir.File("poses-semi.csv") + "' --json '" + dir.File("b.json") + "'");
  ASSERT_EQ(b.exit_code, 0) << b.err;
  EXPECT_EQ(ReadText(dir.File("a.json")), ReadText(dir.File("b.json")));

  // A decimal comma in a comma-separated file: refused with file, line and column.
  std::string broken = poses;
  const size_t row2 = broken.find("\nP2,") + 5;  // P2's q1_deg
  broken.replace(broken.find('.', row2), 1, ",");
  WriteText(dir.File("broken.csv"), broken);
  const auto c = RunArmsig("calibrate" + model_arg + " --poses '" + dir.File("broken.csv") + "'");
  EXPECT_EQ(c.exit_code, 2);
  EXPECT_NE(c.err.find(dir.File("broken.csv") + ":3:2"), std::string::npos) << c.err;
  EXPECT_NE(c.err.find("decimal comma"), std::string::npos) << c.err;
}

// `armsig demo --configurations N` works for every N the calibration can use (60 here:
// random configurations, 24 fitted, 36 validated) and refuses fewer with the minimum.
TEST(Cli, DemoWithSixtyConfigurationsAndTooFew) {
  TempDir dir;
  const auto r = RunArmsig("--db '" + dir.File("demo.db") +
                           "' demo --configurations 60 --time-scale 0.02 --json '" +
                           dir.File("demo.json") + "'");
  ASSERT_EQ(r.exit_code, 0) << r.err << r.out;
  const auto j = nlohmann::json::parse(ReadText(dir.File("demo.json")));
  EXPECT_EQ(j["session"]["poses"], 60);
  ASSERT_EQ(j["stages"].size(), 3u);
  EXPECT_EQ(j["stages"][2]["poses_used"], 24);
  EXPECT_EQ(j["stages"][2]["validation"]["poses"], 36);
  EXPECT_LT(j["stages"][2]["validation"]["mean_mm"].get<double>(), 0.1);

  const auto few = RunArmsig("demo --db '" + dir.File("few.db") + "' --configurations 19");
  EXPECT_EQ(few.exit_code, 2) << few.err;
  EXPECT_NE(few.err.find("at least 20"), std::string::npos) << few.err;
  EXPECT_FALSE(std::filesystem::exists(dir.File("few.db")));
  const auto select =
      RunArmsig("demo --db '" + dir.File("few.db") + "' --configurations 60 --select 55");
  EXPECT_EQ(select.exit_code, 2) << select.err;
  EXPECT_NE(select.err.find("--select"), std::string::npos) << select.err;
  EXPECT_FALSE(std::filesystem::exists(dir.File("few.db")));
}

// The demo night after night on one database measures anew (no lab stores the same
// readings twice: a recalibration of identical data is no test of anything); the seed it
// names repeats a run exactly.
TEST(Cli, RepeatedDemosMeasureAnewAndTheNamedSeedRepeatsOne) {
  TempDir dir;
  const std::string demo = "demo --configurations 30 --time-scale 0";
  const auto first = RunArmsig("--db '" + dir.File("lab.db") + "' " + demo);
  ASSERT_EQ(first.exit_code, 0) << first.err;
  EXPECT_NE(first.out.find("seed 1985"), std::string::npos) << first.out;
  const auto second = RunArmsig("--db '" + dir.File("lab.db") + "' " + demo);
  ASSERT_EQ(second.exit_code, 0) << second.err;
  EXPECT_NE(second.out.find("seed 1986"), std::string::npos) << second.out;
  // The virtual lab's orientation (real GeoCOM drivers, 0.5″ readings, no blunder): data
  // snooping removes nothing.
  for (const auto* night : {&first, &second})
    EXPECT_NE(night->out.find("no reading removed by data snooping"), std::string::npos)
        << night->out;
  const auto again = RunArmsig("--db '" + dir.File("again.db") + "' " + demo + " --seed 1986");
  ASSERT_EQ(again.exit_code, 0) << again.err;
  auto readings = [](const std::string& path, int session) {
    db::Database database(path, db::OpenMode::kReadOnly);
    std::string all;
    auto q = database.connection().Prepare(
        "SELECT hz_rad, v_rad FROM observations WHERE session_id = ? ORDER BY id");
    q->Bind(1, static_cast<int64_t>(session));
    while (q->Step()) all += fmt::format("{:.17g} {:.17g}\n", q->Double(0), q->Double(1));
    return all;
  };
  const std::string night1 = readings(dir.File("lab.db"), 1);
  const std::string night2 = readings(dir.File("lab.db"), 2);
  ASSERT_FALSE(night1.empty());
  EXPECT_NE(night1, night2);
  EXPECT_EQ(readings(dir.File("again.db"), 1), night2);
}

namespace {

int TempEntries(const std::string& dir) {
  int n = 0;
  for (const auto& e : std::filesystem::directory_iterator(dir))
    n += e.path().filename().string().rfind("armsig-demo-", 0) == 0;
  return n;
}

bool HasSession(const std::string& db) {
  if (!std::filesystem::exists(db)) return false;
  try {
    SQLite::Database sql(db, SQLite::OPEN_READONLY, 1000);
    return sql.execAndGet("SELECT count(*) FROM sessions").getInt() > 0;
  } catch (const SQLite::Exception&) {
    return false;  // being created
  }
}

}  // namespace

// Ctrl-C at random moments of a demo: no armsig-demo-* directory is left in $TMPDIR, the
// session is paused (or completed), and the resume command printed completes it.
TEST(Cli, DemoCtrlCAtRandomMomentsLeavesNothingBehindAndResumes) {
  TempDir dir;
  const std::string tmp = dir.File("tmp");
  std::filesystem::create_directories(tmp);
  std::mt19937 rng(1123);
  std::uniform_int_distribution<int> delay(0, 1500);
  int resumed = 0;
  for (int round = 0; round < 6; ++round) {
    const std::string db = dir.File("demo-" + std::to_string(round) + ".db");
    const pid_t child =
        SpawnArmsig({"--db", db, "demo", "--configurations", "40", "--time-scale", "0.05"},
                    dir.File("out"), dir.File("err"), tmp);
    ASSERT_GE(child, 0);
    int status = 0;
    bool running = true;
    if (round % 2 == 1) {
      // Odd rounds: once the session exists (an event: a loaded machine only takes longer
      // to get there), then a random moment after.
      running = WaitForChildOr(child, &status, [&] { return HasSession(db); });
      ASSERT_TRUE(running) << ReadText(dir.File("err"));
      std::this_thread::sleep_for(std::chrono::milliseconds(delay(rng) / 10));
    } else {
      // Even rounds: a blind moment (before the lab is built, during the capture or the
      // calibration); every outcome must be coherent.
      std::this_thread::sleep_for(std::chrono::milliseconds(delay(rng)));
    }
    if (running) {
      ::kill(child, SIGINT);
      ::waitpid(child, &status, 0);
    }
    const std::string err = ReadText(dir.File("err"));
    EXPECT_EQ(TempEntries(tmp), 0) << "round " << round << "\n" << err;
    if (!std::filesystem::exists(db)) continue;
    std::string state;
    {
      SQLite::Database sql(db);
      SQLite::Statement q(sql, "SELECT state FROM sessions");
      if (!q.executeStep()) continue;
      state = q.getColumn(0).getString();
    }
    ASSERT_TRUE(state == "paused" || state == "completed") << state << "\n" << err;
    const size_t at = err.rfind("resume with: armsig ");
    if (WIFEXITED(status) && WEXITSTATUS(status) == 0) continue;  // it had finished
    ASSERT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 130) << status << "\n" << err;
    ASSERT_NE(at, std::string::npos) << err;
    const size_t from = at + std::string("resume with: armsig ").size();
    const std::string hint = err.substr(from, err.find('\n', from) - from);
    setenv("TMPDIR", tmp.c_str(), 1);
    const auto r = RunArmsig(hint, "/");
    unsetenv("TMPDIR");
    ASSERT_EQ(r.exit_code, 0) << hint << "\n" << r.err;
    ++resumed;
    SQLite::Database sql(db);
    EXPECT_EQ(sql.execAndGet("SELECT state FROM sessions").getString(), "completed");
    EXPECT_EQ(sql.execAndGet("SELECT count(*) FROM poses").getInt(), 40);
    EXPECT_EQ(sql.execAndGet("SELECT count(*) FROM calibrations").getInt(), 3);
    EXPECT_EQ(TempEntries(tmp), 0);
  }
  EXPECT_GE(resumed, 2);
}

// systemctl stop (SIGTERM) or Ctrl-C while the nightly job fits the real UR10: it stops
// before storing anything, exits 130 and says so; the same command then fits and stores.
TEST(Cli, RecalibrateStoppedMidFitStoresNothingAndTheSameCommandFitsAgain) {
  TempDir dir;
  const std::string db = dir.File("lab.db");
  ASSERT_EQ(RunArmsig("--db '" + db + "' robot add ur10 --model '" +
                      SourcePath("models/ur10.yaml") + "'")
                .exit_code,
            0);
  ASSERT_EQ(RunArmsig("--db '" + db + "' import poses '" +
                      DataPath("ur10-ipa/series_C-measurements_random_poses.csv") +
                      "' --preset ur-ipa --robot ur10")
                .exit_code,
            0);
  for (const int signal : {SIGTERM, SIGINT}) {
    // A log of its own per run: the last run's would say at once what this one has not yet.
    const std::string log = dir.File("err-" + std::to_string(signal));
    const pid_t child = SpawnArmsig({"--db", db, "recalibrate", "--robot", "ur10"},
                                    dir.File("out"), log, dir.path().string());
    ASSERT_GE(child, 0);
    int status = 0;
    // The event: the job says what it fits (the fit of 1,663 configurations follows).
    ASSERT_TRUE(WaitForChildOr(child, &status, [&] {
      return std::filesystem::exists(log) &&
             ReadText(log).find("validating on the rest") != std::string::npos;
    })) << ReadText(log);
    ::kill(child, signal);
    ::waitpid(child, &status, 0);
    const std::string err = ReadText(log);
    ASSERT_TRUE(WIFEXITED(status)) << status << "\n" << err;
    EXPECT_EQ(WEXITSTATUS(status), 130) << err;
    EXPECT_NE(err.find("stopped before storing anything; run the same command again"),
              std::string::npos)
        << err;
    SQLite::Database sql(db);
    EXPECT_EQ(sql.execAndGet("SELECT count(*) FROM calibrations").getInt(), 0);
  }
  const auto again = RunArmsig("--db '" + db + "' recalibrate --robot ur10");
  EXPECT_EQ(again.exit_code, 0) << again.err;
  SQLite::Database sql(db);
  EXPECT_EQ(sql.execAndGet("SELECT count(*) FROM calibrations").getInt(), 1);
}

// Whether process `pid` has a handler for `signal` (its /proc status' SigCgt mask).
bool Catches(pid_t pid, int signal) {
  std::ifstream status("/proc/" + std::to_string(pid) + "/status");
  for (std::string line; std::getline(status, line);) {
    if (line.rfind("SigCgt:", 0) != 0) continue;
    const unsigned long long mask = std::stoull(line.substr(7), nullptr, 16);
    return (mask >> (signal - 1)) & 1ULL;
  }
  return false;
}

// cli.md: SIGINT, SIGTERM and SIGHUP stop every command with exit 130, also one with no
// safe point of its own. An import waiting for the store (another writer holds it) is
// stopped: 130, a message that says what is kept, nothing stored, no temporary file.
// A signal that arrives before armsig's own code runs is a stop like any other: exit 130
// with its message, not the default 143 (issue 38). Deterministic: sent while this thread
// blocks it, it waits pending in the child across exec until armsig's handlers (installed
// before main) unblock it; before them it stayed pending and `--version` ended 0.
TEST(Cli, ASignalBeforeMainIsAStopToo) {
  TempDir dir;
  for (int signal : {SIGTERM, SIGINT, SIGHUP}) {
    sigset_t blocked, old;
    sigemptyset(&blocked);
    sigaddset(&blocked, signal);
    ASSERT_EQ(::pthread_sigmask(SIG_BLOCK, &blocked, &old), 0);
    const pid_t child = SpawnArmsig({"--version"}, dir.File("out"), dir.File("err"));
    ASSERT_GT(child, 0);
    ::kill(child, signal);
    ASSERT_EQ(::pthread_sigmask(SIG_SETMASK, &old, nullptr), 0);
    int status = 0;
    ASSERT_EQ(::waitpid(child, &status, 0), child);
    ASSERT_TRUE(WIFEXITED(status)) << "signal " << signal << ": ended by signal "
                                   << (WIFSIGNALED(status) ? WTERMSIG(status) : 0);
    EXPECT_EQ(WEXITSTATUS(status), 130) << signal;
    EXPECT_NE(ReadText(dir.File("err")).find("stopped by a signal before finishing (exit 130)"),
              std::string::npos)
        << ReadText(dir.File("err"));
  }
}

TEST(Cli, ACommandWithoutSafePointsStoppedByASignalExits130AndStoresNothing) {
  TempDir dir;
  const std::string db = dir.File("lab.db");
  ASSERT_EQ(RunArmsig("--db '" + db + "' robot add ur10 --model '" + SourcePath("models/ur10.yaml") +
                      "'")
                .exit_code,
            0);
  for (const int signal : {SIGINT, SIGTERM, SIGHUP}) {
    SQLite::Database holder(db, SQLite::OPEN_READWRITE);
    holder.exec("BEGIN IMMEDIATE");  // another writer: the import waits for it
    const std::string log = dir.File("err-" + std::to_string(signal));
    const pid_t child = SpawnArmsig(
        {"--db", db, "import", "poses", DataPath("ur10-ipa/series_C-measurements_random_poses.csv"),
         "--preset", "ur-ipa", "--robot", "ur10"},
        dir.File("out"), log, dir.path().string());
    ASSERT_GT(child, 0);
    // From its first moment in main the program handles the three signals.
    ASSERT_TRUE(WaitUntil([&] { return Catches(child, signal); }, std::chrono::seconds(30)));
    std::this_thread::sleep_for(std::chrono::milliseconds(200));
    ::kill(child, signal);
    int status = 0;
    ::waitpid(child, &status, 0);
    holder.exec("ROLLBACK");
    const std::string err = ReadText(log);
    ASSERT_TRUE(WIFEXITED(status)) << signal << ": " << status << "\n" << err;
    EXPECT_EQ(WEXITSTATUS(status), 130) << signal << "\n" << err;
    EXPECT_NE(err.find("stopped by a signal before finishing (exit 130): every store write and "
                       "output file is whole or absent; run the same command again"),
              std::string::npos)
        << err;
    EXPECT_EQ(holder.execAndGet("SELECT count(*) FROM sessions").getInt(), 0);
    for (const auto& entry : std::filesystem::directory_iterator(dir.path()))
      EXPECT_EQ(entry.path().filename().string().find(".tmp."), std::string::npos) << entry.path();
  }
  // Then the same command stores the session.
  EXPECT_EQ(RunArmsig("--db '" + db + "' import poses '" +
                      DataPath("ur10-ipa/series_C-measurements_random_poses.csv") +
                      "' --preset ur-ipa --robot ur10")
                .exit_code,
            0);
}

}  // namespace armsig::testing

#include "io/builtin_models.h"

namespace armsig::testing {

// A --db the demo could never open is refused before the virtual lab is built.
TEST(Cli, DemoRefusesAnUnusableServerUriFirst) {
  const auto r = RunArmsig("--db 'postgresql://localhost:badport/lab' demo --configurations 30");
  EXPECT_EQ(r.exit_code, 2) << r.err;
  EXPECT_NE(r.err.find("the port 'badport' is not a number"), std::string::npos) << r.err;
  EXPECT_EQ(r.out.find("virtual lab"), std::string::npos) << r.out;
}

// `demo --serve DIR`: the demo's virtual lab kept up for a capture by hand, with the lab
// file a technician would write; one capture drives it like a real lab (a tracker lab's
// base given as measured by hand, so every beam is pointed by prediction), then Ctrl-C
// ends it (exit 130, as every command a signal stops) and nothing was stored by it.
TEST(Cli, ServedVirtualLabIsDrivenByAHandCapture) {
  for (const std::string instrument : {"tracker", "theodolites"}) {
    TempDir dir;
    ServedLab served(dir, "lab", {"--instrument", instrument});
    ASSERT_TRUE(served.ready()) << served.errors();
    const std::string lab = served.folder();
    EXPECT_TRUE(std::filesystem::exists(lab + "/stations.yaml"));
    const auto r = RunArmsig("--db '" + dir.File("hand.db") + "' capture --lab '" + lab +
                             "/lab.yaml' --plan auto:12 --robot puma");
    EXPECT_EQ(r.exit_code, 0) << instrument << "\n" << r.err << r.out;
    EXPECT_NE(r.out.find("12 usable"), std::string::npos) << r.out;
    if (instrument == "tracker") {
      EXPECT_NE(r.out.find("12 pointed at the predicted target"), std::string::npos) << r.out;
    }
    const int status = served.Stop();
    ASSERT_TRUE(WIFEXITED(status));
    EXPECT_EQ(WEXITSTATUS(status), 130) << served.errors();
    EXPECT_FALSE(std::filesystem::exists(dir.File("unused.db")));
  }
}

TEST(BuiltinModels, DemoModelsAreTheShippedModelFiles) {
  EXPECT_EQ(std::string(io::kPuma760Yaml), ReadText(SourcePath("models/puma760.yaml")));
  EXPECT_EQ(std::string(io::kUr10Yaml), ReadText(SourcePath("models/ur10.yaml")));
  EXPECT_EQ(std::string(io::kIrb4600Yaml), ReadText(SourcePath("models/irb4600.yaml")));
  EXPECT_EQ(std::string(io::kKr16Yaml), ReadText(SourcePath("models/kr16_2.yaml")));
}

}  // namespace armsig::testing

namespace armsig::testing {

// A typo is named with the nearest valid word, on one line with the error prefix, exit 2:
// a command, a nested command, an option (before a required one is missed), a choice, a
// robot, a --params word (before any data is read).
TEST(Cli, TyposAreNamedWithTheNearestValidWord) {
  TempDir dir;
  struct Case {
    std::string args, expected;
  };
  for (const Case& c : {
           Case{"recalibrat --robot x", "unknown command 'armsig recalibrat' (did you mean 'armsig recalibrate'?)"},
           Case{"robot ad x --model m.yaml", "unknown command 'armsig robot ad' (did you mean 'armsig robot add'?)"},
           Case{"demo --configuration 50", "armsig demo: unknown option '--configuration' (did you mean '--configurations'?)"},
           Case{"activate --verison 3 --robot p", "armsig activate: unknown option '--verison' (did you mean '--version'?)"},
           Case{"sessions --robt p", "armsig sessions: unknown option '--robt' (did you mean '--robot'?)"},
           Case{"predict --robot p --frame robt --joints j.csv", "--frame: expected robot or measurement, got 'robt' (did you mean 'robot'?)"},
           Case{"calibrate --model '" + SourcePath("models/puma760.yaml") + "' --poses missing.csv --params geometrc",
                "unknown parameter 'geometrc' (did you mean 'geometric'?)"},
       }) {
    const auto r = RunArmsig(c.args, dir.path().string());
    EXPECT_EQ(r.exit_code, 2) << c.args;
    EXPECT_EQ(r.err.rfind("armsig: error: ", 0), 0u) << c.args << "\n" << r.err;
    EXPECT_NE(r.err.find(c.expected), std::string::npos) << c.args << "\n" << r.err;
  }
  // A robot name one letter off: the registered one is suggested.
  const std::string db = "--db '" + dir.File("lab.db") + "' ";
  ASSERT_EQ(RunArmsig(db + "robot add puma --model '" + SourcePath("models/puma760.yaml") + "'")
                .exit_code,
            0);
  const auto robot = RunArmsig(db + "versions --robot pumaa");
  EXPECT_EQ(robot.exit_code, 2);
  EXPECT_NE(robot.err.find("no robot pumaa in the database (did you mean puma?"), std::string::npos)
      << robot.err;
  // The manual's value names are plain words.
  const auto help = RunArmsig("demo --help");
  EXPECT_NE(help.out.find("--configurations N"), std::string::npos) << help.out;
  EXPECT_EQ(help.out.find("INT:"), std::string::npos) << help.out;
}

}  // namespace armsig::testing
