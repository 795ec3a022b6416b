// Internal to acquisition/ (session.cc): the thread pool of a capture's parallel steps.
#pragma once

#include <algorithm>
#include <boost/asio/post.hpp>
#include <boost/asio/thread_pool.hpp>
#include <exception>
#include <functional>
#include <future>
#include <memory>
#include <optional>
#include <vector>

namespace armsig::acquisition {

// The threads of a capture's parallel steps (every instrument and the joints at once),
// started once for the session: a step starts no thread, and its first task runs on the
// calling thread, so one tracker alone is measured without any hand-over between threads.
class Crew {
 public:
  explicit Crew(size_t threads) : pool_(std::max<size_t>(threads, 1)) {}
  ~Crew() { pool_.join(); }
  Crew(const Crew&) = delete;
  Crew& operator=(const Crew&) = delete;

  template <typename F>
  auto Spawn(F f) -> std::future<decltype(f())> {
    auto task = std::make_shared<std::packaged_task<decltype(f())()>>(std::move(f));
    auto future = task->get_future();
    boost::asio::post(pool_, [task] { (*task)(); });
    return future;
  }

  // Runs every task at once, the first here, and waits for all of them (they may hold
  // references into the caller's frame); their results in order, else the first failure
  // in task order.
  template <typename T>
  std::vector<T> Together(std::vector<std::function<T()>>& tasks) {
    std::vector<std::future<T>> others;
    for (size_t i = 1; i < tasks.size(); ++i) others.push_back(Spawn(tasks[i]));
    std::vector<std::optional<T>> results(tasks.size());
    std::exception_ptr failure;
    if (!tasks.empty()) {
      try {
        results[0] = tasks[0]();
      } catch (...) {
        failure = std::current_exception();
      }
    }
    for (size_t i = 1; i < tasks.size(); ++i) {
      try {
        results[i] = others[i - 1].get();
      } catch (...) {
        if (!failure) failure = std::current_exception();
      }
    }
    if (failure) std::rethrow_exception(failure);
    std::vector<T> out;
    for (auto& r : results) out.push_back(std::move(*r));
    return out;
  }

 private:
  boost::asio::thread_pool pool_;
};

}  // namespace armsig::acquisition
