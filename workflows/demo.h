// armsig demo: the whole chain on a virtual lab. A PUMA 760 with hidden true errors (the
// paper's Table 3, h1…h4 included), three theodolites speaking GeoCOM and a
// Kawasaki-AS-style controller on pseudo-terminals, all through the real drivers: the
// stations are oriented from mutual pointings and a scale bar, the configurations are
// captured into the database, reduced, and the best-spread ones calibrated with the
// paper's three parameter sets, validated on the others.
#pragma once

#include <atomic>
#include <functional>
#include <nlohmann/json.hpp>
#include <string>

#include "acquisition/session.h"

namespace armsig::workflows {

struct DemoOptions {
  std::string db_path;
  int configurations = 200;  // captured
  int select = 80;           // fitted (D-optimal), the rest validate
  double time_scale = 0.25;  // multiplies every simulated instrument latency
  unsigned seed = 1985;
  const std::atomic<bool>* stop = nullptr;  // Ctrl-C: stop the capture between configurations
};

struct DemoObserver {
  std::function<void(const std::string&)> say;  // the narrative, one block at a time
  std::function<void(const acquisition::Progress&)> progress;
};

struct DemoResult {
  int64_t session = 0;
  bool completed = false;  // false when stopped before the end (the session is paused)
  double seconds = 0.0;
  nlohmann::json json;     // the --json document
};

DemoResult RunDemo(const DemoOptions& options, const DemoObserver& observer);

}  // namespace armsig::workflows
