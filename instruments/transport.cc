#include "instruments/transport.h"

#include <algorithm>
#include <thread>

#include "instruments/asio_stream.h"

namespace armsig::instruments {

namespace asio = boost::asio;

void TransportBase::Pause(Millis delay, Deadline deadline) {
  const Deadline end = std::min(deadline, Clock::now() + delay);
  for (;;) {
    if (Interrupted()) ThrowInterrupted();
    const auto now = Clock::now();
    if (now >= end) return;
    std::this_thread::sleep_for(std::min<Clock::duration>(end - now, kInterruptPoll));
  }
}

void TransportBase::ThrowInterrupted() const {
  throw TransportError(TransportError::Kind::kInterrupted, name(), "interrupted");
}

void LineBuffer::Clear() {
  buffer_.clear();
  scanned_ = 0;
  skipping_ = false;
  skipped_ = 0;
}

void LineBuffer::Discard(const char* data, size_t size) {
  const bool mid_line = size > 0 ? data[size - 1] != '\r' && data[size - 1] != '\n'
                                 : skipping_ || (!buffer_.empty() && buffer_.back() != '\r' &&
                                                 buffer_.back() != '\n');
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
class AsioLineTransport : public detail::AsioTransport<LineTransport, Stream, 512> {
 public:
  using detail::AsioTransport<LineTransport, Stream, 512>::AsioTransport;

  std::string ReadLine(Deadline deadline) override {
    return this->ReadUntil(deadline, "line", [this](std::string& line) {
      try {
        while (buffer_.Next(this->max_line_bytes(), line)) {
          if (!line.empty()) return true;
        }
      } catch (const std::length_error& e) {
        throw TransportError(TransportError::Kind::kLineTooLong, this->name_, e.what());
      }
      return false;
    });
  }

 protected:
  size_t Received() const override { return buffer_.size(); }
  void Receive(const char* data, size_t size) override { buffer_.Append(data, size); }
  void ClearReceived() override { buffer_.Clear(); }
  void DiscardReceived(const char* data, size_t size) override { buffer_.Discard(data, size); }

 private:
  LineBuffer buffer_;
};

class SerialTransport : public AsioLineTransport<asio::serial_port> {
 public:
  explicit SerialTransport(SerialSettings settings)
      : AsioLineTransport(settings.path), settings_(std::move(settings)) {}

  void Open() override {
    Close();
    boost::system::error_code ec;
    auto& port = conn_.stream();
    port.open(settings_.path, ec);
    if (ec)
      throw TransportError(TransportError::Kind::kOpen, name_,
                           "cannot open (" + ec.message() + ")");
    // Options only after open (a known pitfall of Asio serial drivers).
    using asio::serial_port_base;
    try {
      port.set_option(serial_port_base::baud_rate(settings_.baud));
      port.set_option(serial_port_base::character_size(settings_.data_bits));
      port.set_option(serial_port_base::parity(
          settings_.parity == SerialSettings::Parity::kOdd    ? serial_port_base::parity::odd
          : settings_.parity == SerialSettings::Parity::kEven ? serial_port_base::parity::even
                                                              : serial_port_base::parity::none));
      port.set_option(serial_port_base::stop_bits(settings_.stop_bits == 2
                                                      ? serial_port_base::stop_bits::two
                                                      : serial_port_base::stop_bits::one));
      port.set_option(
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

  void Open() override { OpenTcp(host_, port_, timeout_); }

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
