// A request to stop a long computation, made from outside it (a signal handler's flag, a
// worker told to shut down). The computation looks at it between steps it can abandon — a
// solver iteration, a candidate, a fold — and throws Stopped, so a fit of minutes stops
// within a step and its caller stores nothing. A default token is never set.
#pragma once

#include <atomic>
#include <exception>

namespace armsig::core {

struct Stopped : std::exception {
  const char* what() const noexcept override { return "stopped on request"; }
};

class StopToken {
 public:
  StopToken() = default;
  explicit StopToken(const std::atomic<bool>* flag) : flag_(flag) {}
  bool requested() const { return flag_ != nullptr && flag_->load(std::memory_order_relaxed); }
  void ThrowIfRequested() const {
    if (requested()) throw Stopped();
  }

 private:
  const std::atomic<bool>* flag_ = nullptr;
};

}  // namespace armsig::core
