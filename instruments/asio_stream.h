// Internal to instruments/ (included by the transports' .cc files only): the Boost.Asio
// byte stream under the line transports and the packet transport. Every operation is
// asynchronous and ends by an absolute deadline or the owner's interrupt flag (polled every
// kInterruptPoll); an operation still pending then is cancelled and its handler run before
// returning, so nothing refers to a caller's buffer afterwards.
#pragma once

// clang-format off
#include <utility>  // first: Boost 1.74 Asio uses std::exchange without including it (C++20)
#include <boost/asio.hpp>
// clang-format on
#include <algorithm>
#include <cerrno>
#include <string>
#include <string_view>

#include "instruments/transport.h"

namespace armsig::instruments::detail {

namespace asio = boost::asio;

enum class Wait { kDone, kDeadline, kInterrupted };

// Runs `io` until `done`, the deadline or `owner`'s interrupt; an operation still pending
// then is cancelled (`cancel`) and its handler run before returning.
template <typename Cancel>
Wait RunUntil(asio::io_context& io, const TransportBase& owner, Deadline deadline, bool& done,
              Cancel&& cancel) {
  io.restart();
  Wait why = Wait::kDone;
  while (!done) {
    if (owner.Interrupted()) {
      why = Wait::kInterrupted;
      break;
    }
    const auto now = Clock::now();
    if (now >= deadline) {
      why = Wait::kDeadline;
      break;
    }
    io.run_one_until(std::min(deadline, now + kInterruptPoll));
  }
  if (!done) {
    cancel();
    io.restart();
    while (!done && io.run_one() > 0) {
    }
  }
  io.restart();
  io.poll();  // handlers that were already due
  return why;
}

template <typename Stream>
class AsioStream {
 public:
  using Wait = detail::Wait;

  // `owner` names the stream in errors and holds the interrupt flag; it outlives this.
  explicit AsioStream(const TransportBase& owner) : owner_(owner), stream_(io_) {}

  asio::io_context& io() { return io_; }
  Stream& stream() { return stream_; }
  bool IsOpen() const { return stream_.is_open(); }
  void Close() {
    boost::system::error_code ignored;
    stream_.close(ignored);
  }

  // Runs the io_context until `done`, the deadline or an interrupt; an operation still
  // pending then is cancelled and its handler run before returning.
  Wait Run(Deadline deadline, bool& done) {
    return RunUntil(io_, owner_, deadline, done, [this] {
      boost::system::error_code ignored;
      stream_.cancel(ignored);
    });
  }

  // Writes all of `data` by `deadline`.
  void Write(std::string_view data, Deadline deadline) {
    if (!stream_.is_open())
      throw TransportError(TransportError::Kind::kClosed, owner_.name(), "port is not open");
    boost::system::error_code ec;
    bool done = false;
    asio::async_write(stream_, asio::buffer(data.data(), data.size()),
                      [&](const boost::system::error_code& e, size_t) {
                        ec = e;
                        done = true;
                      });
    // An interrupt wins even when the operation completed meanwhile (a socket that always
    // has data completes a cancelled read with data).
    if (Run(deadline, done) == Wait::kInterrupted) owner_.ThrowInterrupted();
    if (ec == asio::error::operation_aborted || !done) {
      throw TransportError(TransportError::Kind::kTimeout, owner_.name(),
                           "write not done by the deadline");
    }
    if (ec) Fail(ec, "write failed");
  }

  // Reads what arrives by `deadline` (at least one byte) into `buffer`; returns the count.
  size_t ReadSome(char* buffer, size_t capacity, Deadline deadline) {
    if (!stream_.is_open())
      throw TransportError(TransportError::Kind::kClosed, owner_.name(), "port is not open");
    boost::system::error_code ec;
    size_t n = 0;
    bool done = false;
    stream_.async_read_some(asio::buffer(buffer, capacity),
                            [&](const boost::system::error_code& e, size_t count) {
                              ec = e;
                              n = count;
                              done = true;
                            });
    if (Run(deadline, done) == Wait::kInterrupted) owner_.ThrowInterrupted();
    if (ec == asio::error::operation_aborted || !done) {
      throw TransportError(TransportError::Kind::kTimeout, owner_.name(),
                           "no data by the deadline");
    }
    if (ec) Fail(ec, "read failed");
    return n;
  }

  // EOF / EIO / reset: the port or cable is gone (kClosed, the owner reconnects); other
  // errors kIo. The stream is closed either way.
  [[noreturn]] void Fail(const boost::system::error_code& ec, const std::string& what) {
    const bool closed = ec == asio::error::eof || ec == asio::error::connection_reset ||
                        ec == asio::error::broken_pipe || ec.value() == EIO || ec.value() == EBADF;
    Close();
    throw TransportError(closed ? TransportError::Kind::kClosed : TransportError::Kind::kIo,
                         owner_.name(), what + " (" + ec.message() + ")");
  }

 private:
  const TransportBase& owner_;
  asio::io_context io_;
  Stream stream_;
};

// Resolves and connects `socket` by now + `timeout` (TCP_NODELAY set); throws
// TransportError kOpen, or kInterrupted.
inline void ConnectTcp(AsioStream<asio::ip::tcp::socket>& socket, const std::string& host,
                       unsigned short port, Millis timeout, const TransportBase& owner) {
  socket.Close();
  asio::ip::tcp::resolver resolver(socket.io());
  boost::system::error_code ec;
  auto endpoints = resolver.resolve(host, std::to_string(port), ec);
  if (ec)
    throw TransportError(TransportError::Kind::kOpen, owner.name(),
                         "cannot resolve (" + ec.message() + ")");
  bool done = false;
  asio::async_connect(socket.stream(), endpoints,
                      [&](const boost::system::error_code& e, const auto&) {
                        ec = e;
                        done = true;
                      });
  using Wait = AsioStream<asio::ip::tcp::socket>::Wait;
  const Wait why = socket.Run(Clock::now() + timeout, done);
  if (why == Wait::kInterrupted && (!done || ec)) {
    socket.Close();
    owner.ThrowInterrupted();
  }
  if (!done || ec) {
    socket.Close();
    throw TransportError(TransportError::Kind::kOpen, owner.name(),
                         done ? "cannot connect (" + ec.message() + ")" : "connect timed out");
  }
  socket.stream().set_option(asio::ip::tcp::no_delay(true));
}

// What the Asio line and packet transports share whatever they carry: the stream, its
// name, closing, writing, the read loop and draining. `Interface` is LineTransport or
// PacketTransport; the subclass keeps what was received (lines or frames) through the
// three hooks below.
template <typename Interface, typename Stream, size_t kChunkBytes>
class AsioTransport : public Interface {
 public:
  explicit AsioTransport(std::string name) : name_(std::move(name)), conn_(*this) {}

  void Close() override {
    conn_.Close();
    ClearReceived();
  }
  bool IsOpen() const override { return conn_.IsOpen(); }
  const std::string& name() const override { return name_; }
  void Write(std::string_view data, Deadline deadline) override { conn_.Write(data, deadline); }

  int Drain(Millis quiet, Deadline until) override {
    int bytes = static_cast<int>(Received());
    DiscardReceived(nullptr, 0);
    if (!conn_.IsOpen()) return bytes;
    while (Clock::now() < until) {
      size_t n = 0;
      try {
        n = conn_.ReadSome(chunk_, sizeof chunk_, std::min(until, Clock::now() + quiet));
      } catch (const TransportError& e) {
        if (e.kind() != TransportError::Kind::kTimeout) throw;
        break;  // quiet
      }
      DiscardReceived(chunk_, n);
      bytes += static_cast<int>(n);
    }
    return bytes;
  }

 protected:
  // Bytes received and not yet taken.
  virtual size_t Received() const = 0;
  virtual void Receive(const char* data, size_t size) = 0;
  // Forgets them (a closed or reopened stream).
  virtual void ClearReceived() = 0;
  // Drops them and `size` drained bytes (Drain, which starts with none).
  virtual void DiscardReceived(const char* data, size_t size) = 0;

  // Reads until `next(out)` takes a whole `what` (a line, a packet) from what was
  // received; kTimeout at the deadline.
  template <typename Next>
  std::string ReadUntil(Deadline deadline, std::string_view what, Next&& next) {
    std::string out;
    for (;;) {
      if (next(out)) return out;
      if (Clock::now() >= deadline) {
        throw TransportError(TransportError::Kind::kTimeout, name_,
                             "no complete " + std::string(what) + " by the deadline");
      }
      Receive(chunk_, conn_.ReadSome(chunk_, sizeof chunk_, deadline));
    }
  }

  // (Re)opens a TCP stream to host:port.
  void OpenTcp(const std::string& host, unsigned short port, Millis timeout) {
    Close();
    ConnectTcp(conn_, host, port, timeout, *this);
  }

  std::string name_;
  AsioStream<Stream> conn_;

 private:
  char chunk_[kChunkBytes];
};

}  // namespace armsig::instruments::detail
