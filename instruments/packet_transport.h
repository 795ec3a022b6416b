// Packet transports: a TCP connection carrying binary, length-prefixed frames (Leica emScon
// TPI: each packet starts with its whole length as an int32, little-endian; Universal
// Robots RTDE and primary/secondary interfaces: uint16 / int32, big-endian), and an
// in-memory fake. The same deadline and interrupt semantics as the line transports
// (instruments/transport.h): every read and write ends by an absolute deadline, the
// deadline of the whole exchange, however the bytes arrive; the interrupt flag ends any
// wait within kInterruptPoll. Frames are split by instruments::FrameSplitter: several
// packets in one read and a packet split across reads both come out whole; a size field
// outside the protocol's bounds (emScon 12 B … 64 KiB) means the stream lost its framing
// (kBadFrame, everything buffered dropped).
#pragma once

#include <deque>
#include <functional>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "instruments/emscon_codec.h"
#include "instruments/transport.h"

namespace armsig::instruments {

class PacketTransport : public TransportBase {
 public:
  // Writes one whole packet by `deadline`.
  virtual void Write(std::string_view packet, Deadline deadline) = 0;
  // The next whole packet (header included) by `deadline`. Throws TransportError:
  // kTimeout, kBadFrame, kClosed, kIo or kInterrupted.
  virtual std::string ReadPacket(Deadline deadline) = 0;
};

inline constexpr FrameSplitter::Format kEmsconFrames{4, false, emscon::kMinPacketBytes,
                                                     emscon::kMaxPacketBytes};
std::unique_ptr<PacketTransport> MakeEmsconTcpTransport(const std::string& host,
                                                        unsigned short port,
                                                        Millis connect_timeout = Millis(3000));
// Any length-prefixed binary protocol over TCP.
std::unique_ptr<PacketTransport> MakeFramedTcpTransport(const std::string& host,
                                                        unsigned short port,
                                                        const FrameSplitter::Format& format,
                                                        Millis connect_timeout = Millis(3000));

// In-memory packet transport for driver unit tests: every Write is answered by
// `responder` with the bytes the peer sends back, as chunks each delivered by one read
// (a packet may be split over chunks, a chunk may hold several packets; none = silence).
// Silence is a timeout at once (no waiting).
class FakePacketTransport : public PacketTransport {
 public:
  using Responder = std::function<std::vector<std::string>(std::string_view request)>;
  explicit FakePacketTransport(Responder responder, std::string name = "fake tracker",
                               FrameSplitter::Format format = kEmsconFrames)
      : responder_(std::move(responder)), name_(std::move(name)), splitter_(format) {}
  void Open() override;
  void Close() override { open_ = false; }
  bool IsOpen() const override { return open_; }
  void Write(std::string_view packet, Deadline deadline) override;
  std::string ReadPacket(Deadline deadline) override;
  int Drain(Millis quiet, Deadline until) override;
  const std::string& name() const override { return name_; }
  const std::vector<std::string>& written() const { return written_; }
  int opens() const { return opens_; }
  int reads() const { return reads_; }  // chunks delivered so far

 private:
  Responder responder_;
  std::string name_;
  bool open_ = true;
  int opens_ = 0, reads_ = 0;
  std::deque<std::string> chunks_;
  FrameSplitter splitter_;
  std::vector<std::string> written_;
};

}  // namespace armsig::instruments
