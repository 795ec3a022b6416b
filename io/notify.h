// A lab's notification command (mail, a chat hook): run through /bin/sh with a text on
// its standard input and a few variables in its environment, bounded in time, so a stalled
// mail server never holds the nightly job.
#pragma once

#include <chrono>
#include <string>
#include <utility>
#include <vector>

namespace armsig::io {

struct NotifyResult {
  bool started = false;
  bool timed_out = false;  // killed (its whole process group) after the time limit
  int exit_code = -1;      // when it ended by itself: its exit status, or 128 + signal
  std::string error;       // why it could not start
  bool ok() const { return started && !timed_out && exit_code == 0; }
};

// Runs `command` with `input` on its standard input (a file in memory: the command may
// read all, part or none of it) and `environment` added to this process's, its output
// going where this process's goes.
NotifyResult RunNotifyCommand(const std::string& command, const std::string& input,
                              const std::vector<std::pair<std::string, std::string>>& environment,
                              std::chrono::milliseconds limit = std::chrono::seconds(60));

}  // namespace armsig::io
