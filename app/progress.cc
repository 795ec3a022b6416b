// Progress lines on stderr, on a terminal only, redrawn in place and as wide as the
// terminal: a long read ("poses.csv: 45% (123 of 270 MB, 1,234,567 rows)", shown once a
// read has taken a second, at most five times a second, ended with a newline) and a
// capture's progress (workflows::FormatCaptureProgress).
#include <sys/ioctl.h>
#include <unistd.h>

#include <fmt/format.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <iostream>
#include <memory>
#include <string>

#include "app/command.h"
#include "core/text.h"
#include "core/text_layout.h"
#include "workflows/capture.h"

namespace armsig::app {

int TerminalColumns(int fd) {
  struct winsize size {};
  if (::ioctl(fd, TIOCGWINSZ, &size) == 0 && size.ws_col > 0) return size.ws_col;
  if (const char* columns = std::getenv("COLUMNS")) {
    char* end = nullptr;
    const long n = std::strtol(columns, &end, 10);
    if (end != columns && *end == '\0' && n > 0 && n < 10000) return static_cast<int>(n);
  }
  return 80;
}

std::function<void(const acquisition::Progress&)> TerminalCaptureProgress(bool clear_when_done) {
  if (!::isatty(STDERR_FILENO)) return nullptr;
  return [clear_when_done](const acquisition::Progress& p) {
    // One column short of the width: a line that fills it would wrap on some terminals.
    const int width = TerminalColumns(STDERR_FILENO) - 1;
    // "\x1b[K": the rest of the line erased, whatever the last, longer line left there.
    std::cerr << "\r" << workflows::FormatCaptureProgress(p, width) << "\x1b[K";
    if (clear_when_done && p.total > 0 && p.done >= p.total) std::cerr << "\r\x1b[K";
    std::cerr << std::flush;
  };
}

namespace {

// The last `columns` columns of `text`, "…" in front when it was cut ("" for no room).
std::string LastColumns(const std::string& text, int columns) {
  if (DisplayWidth(text) <= columns) return text;
  if (columns < 2) return "";
  size_t at = text.size();
  int kept = 0;
  while (at > 0 && kept < columns - 1) {
    --at;
    if ((static_cast<unsigned char>(text[at]) & 0xc0) != 0x80) ++kept;  // a character's start
  }
  return "…" + text.substr(at);
}

}  // namespace

io::ReadProgressFn TerminalReadProgress() {
  if (!::isatty(STDERR_FILENO)) return nullptr;
  using Clock = std::chrono::steady_clock;
  struct State {
    Clock::time_point start = Clock::now(), last;
    bool shown = false;
  };
  auto state = std::make_shared<State>();
  return [state](const io::ReadProgress& p) {
    const auto now = Clock::now();
    const bool done = p.bytes >= p.total_bytes;
    if (!done && (now - state->start < std::chrono::seconds(1) ||
                  now - state->last < std::chrono::milliseconds(200)))
      return;
    if (done && !state->shown) return;  // a short read: nothing to show
    state->last = now;
    state->shown = true;
    const double percent =
        p.total_bytes ? 100.0 * static_cast<double>(p.bytes) / static_cast<double>(p.total_bytes)
                      : 100.0;
    // Within the terminal's width: the file's name gives way first (its end kept).
    const int width = TerminalColumns(STDERR_FILENO) - 1;
    const std::string figures = fmt::format(": {:3.0f}% ({:.0f} of {:.0f} MB, {} rows)", percent,
                                            p.bytes / 1e6, p.total_bytes / 1e6, p.rows);
    const std::string line =
        LastColumns(Printable(p.source), width - DisplayWidth(figures)) + figures;
    const std::string shown(TruncateUtf8(line, static_cast<size_t>(std::max(width, 0))));
    std::fprintf(stderr, "\r%s\x1b[K%s", shown.c_str(), done ? "\n" : "");
    std::fflush(stderr);
  };
}

}  // namespace armsig::app
