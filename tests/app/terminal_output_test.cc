// What a technician reads on a terminal, through the program: every line of the demo's and
// calibrate's output within 100 columns, the residual map's decision said once and in words
// that agree with its numbers, sigmas with significant digits, the capture's progress line
// as wide as the terminal (a real pseudo-terminal of 50 columns) and absent off a terminal,
// times with their zone, and exit 130 for a command a signal stops.
#include <fcntl.h>
#include <gtest/gtest.h>
#include <pty.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <nlohmann/json.hpp>
#include <random>
#include <regex>
#include <sstream>

#include "calibration/synthetic.h"
#include "core/text_layout.h"
#include "io/poses_csv.h"
#include "test_support.h"

namespace armsig::testing {
namespace {

// Every line within 100 columns, but those that name a path of this test's (their length
// is the machine's, not the program's).
void ExpectLinesFit(const std::string& text, const std::string& path) {
  for (const auto& line : Lines(text)) {
    if (line.find(path) != std::string::npos) continue;
    EXPECT_LE(DisplayWidth(line), 100) << line;
  }
}

// The demo on 60 configurations (24 fitted: enough for the residual map's 5-fold
// cross-validation), once for every test here.
class DemoOutput : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new TempDir;
    result_ = new CommandResult(
        RunArmsig("--db '" + dir_->File("demo.db") + "' demo --configurations 60 --time-scale 0",
                  dir_->path().string()));
  }
  static void TearDownTestSuite() {
    delete result_;
    delete dir_;
  }
  static TempDir* dir_;
  static CommandResult* result_;
};
TempDir* DemoOutput::dir_ = nullptr;
CommandResult* DemoOutput::result_ = nullptr;

}  // namespace

TEST_F(DemoOutput, EveryLineFitsAHundredColumns) {
  ASSERT_EQ(result_->exit_code, 0) << result_->err;
  ExpectLinesFit(result_->out, "/tmp");
  // The parameter tables are whole rows: every label with its values on its own line.
  std::smatch m;
  const std::regex row(R"((alpha|beta|gamma)_i \(1e-3 rad\) +\S)");
  int rows = 0;
  for (const auto& line : Lines(result_->out)) rows += std::regex_search(line, m, row);
  EXPECT_EQ(rows, 3 * 3 * 2) << result_->out;  // three stages, values and sigmas
}

// The decision is said once (stdout, not again in the log), and "better" or "worse" is what
// its own two figures say.
TEST_F(DemoOutput, ResidualMapDecisionIsSaidOnceInWordsThatAgreeWithItsNumbers) {
  ASSERT_EQ(result_->exit_code, 0) << result_->err;
  const std::string all = result_->out + result_->err;
  const size_t at = all.find("residual map");
  ASSERT_NE(at, std::string::npos) << all;
  EXPECT_EQ(all.find("residual map", at + 1), std::string::npos) << all;
  // Joined across the wrap, then read.
  std::string line = all.substr(at, all.find("\n\n", at) - at);
  line = std::regex_replace(line, std::regex(R"(\s+)"), " ");
  std::smatch m;
  ASSERT_TRUE(std::regex_search(
      line, m,
      std::regex(
          R"(([0-9.]+) mm with the map, ([0-9.]+) mm without it: (only )?([0-9.]+) % (better|worse))")))
      << line;
  const double with = std::stod(m[1]), without = std::stod(m[2]), percent = std::stod(m[4]);
  EXPECT_EQ(m[5] == "better", with < without) << line;
  EXPECT_NEAR(percent, 100.0 * std::abs(with / without - 1.0), 0.1 + 100 * 5e-5 / without) << line;
  const bool used = line.rfind("residual map used", 0) == 0;
  EXPECT_EQ(used, m[5] == "better" && percent >= 5.0) << line;
  EXPECT_EQ(line.find("not used: needs"), std::string::npos) << line;
}

TEST_F(DemoOutput, CountsTakeTheirPlural) {
  ASSERT_EQ(result_->exit_code, 0) << result_->err;
  std::smatch m;
  // "1 rays", "1 stations", "1 configurations": a count of one with a plural noun.
  const std::string out = std::regex_replace(result_->out, std::regex(R"(\s+)"), " ");
  EXPECT_FALSE(std::regex_search(
      out, m,
      std::regex(
          R"(\b1 (rays|stations|configurations|points|readings|observations|iterations|degrees)\b)")))
      << m[0];
  EXPECT_NE(out.find("degrees of freedom"), std::string::npos);
}

// The robot list of the demo's store: its one robot with its one session, said in the
// singular.
TEST_F(DemoOutput, TheRobotListCountsItsSessionsInWords) {
  ASSERT_EQ(result_->exit_code, 0) << result_->err;
  const auto r = RunArmsig("--db '" + dir_->File("demo.db") + "' robot list");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find(" 1 session "), std::string::npos) << r.out;
  EXPECT_EQ(r.out.find("1 sessions"), std::string::npos) << r.out;
}

// Stored times are shown with their zone (ISO 8601: Z or an offset), never as a bare clock.
TEST_F(DemoOutput, VersionsSessionsAndJobsShowTimesWithTheirZone) {
  ASSERT_EQ(result_->exit_code, 0) << result_->err;
  const std::string db = "--db '" + dir_->File("demo.db") + "' ";
  ASSERT_EQ(RunArmsig(db + "schedule recalibrate --all").exit_code, 0);
  const std::regex time(R"(\d{4}-\d\d-\d\dT\d\d:\d\d:\d\d(\.\d+)?([^\d.]|$))");
  const std::regex zoned(R"(\d{4}-\d\d-\d\dT\d\d:\d\d:\d\d(Z|[+-]\d\d:?\d\d))");
  for (const std::string command : {"versions --robot puma760-demo", "sessions", "jobs"}) {
    const auto r = RunArmsig(db + command);
    ASSERT_EQ(r.exit_code, 0) << command << "\n" << r.err;
    const int times = static_cast<int>(std::distance(
        std::sregex_iterator(r.out.begin(), r.out.end(), time), std::sregex_iterator()));
    const int with_zone = static_cast<int>(std::distance(
        std::sregex_iterator(r.out.begin(), r.out.end(), zoned), std::sregex_iterator()));
    EXPECT_GT(times, 0) << command << "\n" << r.out;
    EXPECT_EQ(with_zone, times) << command << "\n" << r.out;
    ExpectLinesFit(r.out, "/tmp");
  }
}

// The report of a demo's set (`armsig report`): the run named its poses by their bare
// labels (one session's), and the report still finds every validation pose.
TEST_F(DemoOutput, TheReportOfADemoSetFindsItsValidationPoses) {
  ASSERT_EQ(result_->exit_code, 0) << result_->err;
  const auto r = RunArmsig("--db '" + dir_->File("demo.db") +
                           "' report --robot puma760-demo --out '" + dir_->File("report") + "'");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(r.err.find("left out of this page"), std::string::npos) << r.err;
  EXPECT_NE(ReadText(dir_->File("report/index.html")).find("on the 36 validation poses"),
            std::string::npos);
  // Its session discarded: the poses are still stored, only kept out of use, and the report
  // says so (it said "no longer stored").
  const std::string db = "--db '" + dir_->File("demo.db") + "' ";
  ASSERT_EQ(RunArmsig(db + "session discard 1 --reason 'wrong set-up'").exit_code, 0);
  const auto discarded =
      RunArmsig(db + "report --robot puma760-demo --out '" + dir_->File("report2") + "'");
  EXPECT_NE(discarded.err.find("36 validation configurations of version "), std::string::npos)
      << discarded.err;
  EXPECT_NE(discarded.err.find(" are in session 1 (discarded since: stored, kept out of use): "
                               "left out of this page"),
            std::string::npos)
      << discarded.err;
  ASSERT_EQ(RunArmsig(db + "session restore 1").exit_code, 0);
}

// calibrate's tables: whole rows within 100 columns; every sigma of an identified parameter
// with two significant digits (never "0.000"), and equal to the JSON's sigma to that rounding.
TEST(CalibrateOutput, SigmasHaveSignificantDigitsAndTheTablesFit) {
  const auto model = Puma();
  std::mt19937 rng(31);
  TempDir dir;
  const auto poses = calibration::SimulatePoses(
      model, Eigen::Isometry3d::Identity(), calibration::PaperTable3Parameters(),
      calibration::RandomConfigurations(model, 160, rng), 0.002, rng);
  WriteText(dir.File("poses.csv"), io::FormatPosesCsv(poses));
  const auto r =
      RunArmsig("calibrate --model '" + SourcePath("models/puma760.yaml") + "' --poses '" +
                dir.File("poses.csv") + "' --select 80 --json '" + dir.File("out.json") + "'");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  ExpectLinesFit(r.out, dir.path().string());
  const auto j = nlohmann::json::parse(ReadText(dir.File("out.json")));
  // The sigma table: the block after "sigma, i =".
  const auto lines = Lines(r.out);
  size_t k = 0;
  while (k < lines.size() && lines[k].rfind("sigma, i =", 0) != 0) ++k;
  ASSERT_LT(k, lines.size()) << r.out;
  const char* rows[] = {"a_i (mm)",           "b_i (mm)",          "c_i (mm)",
                        "alpha_i (1e-3 rad)", "beta_i (1e-3 rad)", "gamma_i (1e-3 rad)"};
  int checked = 0;
  for (int row = 0; row < 6; ++row) {
    const std::string& line = lines[k + 1 + row];
    ASSERT_EQ(line.rfind(rows[row], 0), 0u) << line;
    std::istringstream cells(line.substr(std::string(rows[row]).size()));
    int column = 0;
    for (std::string cell; cells >> cell; ++column) {
      const int index = column < 6 ? 6 * column + row : 36 + row;
      if (cell == "—" || cell == "off") continue;
      EXPECT_NE(cell, "0.000") << line;
      const size_t first = cell.find_first_not_of("0.");
      ASSERT_NE(first, std::string::npos) << line;
      int digits = 0;
      for (size_t i = first; i < cell.size(); ++i) digits += cell[i] != '.';
      EXPECT_EQ(digits, 2) << cell << " in " << line;
      const double sigma = j["parameters"][index]["sigma"].get<double>() * (row < 3 ? 1.0 : 1e3);
      const double shown = std::stod(cell);
      EXPECT_LE(std::abs(shown - sigma), 0.051 * shown) << j["parameters"][index]["name"];
      ++checked;
    }
  }
  EXPECT_EQ(checked, 29 - 4);  // the identified geometric parameters (h1…h4 below the table)
}

namespace {

// Runs armsig with its stderr on a pseudo-terminal `columns` wide (stdout to `out`); returns
// what the terminal received and the exit status.
std::string RunOnTerminal(const std::vector<std::string>& args, int columns, const std::string& out,
                          int* status) {
  int master = -1, slave = -1;
  struct winsize size {};
  size.ws_row = 24;
  size.ws_col = static_cast<unsigned short>(columns);
  if (::openpty(&master, &slave, nullptr, nullptr, &size) != 0) return "(no pty)";
  const pid_t child = ::fork();
  if (child == 0) {
    ::close(master);
    ::dup2(slave, 2);
    ::dup2(::open(out.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0600), 1);
    ::close(slave);
    ::unsetenv("COLUMNS");
    std::vector<std::string> words = args;
    words.insert(words.begin(), ARMSIG_BINARY);
    std::vector<char*> argv;
    for (auto& w : words) argv.push_back(w.data());
    argv.push_back(nullptr);
    ::execv(argv[0], argv.data());
    _exit(127);
  }
  ::close(slave);
  std::string received;
  char buffer[4096];
  for (;;) {  // until the child's end closes the terminal's last slave (EIO)
    const ssize_t n = ::read(master, buffer, sizeof buffer);
    if (n <= 0) break;
    received.append(buffer, static_cast<size_t>(n));
  }
  ::close(master);
  ::waitpid(child, status, 0);
  return received;
}

}  // namespace

// On a 50-column terminal every redraw of the progress line fits in 49 columns (one left
// for the cursor); with stderr in a file there is no progress line at all.
TEST(TerminalProgress, FitsTheTerminalAndIsAbsentOffIt) {
  TempDir dir;
  int status = 0;
  const std::string terminal = RunOnTerminal(
      {"--db", dir.File("pty.db"), "demo", "--configurations", "25", "--time-scale", "0"}, 50,
      dir.File("out"), &status);
  ASSERT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0) << terminal;
  int redraws = 0;
  std::string segment;
  auto check = [&] {
    // Without the erase-to-end-of-line sequence, which takes no column.
    const std::string shown = std::regex_replace(segment, std::regex("\x1b\\[K"), "");
    if (shown.find("ETA") != std::string::npos) {
      ++redraws;
      EXPECT_LE(DisplayWidth(shown), 49) << shown;
      EXPECT_TRUE(std::regex_search(shown, std::regex(R"(\b\d+/25 )"))) << shown;  // done/total
    }
    segment.clear();
  };
  for (char c : terminal) {
    if (c == '\r' || c == '\n') {
      check();
    } else {
      segment += c;
    }
  }
  check();
  EXPECT_GE(redraws, 25) << terminal;

  const auto off =
      RunArmsig("--db '" + dir.File("file.db") + "' demo --configurations 25 --time-scale 0");
  ASSERT_EQ(off.exit_code, 0) << off.err;
  EXPECT_EQ(off.err.find('\r'), std::string::npos) << off.err;
  EXPECT_EQ(off.err.find("ETA"), std::string::npos) << off.err;
}

// A virtual instrument served until Ctrl-C: stopped by the signal, it exits 130 as every
// command a signal stops; one given seconds that run out exits 0.
TEST(Interrupted, AServedInstrumentStoppedByCtrlCExits130) {
  TempDir dir;
  const std::string out = dir.File("out"), err = dir.File("err");
  const pid_t child = ::fork();
  if (child == 0) {
    ::dup2(::open(out.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0600), 1);
    ::dup2(::open(err.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0600), 2);
    const std::string link = dir.File("tps");
    ::execl(ARMSIG_BINARY, ARMSIG_BINARY, "instrument", "simulate", "--protocol", "geocom",
            "--link", link.c_str(), static_cast<char*>(nullptr));
    _exit(127);
  }
  int status = 0;
  ASSERT_TRUE(WaitForChildOr(child, &status, [&] {
    return ReadText(out).find("until Ctrl-C") != std::string::npos;
  })) << ReadText(err);
  ::kill(child, SIGINT);
  ::waitpid(child, &status, 0);
  ASSERT_TRUE(WIFEXITED(status)) << status;
  EXPECT_EQ(WEXITSTATUS(status), 130) << ReadText(err);
  const auto timed = RunArmsig("instrument simulate --protocol geocom --link '" + dir.File("tps2") +
                               "' --seconds 0.1");
  EXPECT_EQ(timed.exit_code, 0) << timed.err;
}

}  // namespace armsig::testing
