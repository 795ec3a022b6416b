#include "instruments/transport.h"

// clang-format off
#include <utility>  // first: Boost 1.74 Asio uses std::exchange without including it (C++20)
#include <boost/asio.hpp>
// clang-format on
#include <algorithm>
#include <thread>

namespace armsig::instruments {

namespace asio = boost::asio;

void LineTransport::Pause(Millis delay, Deadline deadline) {
  const Deadline end = std::min(deadline, Clock::now() + delay);
  for (;;) {
    if (Interrupted()) ThrowInterrupted();
    const auto now = Clock::now();
    if (now >= end) return;
    std::this_thread::sleep_for(std::min<Clock::duration>(end - now, kInterruptPoll));
  }
}

void LineTransport::ThrowInterrupted() const {
  throw TransportError(TransportError::Kind::kInterrupted, name(), "interrupted");
}

void LineBuffer::Clear() {
  buffer_.clear();
  scanned_ = 0;
  skipping_ = false;
  skipped_ = 0;
}

void LineBuffer::Discard(const char* data, size_t size) {
  const bool mid_line =
      size > 0 ? data[size - 1] != '\r' && data[size - 1] != '\n'
               : skipping_ || (!buffer_.empty() && buffer_.back() != '\r' && buffer_.back() != '\n');
  Clear();
  skipping_ = mid_line;
}

bool LineBuffer::Next(size_t max_bytes, std::string& line) {
  for (;;) {
    const size_t end = buffer_.find_first_of("\r\n", scanned_);
    if (end == std::string::npos) {
      if (skipping_) {
        // Still the over-long line: each further `max_bytes` of it is another error, so
        // an endless line fails every attempt at once instead of holding it.
        const size_t skipped = skipped_ + buffer_.size();
        Clear();
        skipping_ = true;
        skipped_ = skipped;
        if (skipped_ > max_bytes) {
          skipped_ = 0;
          throw std::length_error("line longer than " + std::to_string(max_bytes) + " bytes");
        }
        return false;
      }
      scanned_ = buffer_.size();
      if (buffer_.size() > max_bytes) {
        Clear();
        skipping_ = true;
        throw std::length_error("line longer than " + std::to_string(max_bytes) + " bytes");
      }
      return false;
    }
    const bool tail = skipping_;
    const bool too_long = end > max_bytes;
    line.assign(buffer_, 0, end);
    buffer_.erase(0, end + 1);
    scanned_ = 0;
    skipping_ = false;
    skipped_ = 0;
    if (tail) continue;  // the rest of an over-long line
    if (too_long) {
      line.clear();
      throw std::length_error("line longer than " + std::to_string(max_bytes) + " bytes");
    }
    return true;
  }
}

namespace {

template <typename Stream>
class AsioLineTransport : public LineTransport {
 public:
  explicit AsioLineTransport(std::string name) : name_(std::move(name)), stream_(io_) {}

  void Close() override {
    boost::system::error_code ignored;
    stream_.close(ignored);
    buffer_.Clear();
  }
  bool IsOpen() const override { return stream_.is_open(); }
  const std::string& name() const override { return name_; }

  void Write(std::string_view data, Deadline deadline) override {
    if (!stream_.is_open())
      throw TransportError(TransportError::Kind::kClosed, name_, "port is not open");
    boost::system::error_code ec;
    bool done = false;
    asio::async_write(stream_, asio::buffer(data.data(), data.size()),
                      [&](const boost::system::error_code& e, size_t) {
                        ec = e;
                        done = true;
                      });
    const Wait why = Run(deadline, done);
    if (ec == asio::error::operation_aborted || !done) {
      if (why == Wait::kInterrupted) ThrowInterrupted();
      throw TransportError(TransportError::Kind::kTimeout, name_, "write not done by the deadline");
    }
    if (ec) Fail(ec, "write failed");
  }

  std::string ReadLine(Deadline deadline) override {
    std::string line;
    for (;;) {
      try {
        while (buffer_.Next(max_line_bytes(), line)) {
          if (!line.empty()) return line;
        }
      } catch (const std::length_error& e) {
        throw TransportError(TransportError::Kind::kLineTooLong, name_, e.what());
      }
      if (Clock::now() >= deadline) {
        throw TransportError(TransportError::Kind::kTimeout, name_,
                             "no complete line by the deadline");
      }
      buffer_.Append(chunk_, ReadSome(deadline));
    }
  }

  int Drain(Millis quiet, Deadline until) override {
    int bytes = static_cast<int>(buffer_.size());
    buffer_.Discard(nullptr, 0);
    if (!stream_.is_open()) return bytes;
    while (Clock::now() < until) {
      size_t n = 0;
      try {
        n = ReadSome(std::min(until, Clock::now() + quiet));
      } catch (const TransportError& e) {
        if (e.kind() != TransportError::Kind::kTimeout) throw;
        break;  // quiet
      }
      buffer_.Discard(chunk_, n);
      bytes += static_cast<int>(n);
    }
    return bytes;
  }

 protected:
  enum class Wait { kDone, kDeadline, kInterrupted };

  // Runs the io_context until `done`, the deadline or an interrupt; an operation still
  // pending then is cancelled and its handler run before returning.
  Wait Run(Deadline deadline, bool& done) {
    io_.restart();
    Wait why = Wait::kDone;
    while (!done) {
      if (Interrupted()) {
        why = Wait::kInterrupted;
        break;
      }
      const auto now = Clock::now();
      if (now >= deadline) {
        why = Wait::kDeadline;
        break;
      }
      io_.run_one_until(std::min(deadline, now + kInterruptPoll));
    }
    if (!done) {
      boost::system::error_code ignored;
      stream_.cancel(ignored);
      io_.restart();
      while (!done && io_.run_one() > 0) {
      }
    }
    io_.restart();
    io_.poll();  // handlers that were already due
    return why;
  }

  // Reads what arrives by `deadline` into chunk_; returns the number of bytes.
  size_t ReadSome(Deadline deadline) {
    if (!stream_.is_open())
      throw TransportError(TransportError::Kind::kClosed, name_, "port is not open");
    boost::system::error_code ec;
    size_t n = 0;
    bool done = false;
    stream_.async_read_some(asio::buffer(chunk_),
                            [&](const boost::system::error_code& e, size_t count) {
                              ec = e;
                              n = count;
                              done = true;
                            });
    const Wait why = Run(deadline, done);
    if (ec == asio::error::operation_aborted || !done) {
      if (why == Wait::kInterrupted) ThrowInterrupted();
      throw TransportError(TransportError::Kind::kTimeout, name_, "no data by the deadline");
    }
    if (ec) Fail(ec, "read failed");
    return n;
  }

  [[noreturn]] void Fail(const boost::system::error_code& ec, const std::string& what) {
    // EOF / EIO / reset: the port or cable is gone. Close so the owner reconnects.
    const bool closed = ec == asio::error::eof || ec == asio::error::connection_reset ||
                        ec == asio::error::broken_pipe || ec.value() == EIO || ec.value() == EBADF;
    Close();
    throw TransportError(closed ? TransportError::Kind::kClosed : TransportError::Kind::kIo, name_,
                         what + " (" + ec.message() + ")");
  }

  std::string name_;
  asio::io_context io_;
  Stream stream_;
  LineBuffer buffer_;
  char chunk_[512];
};

class SerialTransport : public AsioLineTransport<asio::serial_port> {
 public:
  explicit SerialTransport(SerialSettings settings)
      : AsioLineTransport(settings.path), settings_(std::move(settings)) {}

  void Open() override {
    Close();
    boost::system::error_code ec;
    stream_.open(settings_.path, ec);
    if (ec)
      throw TransportError(TransportError::Kind::kOpen, name_,
                           "cannot open (" + ec.message() + ")");
    // Options only after open (a known pitfall of Asio serial drivers).
    using asio::serial_port_base;
    try {
      stream_.set_option(serial_port_base::baud_rate(settings_.baud));
      stream_.set_option(serial_port_base::character_size(settings_.data_bits));
      stream_.set_option(serial_port_base::parity(
          settings_.parity == SerialSettings::Parity::kOdd    ? serial_port_base::parity::odd
          : settings_.parity == SerialSettings::Parity::kEven ? serial_port_base::parity::even
                                                              : serial_port_base::parity::none));
      stream_.set_option(serial_port_base::stop_bits(settings_.stop_bits == 2
                                                         ? serial_port_base::stop_bits::two
                                                         : serial_port_base::stop_bits::one));
      stream_.set_option(
          serial_port_base::flow_control(settings_.flow == SerialSettings::Flow::kSoftware
                                             ? serial_port_base::flow_control::software
                                         : settings_.flow == SerialSettings::Flow::kHardware
                                             ? serial_port_base::flow_control::hardware
                                             : serial_port_base::flow_control::none));
    } catch (const boost::system::system_error& e) {
      Close();
      throw TransportError(TransportError::Kind::kOpen, name_,
                           std::string("cannot configure (") + e.what() + ")");
    }
  }

 private:
  SerialSettings settings_;
};

class TcpTransport : public AsioLineTransport<asio::ip::tcp::socket> {
 public:
  TcpTransport(std::string host, unsigned short port, Millis timeout)
      : AsioLineTransport(host + ":" + std::to_string(port)),
        host_(std::move(host)),
        port_(port),
        timeout_(timeout) {}

  void Open() override {
    Close();
    asio::ip::tcp::resolver resolver(io_);
    boost::system::error_code ec;
    auto endpoints = resolver.resolve(host_, std::to_string(port_), ec);
    if (ec)
      throw TransportError(TransportError::Kind::kOpen, name_,
                           "cannot resolve (" + ec.message() + ")");
    bool done = false;
    asio::async_connect(stream_, endpoints, [&](const boost::system::error_code& e, const auto&) {
      ec = e;
      done = true;
    });
    const Wait why = Run(Clock::now() + timeout_, done);
    if (why == Wait::kInterrupted && (!done || ec)) {
      Close();
      ThrowInterrupted();
    }
    if (!done || ec) {
      Close();
      throw TransportError(TransportError::Kind::kOpen, name_,
                           done ? "cannot connect (" + ec.message() + ")" : "connect timed out");
    }
    stream_.set_option(asio::ip::tcp::no_delay(true));
  }

 private:
  std::string host_;
  unsigned short port_;
  Millis timeout_;
};

}  // namespace

std::unique_ptr<LineTransport> MakeSerialTransport(const SerialSettings& settings) {
  return std::make_unique<SerialTransport>(settings);
}

std::unique_ptr<LineTransport> MakeTcpTransport(const std::string& host, unsigned short port,
                                                Millis connect_timeout) {
  return std::make_unique<TcpTransport>(host, port, connect_timeout);
}

void FakeTransport::Write(std::string_view data, Deadline) {
  if (Interrupted()) ThrowInterrupted();
  if (!open_) throw TransportError(TransportError::Kind::kClosed, name_, "port is not open");
  written_.emplace_back(data);
  const std::string reply = responder_(data);
  pending_.Append(reply.data(), reply.size());
}

std::string FakeTransport::ReadLine(Deadline) {
  if (Interrupted()) ThrowInterrupted();
  if (!open_) throw TransportError(TransportError::Kind::kClosed, name_, "port is not open");
  std::string line;
  try {
    while (pending_.Next(max_line_bytes(), line)) {
      if (!line.empty()) return line;
    }
  } catch (const std::length_error& e) {
    throw TransportError(TransportError::Kind::kLineTooLong, name_, e.what());
  }
  throw TransportError(TransportError::Kind::kTimeout, name_, "no complete line by the deadline");
}

int FakeTransport::Drain(Millis, Deadline) {
  const int n = static_cast<int>(pending_.size());
  pending_.Clear();
  return n;
}

}  // namespace armsig::instruments
