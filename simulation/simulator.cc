#include "simulation/simulator.h"

namespace armsig::simulation {

void FaultQueue::Once(FaultSpec fault) {
  std::lock_guard lock(mutex_);
  once_.push_back(fault);
}

void FaultQueue::Always(FaultSpec fault) {
  std::lock_guard lock(mutex_);
  always_ = fault;
}

void FaultQueue::Clear() {
  std::lock_guard lock(mutex_);
  once_.clear();
  always_.reset();
}

FaultSpec FaultQueue::Next() {
  std::lock_guard lock(mutex_);
  if (!once_.empty()) {
    const FaultSpec fault = once_.front();
    once_.pop_front();
    return fault;
  }
  return always_.value_or(FaultSpec{});
}

}  // namespace armsig::simulation
