// Line transports: a serial port or a TCP socket (Boost.Asio), and an in-memory fake.
// Every operation has a deadline (async operation + timer); no read ever blocks
// without one. Lines end with CR, LF or CR LF; empty lines are skipped.
#pragma once

#include <chrono>
#include <deque>
#include <functional>
#include <memory>
#include <stdexcept>
#include <string>
#include <string_view>

namespace armsig::instruments {

using Millis = std::chrono::milliseconds;

// A transport failure (not an instrument return code).
class TransportError : public std::runtime_error {
 public:
  enum class Kind { kOpen, kTimeout, kClosed, kIo };
  TransportError(Kind kind, std::string device, const std::string& message)
      : std::runtime_error(device + ": " + message), kind_(kind), device_(std::move(device)) {}
  Kind kind() const { return kind_; }
  const std::string& device() const { return device_; }

 private:
  Kind kind_;
  std::string device_;
};

class LineTransport {
 public:
  virtual ~LineTransport() = default;
  virtual void Open() = 0;  // (re)opens; throws TransportError(kOpen)
  virtual void Close() = 0;
  virtual bool IsOpen() const = 0;
  virtual void Write(std::string_view data, Millis timeout) = 0;
  // The next non-empty line without its terminator.
  virtual std::string ReadLine(Millis timeout) = 0;
  // Discards everything received until the line is quiet for `quiet`.
  virtual int Drain(Millis quiet) = 0;
  virtual const std::string& name() const = 0;
};

struct SerialSettings {
  std::string path;
  unsigned baud = 19200;
  unsigned data_bits = 8;
  enum class Parity { kNone, kOdd, kEven } parity = Parity::kNone;
  unsigned stop_bits = 1;  // 1 or 2
  enum class Flow { kNone, kSoftware, kHardware } flow = Flow::kNone;
};

std::unique_ptr<LineTransport> MakeSerialTransport(const SerialSettings& settings);
std::unique_ptr<LineTransport> MakeTcpTransport(const std::string& host, unsigned short port,
                                                Millis connect_timeout = Millis(3000));

// In-memory transport for driver unit tests: every Write is answered by `responder`
// (which may return "" for silence or several lines at once).
class FakeTransport : public LineTransport {
 public:
  using Responder = std::function<std::string(std::string_view request)>;
  explicit FakeTransport(Responder responder, std::string name = "fake")
      : responder_(std::move(responder)), name_(std::move(name)) {}
  void Open() override { open_ = true; }
  void Close() override { open_ = false; }
  bool IsOpen() const override { return open_; }
  void Write(std::string_view data, Millis) override;
  std::string ReadLine(Millis) override;
  int Drain(Millis) override;
  const std::string& name() const override { return name_; }
  const std::vector<std::string>& written() const { return written_; }

 private:
  Responder responder_;
  std::string name_;
  bool open_ = true;
  std::string pending_;
  std::vector<std::string> written_;
};

}  // namespace armsig::instruments
