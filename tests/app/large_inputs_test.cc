// Large inputs read row by row, through the binary: a million-row pose table (105 MB) goes
// through `import poses` and is refused by `calibrate --poses` at its limit, each under a
// stated memory bound: the peak resident memory of the child (wait4) at most 48 MiB above
// the binary's own (`armsig --version`). Before, `import poses` held the whole file and its
// table of strings (879 MB for this file) and `calibrate` read it all before fitting it.
#include <gtest/gtest.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <string>
#include <vector>

#include "test_support.h"

#if defined(__SANITIZE_ADDRESS__)
#define ARMSIG_UNDER_ASAN 1
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
#define ARMSIG_UNDER_ASAN 1
#endif
#endif

namespace armsig::testing {
namespace {

struct Measured {
  int exit_code = -1;
  long peak_kib = 0;  // the child's peak resident set (ru_maxrss)
  double seconds = 0;
  std::string err;
};

// Runs the binary with `args` (stdout to /dev/null); its exit code, peak RSS and time. The
// child is capped at 4 GiB so that a reader that holds everything fails instead of taking the
// machine: its address space, or under AddressSanitizer (whose shadow reserves terabytes of
// addresses) its resident memory (hard_rss_limit_mb). Under ASan freed memory is returned at
// once (no quarantine, which would hold every freed block): the peak is then the program's
// own plus ASan's fixed cost, which the `--version` baseline carries too.
Measured RunMeasured(const std::vector<std::string>& args, const TempDir& dir) {
  const std::string err = dir.File("measured.err");
  const auto start = std::chrono::steady_clock::now();
  std::fflush(nullptr);  // nothing buffered is written twice
  const pid_t pid = ::fork();
  if (pid == 0) {
#ifdef ARMSIG_UNDER_ASAN
    const char* given = std::getenv("ASAN_OPTIONS");
    const std::string options = std::string(given ? given : "") +
                                ":quarantine_size_mb=0:thread_local_quarantine_size_kb=0"
                                ":hard_rss_limit_mb=4096";
    ::setenv("ASAN_OPTIONS", options.c_str(), 1);
#else
    const rlimit cap{rlim_t{4} << 30, rlim_t{4} << 30};
    ::setrlimit(RLIMIT_AS, &cap);
#endif
    std::freopen("/dev/null", "w", stdout);
    std::freopen(err.c_str(), "w", stderr);
    std::vector<char*> argv{const_cast<char*>(ARMSIG_BINARY)};
    for (const auto& a : args) argv.push_back(const_cast<char*>(a.c_str()));
    argv.push_back(nullptr);
    ::execv(ARMSIG_BINARY, argv.data());
    ::_exit(127);
  }
  Measured m;
  int status = 0;
  rusage usage{};
  ::wait4(pid, &status, 0, &usage);
  m.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  m.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  m.peak_kib = usage.ru_maxrss;
  m.err = ReadText(err);
  return m;
}

// `rows` poses in the interface reference's format (pose,q1_deg…q6_deg,x_mm,y_mm,z_mm),
// every value within the plausible ranges.
void WritePoseTable(const std::string& path, int rows) {
  std::FILE* f = std::fopen(path.c_str(), "w");
  ASSERT_NE(f, nullptr);
  std::fputs("pose,q1_deg,q2_deg,q3_deg,q4_deg,q5_deg,q6_deg,x_mm,y_mm,z_mm\n", f);
  for (int k = 0; k < rows; ++k) {
    std::fprintf(f, "p%d,%.6f,%.6f,%.6f,%.6f,%.6f,%.6f,%.6f,%.6f,%.6f\n", k,
                 (k * 37 % 3600) / 10.0 - 180, (k * 53 % 1800) / 10.0 - 90,
                 (k * 71 % 2400) / 10.0 - 120, (k * 13 % 3600) / 10.0 - 180,
                 (k * 29 % 2000) / 10.0 - 100, (k * 31 % 3600) / 10.0 - 180, 500 + (k % 1000) * 0.7,
                 -300 + (k % 777) * 0.9, 200 + (k % 555) * 1.1);
  }
  std::fclose(f);
}

size_t LineCount(const std::string& path) {
  std::ifstream in(path);
  size_t n = 0;
  for (std::string line; std::getline(in, line);) ++n;
  return n;
}

TEST(LargeInputs, AMillionRowPoseTableStaysWithinTheMemoryBound) {
  TempDir dir;
  const std::string table = dir.File("poses.csv");
  WritePoseTable(table, 1000000);
  const Measured baseline = RunMeasured({"--version"}, dir);
  ASSERT_EQ(baseline.exit_code, 0);
  const long bound_kib = baseline.peak_kib + 48 * 1024;

  // import poses: every row read, converted and written to --out, one row at a time.
  const std::string out = dir.File("out.csv");
  const Measured import = RunMeasured(
      {"import", "poses", table, "--joint-columns", "q1_deg,q2_deg,q3_deg,q4_deg,q5_deg,q6_deg",
       "--joint-unit", "deg", "--xyz-columns", "x_mm,y_mm,z_mm", "--id", "pose", "--out", out},
      dir);
  std::cout << "1,000,000 poses: import poses " << import.seconds << " s, peak "
            << import.peak_kib / 1024 << " MiB (binary alone " << baseline.peak_kib / 1024
            << " MiB, bound " << bound_kib / 1024 << " MiB)\n";
  EXPECT_EQ(import.exit_code, 0) << import.err;
  EXPECT_LE(import.peak_kib, bound_kib);
  EXPECT_EQ(LineCount(out), 1000001u);

  // calibrate --poses: refused at the row past its limit, having held no more than that.
  const Measured calibrate = RunMeasured(
      {"calibrate", "--model", SourcePath("models/puma760.yaml"), "--poses", table}, dir);
  std::cout << "calibrate --poses refused after " << calibrate.seconds << " s, peak "
            << calibrate.peak_kib / 1024 << " MiB\n";
  EXPECT_EQ(calibrate.exit_code, 2) << calibrate.err;
  EXPECT_NE(calibrate.err.find("poses.csv:100002"), std::string::npos) << calibrate.err;
  EXPECT_NE(calibrate.err.find("more than 100000 poses"), std::string::npos) << calibrate.err;
  EXPECT_LE(calibrate.peak_kib, bound_kib);
}

}  // namespace
}  // namespace armsig::testing
