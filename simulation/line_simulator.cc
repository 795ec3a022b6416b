#include "simulation/line_simulator.h"

#include <unistd.h>

#include <cmath>
#include <future>

namespace armsig::simulation {

namespace asio = boost::asio;

LineSimulator::LineSimulator(std::string link_path, SimulatorOptions options)
    : options_(options), port_(std::move(link_path)) {}

LineSimulator::~LineSimulator() { Stop(); }

std::chrono::milliseconds LineSimulator::Scaled(std::chrono::milliseconds latency) const {
  return std::chrono::milliseconds(
      static_cast<long>(std::llround(latency.count() * options_.time_scale)));
}

void LineSimulator::Start() {
  descriptor_ = std::make_unique<asio::posix::stream_descriptor>(io_, ::dup(port_.master_fd()));
  work_.emplace(asio::make_work_guard(io_));
  StartRead();
  thread_ = std::thread([this] { io_.run(); });
}

void LineSimulator::Stop() {
  if (!thread_.joinable()) return;
  asio::post(io_, [this] {
    boost::system::error_code ignored;
    if (descriptor_) descriptor_->close(ignored);
    work_.reset();
  });
  io_.stop();
  thread_.join();
}

void LineSimulator::InjectOnce(FaultSpec fault) { faults_.Once(fault); }

void LineSimulator::InjectAlways(FaultSpec fault) { faults_.Always(fault); }

void LineSimulator::ClearFaults() {
  faults_.Clear();
  ++flood_generation_;
  std::promise<void> done;
  asio::post(io_, [&] {
    flooding_ = false;
    done.set_value();
  });
  done.get_future().wait();
}

void LineSimulator::Vanish() {
  present_ = false;
  flooding_ = false;
  ++flood_generation_;
  boost::system::error_code ignored;
  if (descriptor_) descriptor_->close(ignored);  // our duplicate of the master
  port_.Disappear();
  buffer_.clear();
}

void LineSimulator::Disappear() {
  std::promise<void> done;
  asio::post(io_, [&] {
    Vanish();
    done.set_value();
  });
  done.get_future().wait();
}

void LineSimulator::Reappear() {
  std::promise<void> done;
  asio::post(io_, [&] {
    port_.Reappear();
    descriptor_ = std::make_unique<asio::posix::stream_descriptor>(io_, ::dup(port_.master_fd()));
    present_ = true;
    StartRead();
    done.set_value();
  });
  done.get_future().wait();
}

void LineSimulator::StartRead() {
  descriptor_->async_read_some(
      asio::buffer(chunk_), [this](const boost::system::error_code& ec, size_t n) {
        if (ec) {
          // EIO while no driver has the slave open is normal on a pty: keep listening.
          if (ec != asio::error::operation_aborted && present_ && descriptor_->is_open()) {
            auto timer = std::make_shared<asio::steady_timer>(io_, std::chrono::milliseconds(5));
            timer->async_wait([this, timer](const boost::system::error_code& e) {
              if (!e && present_ && descriptor_->is_open()) StartRead();
            });
          }
          return;
        }
        buffer_.append(chunk_, n);
        for (;;) {
          const size_t end = buffer_.find_first_of("\r\n");
          if (end == std::string::npos) break;
          std::string line = buffer_.substr(0, end);
          buffer_.erase(0, end + 1);
          if (!line.empty()) OnLine(line);
        }
        StartRead();
      });
}

void LineSimulator::OnLine(const std::string& line) {
  ++requests_;
  const FaultSpec fault = faults_.Next();
  switch (fault.fault) {
    case Fault::kVanish:
      Vanish();
      return;
    case Fault::kFloodBytes: {
      // Deterministic garbage, every byte value, CR and LF among it.
      StartFlood([](int64_t k) {
        std::string chunk(4096, '\0');
        uint32_t x = static_cast<uint32_t>(k) * 2654435761u + 12345u;
        for (char& c : chunk) {
          x = x * 1664525u + 1013904223u;
          c = static_cast<char>(x >> 24);
        }
        return chunk;
      });
      return;
    }
    case Fault::kEndlessLine:
      StartFlood([](int64_t) {
        std::string chunk;
        while (chunk.size() < 4096) chunk += "%R1P,0,1:0,3.14159265358979,";
        return chunk;
      });
      return;
    case Fault::kFloodLines:
      StartFlood([this, line](int64_t k) {
        std::string chunk;
        for (int64_t i = 0; chunk.size() < 4096; ++i) chunk += FloodLine(line, k * 1000 + i);
        return chunk;
      });
      return;
    default:
      break;
  }
  auto response = Handle(line, fault);
  if (!response || fault.fault == Fault::kDropReply) return;
  std::string bytes = response->bytes;
  if (fault.fault == Fault::kNoiseBytes) bytes = "\x13\xfe~#garbage\r\n\x07" + bytes;
  if (fault.fault == Fault::kTruncateReply) bytes = bytes.substr(0, bytes.size() / 2);
  Send(std::move(bytes), response->latency);
}

void LineSimulator::StartFlood(std::function<std::string(int64_t)> next) {
  if (flooding_ || !present_ || !descriptor_->is_open()) return;
  flooding_ = true;
  FloodMore(std::make_shared<std::function<std::string(int64_t)>>(std::move(next)), 0,
            flood_generation_.load());
}

void LineSimulator::FloodMore(std::shared_ptr<std::function<std::string(int64_t)>> next, int64_t k,
                              uint64_t generation) {
  if (!flooding_ || generation != flood_generation_.load() || !present_ ||
      !descriptor_->is_open()) {
    return;
  }
  // The chunk first: the order in which function arguments are evaluated is unspecified,
  // and moving `next` into its parameter before calling it left it empty under clang.
  auto data = std::make_shared<std::string>((*next)(k));
  FloodChunk(std::move(next), k, generation, std::move(data), 0);
}

// One write_some at a time, so flood_bytes() counts what the line took as it takes it (a
// composed async_write would count a 4 KiB chunk only once all of it was read).
void LineSimulator::FloodChunk(std::shared_ptr<std::function<std::string(int64_t)>> next, int64_t k,
                               uint64_t generation, std::shared_ptr<std::string> data,
                               size_t offset) {
  if (!flooding_ || generation != flood_generation_.load() || !present_ ||
      !descriptor_->is_open()) {
    return;
  }
  descriptor_->async_write_some(
      asio::buffer(data->data() + offset, data->size() - offset),
      [this, next, k, generation, data, offset](const boost::system::error_code& ec, size_t n) {
        flood_bytes_ += static_cast<int64_t>(n);
        if (ec) {
          if (generation == flood_generation_.load()) flooding_ = false;
          return;
        }
        if (offset + n < data->size()) {
          FloodChunk(next, k, generation, data, offset + n);
        } else {
          FloodMore(next, k + 1, generation);
        }
      });
}

void LineSimulator::Send(std::string bytes, std::chrono::milliseconds latency) {
  auto timer = std::make_shared<asio::steady_timer>(io_, Scaled(latency));
  auto data = std::make_shared<std::string>(std::move(bytes));
  timer->async_wait([this, timer, data](const boost::system::error_code& ec) {
    if (ec || !present_ || !descriptor_->is_open()) return;
    boost::system::error_code ignored;
    asio::write(*descriptor_, asio::buffer(*data), ignored);
  });
}

}  // namespace armsig::simulation
