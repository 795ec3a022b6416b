// What the simulators serving binary protocols over TCP share (emscon_simulator.h,
// kuka_simulator.h): an acceptor listening on HOST:PORT, and a client connection whose answers
// go out in order, each after its delay (the device's latency), on the server's io thread.
#pragma once

// clang-format off
#include <utility>  // first: Boost 1.74 Asio uses std::exchange without including it (C++20)
#include <boost/asio.hpp>
// clang-format on
#include <chrono>
#include <deque>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "instruments/frame_splitter.h"

namespace armsig::simulation {

// An acceptor listening on `host`:`port` (0: any free port; local_endpoint() names the one
// taken). std::runtime_error naming `device` when the host is no IP address or the address
// cannot be bound.
std::unique_ptr<boost::asio::ip::tcp::acceptor> ListenTcp(boost::asio::io_context& io,
                                                          const std::string& host,
                                                          unsigned short port,
                                                          const std::string& device);

// One client connection. Used on the server's io thread only.
class TcpPeer {
 public:
  struct Step {
    std::chrono::microseconds delay{0};  // after the step before it went out
    std::string bytes;
  };
  explicit TcpPeer(boost::asio::io_context& io) : socket(io) {}
  virtual ~TcpPeer() = default;

  // Closes the connection; what is queued is dropped.
  void Close();
  // Queues `steps` behind those queued before: each is written after its delay.
  static void Send(const std::shared_ptr<TcpPeer>& peer, std::vector<Step> steps);

  boost::asio::ip::tcp::socket socket;
  bool closed = false;

 private:
  static void Pump(std::shared_ptr<TcpPeer> peer);
  std::deque<Step> out_;
  bool writing_ = false;
};

// A connection whose requests are length-prefixed binary frames.
class FramedPeer : public TcpPeer {
 public:
  FramedPeer(boost::asio::io_context& io, const instruments::FrameSplitter::Format& format)
      : TcpPeer(io), splitter_(format) {}
  // Reads the connection's frames, each to `on_frame`, until it closes or fails; bytes whose
  // size field is out of bounds are dropped (logged under `device`), and reading goes on.
  static void ReadFrames(const std::shared_ptr<FramedPeer>& peer, std::string device,
                         std::function<void(const std::string& frame)> on_frame);

 private:
  instruments::FrameSplitter splitter_;
  char chunk_[4096];
};

}  // namespace armsig::simulation
