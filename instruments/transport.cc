#include "instruments/transport.h"

// clang-format off
#include <utility>  // first: Boost 1.74 Asio uses std::exchange without including it (C++20)
#include <boost/asio.hpp>
// clang-format on
#include <optional>

namespace armsig::instruments {

namespace asio = boost::asio;

namespace {

// Extracts the next line from `buffer` (CR, LF or CR LF terminated); nullopt if none.
std::optional<std::string> TakeLine(std::string& buffer) {
  const size_t end = buffer.find_first_of("\r\n");
  if (end == std::string::npos) return std::nullopt;
  std::string line = buffer.substr(0, end);
  size_t skip = end + 1;
  if (buffer[end] == '\r' && skip < buffer.size() && buffer[skip] == '\n') ++skip;
  buffer.erase(0, skip);
  return line;
}

template <typename Stream>
class AsioLineTransport : public LineTransport {
 public:
  explicit AsioLineTransport(std::string name) : name_(std::move(name)), stream_(io_) {}

  void Close() override {
    boost::system::error_code ignored;
    stream_.close(ignored);
    buffer_.clear();
  }
  bool IsOpen() const override { return stream_.is_open(); }
  const std::string& name() const override { return name_; }

  void Write(std::string_view data, Millis timeout) override {
    if (!stream_.is_open())
      throw TransportError(TransportError::Kind::kClosed, name_, "port is not open");
    boost::system::error_code ec;
    bool done = false;
    asio::async_write(stream_, asio::buffer(data.data(), data.size()),
                      [&](const boost::system::error_code& e, size_t) {
                        ec = e;
                        done = true;
                      });
    Run(timeout, done);
    if (!done) throw TransportError(TransportError::Kind::kTimeout, name_, "write timed out");
    if (ec) Fail(ec, "write failed");
  }

  std::string ReadLine(Millis timeout) override {
    const auto deadline = std::chrono::steady_clock::now() + timeout;
    for (;;) {
      while (auto line = TakeLine(buffer_)) {
        if (!line->empty()) return *line;
      }
      const auto now = std::chrono::steady_clock::now();
      if (now >= deadline) {
        throw TransportError(TransportError::Kind::kTimeout, name_,
                             "no reply within " + std::to_string(timeout.count()) + " ms");
      }
      ReadSome(std::chrono::duration_cast<Millis>(deadline - now) + Millis(1));
    }
  }

  int Drain(Millis quiet) override {
    int bytes = static_cast<int>(buffer_.size());
    buffer_.clear();
    if (!stream_.is_open()) return bytes;
    try {
      for (;;) bytes += ReadSome(quiet, /*keep=*/false);
    } catch (const TransportError& e) {
      if (e.kind() != TransportError::Kind::kTimeout) throw;
    }
    return bytes;
  }

 protected:
  // Runs the io_context until `done` or the timeout; on timeout cancels the operation.
  void Run(Millis timeout, bool& done) {
    io_.restart();
    asio::steady_timer timer(io_);
    bool expired = false;
    timer.expires_after(timeout);
    timer.async_wait([&](const boost::system::error_code& e) {
      if (!e && !done) {
        expired = true;
        boost::system::error_code ignored;
        stream_.cancel(ignored);
      }
    });
    while (!done && io_.run_one() > 0) {
    }
    timer.cancel();
    io_.run();  // let the cancelled handlers finish
    if (expired && !done) done = false;
  }

  int ReadSome(Millis timeout, bool keep = true) {
    if (!stream_.is_open())
      throw TransportError(TransportError::Kind::kClosed, name_, "port is not open");
    char chunk[512];
    boost::system::error_code ec;
    size_t n = 0;
    bool done = false;
    stream_.async_read_some(asio::buffer(chunk),
                            [&](const boost::system::error_code& e, size_t count) {
                              ec = e;
                              n = count;
                              done = true;
                            });
    Run(timeout, done);
    if (ec == asio::error::operation_aborted || !done) {
      throw TransportError(TransportError::Kind::kTimeout, name_,
                           "no data within " + std::to_string(timeout.count()) + " ms");
    }
    if (ec) Fail(ec, "read failed");
    if (keep) buffer_.append(chunk, n);
    return static_cast<int>(n);
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
  std::string buffer_;
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
    Run(timeout_, done);
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

void FakeTransport::Write(std::string_view data, Millis) {
  if (!open_) throw TransportError(TransportError::Kind::kClosed, name_, "port is not open");
  written_.emplace_back(data);
  pending_ += responder_(data);
}

std::string FakeTransport::ReadLine(Millis timeout) {
  if (!open_) throw TransportError(TransportError::Kind::kClosed, name_, "port is not open");
  while (auto line = TakeLine(pending_)) {
    if (!line->empty()) return *line;
  }
  throw TransportError(TransportError::Kind::kTimeout, name_,
                       "no reply within " + std::to_string(timeout.count()) + " ms");
}

int FakeTransport::Drain(Millis) {
  const int n = static_cast<int>(pending_.size());
  pending_.clear();
  return n;
}

}  // namespace armsig::instruments
