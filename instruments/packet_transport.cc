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

class TcpPacketTransport : public PacketTransport {
 public:
  TcpPacketTransport(std::string host, unsigned short port, Millis timeout,
                     FrameSplitter::Format format)
      : name_(host + ":" + std::to_string(port)),
        host_(std::move(host)),
        port_(port),
        timeout_(timeout),
        conn_(*this),
        splitter_(format) {}

  void Open() override {
    Close();
    detail::ConnectTcp(conn_, host_, port_, timeout_, *this);
  }
  void Close() override {
    conn_.Close();
    splitter_.Clear();
  }
  bool IsOpen() const override { return conn_.IsOpen(); }
  const std::string& name() const override { return name_; }

  void Write(std::string_view packet, Deadline deadline) override { conn_.Write(packet, deadline); }

  std::string ReadPacket(Deadline deadline) override {
    std::string frame;
    for (;;) {
      int32_t size = 0;
      switch (splitter_.Next(frame, &size)) {
        case FrameSplitter::Status::kFrame:
          return frame;
        case FrameSplitter::Status::kBadSize:
          throw BadFrame(name_, size, splitter_.format());
        case FrameSplitter::Status::kNeedMore:
          break;
      }
      if (Clock::now() >= deadline) {
        throw TransportError(TransportError::Kind::kTimeout, name_,
                             "no complete packet by the deadline");
      }
      const size_t n = conn_.ReadSome(chunk_, sizeof chunk_, deadline);
      splitter_.Append(std::string_view(chunk_, n));
    }
  }

  int Drain(Millis quiet, Deadline until) override {
    int bytes = static_cast<int>(splitter_.buffered());
    splitter_.Clear();
    if (!conn_.IsOpen()) return bytes;
    while (Clock::now() < until) {
      size_t n = 0;
      try {
        n = conn_.ReadSome(chunk_, sizeof chunk_, std::min(until, Clock::now() + quiet));
      } catch (const TransportError& e) {
        if (e.kind() != TransportError::Kind::kTimeout) throw;
        break;  // quiet
      }
      bytes += static_cast<int>(n);
    }
    return bytes;
  }

 private:
  std::string name_, host_;
  unsigned short port_;
  Millis timeout_;
  detail::AsioStream<asio::ip::tcp::socket> conn_;
  FrameSplitter splitter_;
  char chunk_[4096];
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
