// Line transports: a serial port or a TCP socket (Boost.Asio), and an in-memory fake.
// Every operation ends by an absolute deadline (async operation + timer): a deadline
// bounds a whole exchange (command to parsed reply, every discarded line included), not
// one byte or one line, so a port that floods bytes or unrelated lines cannot keep a
// caller past it. Lines end with CR, LF or CR LF; empty lines are skipped; a line longer
// than the protocol's maximum is a typed error (kLineTooLong) and the rest of it, up to
// its terminator, is discarded. An interrupt flag (Ctrl-C) ends any wait within
// kInterruptPoll.
#pragma once

#include <atomic>
#include <chrono>
#include <cstddef>
#include <deque>
#include <functional>
#include <memory>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

namespace armsig::instruments {

using Millis = std::chrono::milliseconds;
using Clock = std::chrono::steady_clock;
using Deadline = Clock::time_point;

// How often a wait looks at the interrupt flag.
inline constexpr Millis kInterruptPoll{10};
// The default maximum line length; each driver sets its protocol's own.
inline constexpr size_t kDefaultMaxLineBytes = 4096;

// A transport failure (not an instrument return code).
class TransportError : public std::runtime_error {
 public:
  enum class Kind {
    kOpen,
    kTimeout,  // the deadline passed
    kClosed,   // the port or connection is gone
    kIo,
    kLineTooLong,  // more bytes than the protocol's maximum line length without a terminator
    kInterrupted,  // the interrupt flag was raised (Ctrl-C): no retry
    kBadFrame,     // a binary frame whose size field is out of bounds: the stream lost its
                   // framing (what was buffered is dropped)
  };
  TransportError(Kind kind, std::string device, std::string message)
      : std::runtime_error(device + ": " + message),
        kind_(kind),
        device_(std::move(device)),
        message_(std::move(message)) {}
  Kind kind() const { return kind_; }
  const std::string& device() const { return device_; }
  const std::string& message() const { return message_; }  // without the device

 private:
  Kind kind_;
  std::string device_, message_;
};

// What every transport has, whatever it carries (lines or binary packets): opening and
// closing, a name for messages, the interrupt flag and an interruptible pause.
class TransportBase {
 public:
  virtual ~TransportBase() = default;
  virtual void Open() = 0;  // (re)opens; throws TransportError(kOpen)
  virtual void Close() = 0;
  virtual bool IsOpen() const = 0;
  // Discards everything received until the line is quiet for `quiet`, at the latest
  // until `until` (a port that never goes quiet cannot hold it longer). Returns the
  // number of bytes discarded.
  virtual int Drain(Millis quiet, Deadline until) = 0;
  virtual const std::string& name() const = 0;

  // A flag that, once true, ends every wait of this transport with kInterrupted (the
  // owner keeps the flag alive while it is set; nullptr clears it).
  void SetInterrupt(const std::atomic<bool>* flag) { interrupt_ = flag; }
  bool Interrupted() const { return interrupt_ != nullptr && interrupt_->load(); }
  // Waits `delay`, never past `deadline`; an interrupt ends it with kInterrupted.
  void Pause(Millis delay, Deadline deadline);
  [[noreturn]] void ThrowInterrupted() const;

 private:
  const std::atomic<bool>* interrupt_ = nullptr;
};

class LineTransport : public TransportBase {
 public:
  virtual void Write(std::string_view data, Deadline deadline) = 0;
  // The next non-empty line without its terminator, by `deadline`. Throws
  // TransportError: kTimeout, kLineTooLong, kClosed, kIo or kInterrupted.
  virtual std::string ReadLine(Deadline deadline) = 0;

  // The protocol's longest line in bytes, its terminator not counted.
  void SetMaxLineBytes(size_t bytes) { max_line_bytes_ = bytes; }
  size_t max_line_bytes() const { return max_line_bytes_; }

 private:
  size_t max_line_bytes_ = kDefaultMaxLineBytes;
};

// Received bytes split into lines with a maximum length, without rescanning: each byte
// is looked at once however the bytes arrive, so a flood costs linear time.
class LineBuffer {
 public:
  void Append(const char* data, size_t size) { buffer_.append(data, size); }
  // Drops what is held and `size` more bytes; if they end inside a line, the rest of that
  // line is dropped as it arrives (its tail is no line of its own).
  void Discard(const char* data, size_t size);
  void Clear();  // forgets everything (a reopened port)
  size_t size() const { return buffer_.size(); }
  // Moves the next line (possibly empty: CR LF is a line end and an empty line) into
  // `line` and returns true; false when no complete line is there. Throws
  // std::length_error when a line is longer than `max_bytes`, as soon as that many bytes
  // arrived without a terminator, and again for every further `max_bytes` of it (an
  // endless line); those bytes and the rest of that line, up to its terminator, are
  // discarded.
  bool Next(size_t max_bytes, std::string& line);

 private:
  std::string buffer_;
  size_t scanned_ = 0;     // bytes of buffer_ known to hold no terminator
  bool skipping_ = false;  // inside an over-long line: discard up to its terminator
  size_t skipped_ = 0;     // bytes of it discarded since its last error
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
// (which may return "" for silence or several lines at once). Silence is a timeout at
// once (no waiting).
class FakeTransport : public LineTransport {
 public:
  using Responder = std::function<std::string(std::string_view request)>;
  explicit FakeTransport(Responder responder, std::string name = "fake")
      : responder_(std::move(responder)), name_(std::move(name)) {}
  void Open() override { open_ = true; }
  void Close() override { open_ = false; }
  bool IsOpen() const override { return open_; }
  void Write(std::string_view data, Deadline deadline) override;
  std::string ReadLine(Deadline deadline) override;
  int Drain(Millis quiet, Deadline until) override;
  const std::string& name() const override { return name_; }
  const std::vector<std::string>& written() const { return written_; }

 private:
  Responder responder_;
  std::string name_;
  bool open_ = true;
  LineBuffer pending_;
  std::vector<std::string> written_;
};

}  // namespace armsig::instruments
