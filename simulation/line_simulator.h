// A virtual instrument on a pseudo-terminal that answers request lines: the port, the
// Boost.Asio loop on its own thread, latency, faults and floods. Each protocol's simulator
// derives from it and answers one line at a time (Handle); drivers open the slave by path
// like any serial port.
#pragma once

#include <atomic>
// clang-format off
#include <utility>  // first: Boost 1.74 Asio uses std::exchange without including it (C++20)
#include <boost/asio.hpp>
// clang-format on
#include <chrono>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <thread>

#include "simulation/simulator.h"
#include "simulation/virtual_port.h"

namespace armsig::simulation {

class LineSimulator : public Simulator {
 public:
  LineSimulator(std::string link_path, SimulatorOptions options);
  ~LineSimulator() override;
  LineSimulator(const LineSimulator&) = delete;
  LineSimulator& operator=(const LineSimulator&) = delete;

  void Start() override;
  void Stop() override;
  const std::string& path() const override { return port_.path(); }
  void InjectOnce(FaultSpec fault) override;
  void InjectAlways(FaultSpec fault) override;
  void ClearFaults() override;
  void Disappear();  // the port vanishes (thread-safe)
  void Reappear();
  int requests() const override { return requests_.load(); }
  int64_t flood_bytes() const override { return flood_bytes_.load(); }

 protected:
  struct Response {
    std::string bytes;
    std::chrono::milliseconds latency{0};
  };
  // Handles one request line; nullopt = silence.
  virtual std::optional<Response> Handle(const std::string& line, const FaultSpec& fault) = 0;
  // The k-th line of a kFloodLines flood (with its terminator): the protocol's own kind
  // of line, never the reply to `request`.
  virtual std::string FloodLine(const std::string& request, int64_t k) = 0;
  std::chrono::milliseconds Scaled(std::chrono::milliseconds latency) const;
  SimulatorOptions options_;

 private:
  void StartRead();
  void OnLine(const std::string& line);
  void Send(std::string bytes, std::chrono::milliseconds latency);
  void Vanish();  // on the io thread
  // Writes chunks made by `next` back to back until the fault is cleared or the port
  // goes; one flood at a time.
  void StartFlood(std::function<std::string(int64_t)> next);
  void FloodMore(std::shared_ptr<std::function<std::string(int64_t)>> next, int64_t k,
                 uint64_t generation);
  void FloodChunk(std::shared_ptr<std::function<std::string(int64_t)>> next, int64_t k,
                  uint64_t generation, std::shared_ptr<std::string> data, size_t offset);

  VirtualPort port_;
  boost::asio::io_context io_;
  std::unique_ptr<boost::asio::posix::stream_descriptor> descriptor_;
  std::thread thread_;
  std::string buffer_;
  char chunk_[512];
  FaultQueue faults_;
  std::atomic<int> requests_{0};
  std::atomic<int64_t> flood_bytes_{0};
  std::atomic<uint64_t> flood_generation_{0};  // a cleared flood stops at its next chunk
  bool flooding_ = false;
  bool present_ = true;
  std::optional<boost::asio::executor_work_guard<boost::asio::io_context::executor_type>> work_;
};

}  // namespace armsig::simulation
