#include "instruments/packet_transport.h"

#include "instruments/asio_stream.h"

namespace armsig::instruments {

namespace {

namespace asio = boost::asio;

TransportError BadFrame(const std::string& name, int32_t size,
                        const FrameSplitter::Format& format) {
  return TransportError(TransportError::Kind::kBadFrame, name,
                        "frame size field " + std::to_string(size) + " outside " +
                            std::to_string(format.min_bytes) + " to " +
                            std::to_string(format.max_bytes) +
                            " bytes: the stream lost its framing");
}

class TcpPacketTransport
    : public detail::AsioTransport<PacketTransport, asio::ip::tcp::socket, 4096> {
 public:
  TcpPacketTransport(std::string host, unsigned short port, Millis timeout,
                     FrameSplitter::Format format)
      : AsioTransport(host + ":" + std::to_string(port)),
        host_(std::move(host)),
        port_(port),
        timeout_(timeout),
        splitter_(format) {}

  void Open() override { OpenTcp(host_, port_, timeout_); }

  std::string ReadPacket(Deadline deadline) override {
    return ReadUntil(deadline, "packet", [this](std::string& frame) {
      int32_t size = 0;
      switch (splitter_.Next(frame, &size)) {
        case FrameSplitter::Status::kFrame:
          return true;
        case FrameSplitter::Status::kBadSize:
          throw BadFrame(name_, size, splitter_.format());
        case FrameSplitter::Status::kNeedMore:
          break;
      }
      return false;
    });
  }

 protected:
  size_t Received() const override { return splitter_.buffered(); }
  void Receive(const char* data, size_t size) override {
    splitter_.Append(std::string_view(data, size));
  }
  void ClearReceived() override { splitter_.Clear(); }
  // Drained bytes are dropped unsplit: what follows starts a new frame.
  void DiscardReceived(const char*, size_t) override { splitter_.Clear(); }

 private:
  std::string host_;
  unsigned short port_;
  Millis timeout_;
  FrameSplitter splitter_;
};

}  // namespace

std::unique_ptr<PacketTransport> MakeEmsconTcpTransport(const std::string& host,
                                                        unsigned short port,
                                                        Millis connect_timeout) {
  return MakeFramedTcpTransport(host, port, kEmsconFrames, connect_timeout);
}

std::unique_ptr<PacketTransport> MakeFramedTcpTransport(const std::string& host,
                                                        unsigned short port,
                                                        const FrameSplitter::Format& format,
                                                        Millis connect_timeout) {
  return std::make_unique<TcpPacketTransport>(host, port, connect_timeout, format);
}

void FakePacketTransport::Open() {
  if (Interrupted()) ThrowInterrupted();
  open_ = true;
  ++opens_;
  chunks_.clear();
  splitter_.Clear();
}

void FakePacketTransport::Write(std::string_view packet, Deadline) {
  if (Interrupted()) ThrowInterrupted();
  if (!open_) throw TransportError(TransportError::Kind::kClosed, name_, "port is not open");
  written_.emplace_back(packet);
  for (auto& chunk : responder_(packet)) chunks_.push_back(std::move(chunk));
}

std::string FakePacketTransport::ReadPacket(Deadline) {
  std::string frame;
  for (;;) {
    if (Interrupted()) ThrowInterrupted();
    if (!open_) throw TransportError(TransportError::Kind::kClosed, name_, "port is not open");
    int32_t size = 0;
    switch (splitter_.Next(frame, &size)) {
      case FrameSplitter::Status::kFrame:
        return frame;
      case FrameSplitter::Status::kBadSize:
        throw BadFrame(name_, size, splitter_.format());
      case FrameSplitter::Status::kNeedMore:
        break;
    }
    if (chunks_.empty()) {
      throw TransportError(TransportError::Kind::kTimeout, name_,
                           "no complete packet by the deadline");
    }
    ++reads_;
    splitter_.Append(chunks_.front());
    chunks_.pop_front();
  }
}

int FakePacketTransport::Drain(Millis, Deadline) {
  int n = static_cast<int>(splitter_.buffered());
  for (const auto& c : chunks_) n += static_cast<int>(c.size());
  chunks_.clear();
  splitter_.Clear();
  return n;
}

}  // namespace armsig::instruments
