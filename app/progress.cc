// The progress line of a long read on stderr (a terminal only): "poses.csv: 45% (123 of
// 270 MB, 1,234,567 rows)", redrawn at most five times a second, shown only once a read has
// taken a second, and ended with a newline.
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <memory>

#include "app/command.h"
#include "core/text.h"

namespace armsig::app {

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
    std::fprintf(stderr, "\r%s: %3.0f%% (%.0f of %.0f MB, %lld rows)%s",
                 Printable(p.source).c_str(), percent, p.bytes / 1e6, p.total_bytes / 1e6,
                 static_cast<long long>(p.rows), done ? "\n" : "");
    std::fflush(stderr);
  };
}

}  // namespace armsig::app
