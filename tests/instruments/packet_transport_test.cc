// The emScon packet transport over a real TCP connection on localhost: a peer written here
// with Boost.Asio plays the tracker's side byte by byte. Whole packets come out however the
// bytes arrive; a stalled peer is a timeout named by the connection and loses nothing; a
// peer that closes mid-packet is kClosed, and a reconnection starts from clean framing; a
// size field out of bounds is kBadFrame; the interrupt flag and a refused connection are
// their own errors.
#include "instruments/packet_transport.h"

#include <gtest/gtest.h>

// clang-format off
#include <utility>  // first: Boost 1.74 Asio uses std::exchange without including it (C++20)
#include <boost/asio.hpp>
// clang-format on
#include <atomic>
#include <cstdint>
#include <functional>
#include <string>

namespace armsig::instruments {
namespace {

namespace asio = boost::asio;
using asio::ip::tcp;
using namespace std::chrono_literals;

// An emScon frame: its whole length and its type as int32 little-endian, then the payload.
std::string Packet(int32_t type, const std::string& payload) {
  std::string out;
  auto put = [&](int32_t v) {
    for (int k = 0; k < 4; ++k)
      out += static_cast<char>((static_cast<uint32_t>(v) >> (8 * k)) & 0xff);
  };
  put(static_cast<int32_t>(8 + payload.size()));
  put(type);
  return out + payload;
}

// The tracker's side: a socket listening on a free port of 127.0.0.1; each Accept takes
// the transport's next connection (which the kernel completes as soon as it is made).
class Peer {
 public:
  Peer() : acceptor_(io_, tcp::endpoint(asio::ip::address_v4::loopback(), 0)) {}
  unsigned short port() const { return acceptor_.local_endpoint().port(); }
  void Accept() {
    socket_ = tcp::socket(io_);
    acceptor_.accept(socket_);
  }
  void Send(const std::string& bytes) { asio::write(socket_, asio::buffer(bytes)); }
  std::string Receive(size_t n) {
    std::string bytes(n, '\0');
    asio::read(socket_, asio::buffer(bytes));
    return bytes;
  }
  void Close() { socket_.close(); }

 private:
  asio::io_context io_;
  tcp::acceptor acceptor_;
  tcp::socket socket_{io_};
};

// The kind of TransportError `f` throws, its text in `*what`.
std::optional<TransportError::Kind> ErrorOf(const std::function<void()>& f, std::string* what) {
  try {
    f();
  } catch (const TransportError& e) {
    *what = e.what();
    return e.kind();
  }
  return std::nullopt;
}

Deadline In(Millis m) { return Clock::now() + m; }

struct Connected {
  Peer peer;
  std::unique_ptr<PacketTransport> transport;
  std::string name;
  Connected() {
    transport = MakeEmsconTcpTransport("127.0.0.1", peer.port());
    transport->Open();
    peer.Accept();
    name = "127.0.0.1:" + std::to_string(peer.port());
  }
};

}  // namespace

// What the client writes arrives as written; two packets in one segment come out as two,
// and a packet given in pieces comes out whole.
TEST(TcpPacketTransport, CarriesWholePacketsWhateverTheSegments) {
  Connected c;
  EXPECT_TRUE(c.transport->IsOpen());
  EXPECT_EQ(c.transport->name(), c.name);
  const std::string command = Packet(0, std::string("\x0b\x00\x00\x00", 4));
  c.transport->Write(command, In(10s));
  EXPECT_EQ(c.peer.Receive(command.size()), command);

  const std::string a = Packet(2, std::string(40, 'a')), b = Packet(8, "bbbb");
  const std::string d = Packet(3, std::string(5000, 'd'));  // more than one read's 4 KiB
  c.peer.Send(a + b);
  c.peer.Send(d.substr(0, 3));
  c.peer.Send(d.substr(3, 9));
  c.peer.Send(d.substr(12));
  EXPECT_EQ(c.transport->ReadPacket(In(10s)), a);
  EXPECT_EQ(c.transport->ReadPacket(In(10s)), b);
  EXPECT_EQ(c.transport->ReadPacket(In(10s)), d);
}

// A peer that sends half a packet and stalls: the read ends at its deadline, no earlier,
// as a timeout named by the connection; the half is kept, and the packet comes out whole
// when the rest arrives.
TEST(TcpPacketTransport, AStalledPeerIsATimeoutAtTheDeadlineAndLosesNothing) {
  Connected c;
  const std::string p = Packet(2, std::string(32, 'p'));
  c.peer.Send(p.substr(0, 10));
  std::string what;
  const auto start = Clock::now();
  const auto kind = ErrorOf([&] { c.transport->ReadPacket(In(150ms)); }, &what);
  EXPECT_GE(Clock::now() - start, 150ms);
  ASSERT_EQ(kind, TransportError::Kind::kTimeout) << what;
  EXPECT_EQ(what.rfind(c.name + ": ", 0), 0u) << what;
  EXPECT_NE(what.find("by the deadline"), std::string::npos) << what;
  EXPECT_TRUE(c.transport->IsOpen());
  c.peer.Send(p.substr(10));
  EXPECT_EQ(c.transport->ReadPacket(In(10s)), p);
}

// A peer that closes in the middle of a packet: kClosed, the connection closed on this side
// too; reopened, the next connection's packets are read from their first byte (the torn
// half is not glued to them).
TEST(TcpPacketTransport, APeerThatClosesMidPacketIsClosedAndAReconnectionStartsClean) {
  Connected c;
  const std::string torn = Packet(2, std::string(32, 't'));
  c.peer.Send(torn.substr(0, 20));
  c.peer.Close();
  std::string what;
  EXPECT_EQ(ErrorOf([&] { c.transport->ReadPacket(In(10s)); }, &what),
            TransportError::Kind::kClosed)
      << what;
  EXPECT_EQ(what.rfind(c.name + ": read failed", 0), 0u) << what;
  EXPECT_FALSE(c.transport->IsOpen());
  EXPECT_EQ(ErrorOf([&] { c.transport->ReadPacket(In(10s)); }, &what),
            TransportError::Kind::kClosed);
  EXPECT_EQ(what, c.name + ": port is not open");

  c.transport->Open();
  c.peer.Accept();
  const std::string fresh = Packet(8, "next");
  c.peer.Send(fresh);
  EXPECT_EQ(c.transport->ReadPacket(In(10s)), fresh);
}

// A size field below the smallest packet: the stream lost its framing (kBadFrame, naming
// the field); what was buffered is dropped, and packets sent afterwards are read again.
TEST(TcpPacketTransport, ASizeFieldOutOfBoundsIsABadFrame) {
  Connected c;
  c.peer.Send(std::string("\x04\x00\x00\x00garbage", 11));
  std::string what;
  EXPECT_EQ(ErrorOf([&] { c.transport->ReadPacket(In(10s)); }, &what),
            TransportError::Kind::kBadFrame)
      << what;
  EXPECT_EQ(what,
            c.name + ": frame size field 4 outside 12 to 65536 bytes: the stream lost its framing");
  const std::string good = Packet(8, "good");
  c.peer.Send(good);
  EXPECT_EQ(c.transport->ReadPacket(In(10s)), good);
}

// The interrupt flag (Ctrl-C) ends a wait that has minutes left: kInterrupted.
TEST(TcpPacketTransport, TheInterruptFlagEndsAWait) {
  Connected c;
  std::atomic<bool> stop{true};
  c.transport->SetInterrupt(&stop);
  std::string what;
  EXPECT_EQ(ErrorOf([&] { c.transport->ReadPacket(In(10min)); }, &what),
            TransportError::Kind::kInterrupted)
      << what;
  c.transport->SetInterrupt(nullptr);
}

// Nothing listening on the port: Open fails as kOpen, naming host and port.
TEST(TcpPacketTransport, ARefusedConnectionIsAnOpenError) {
  unsigned short port = 0;
  {
    Peer gone;  // a port that was free a moment ago, its listener closed again
    port = gone.port();
  }
  auto transport = MakeEmsconTcpTransport("127.0.0.1", port, 3000ms);
  std::string what;
  EXPECT_EQ(ErrorOf([&] { transport->Open(); }, &what), TransportError::Kind::kOpen) << what;
  EXPECT_EQ(what.rfind("127.0.0.1:" + std::to_string(port) + ": cannot connect", 0), 0u) << what;
  EXPECT_FALSE(transport->IsOpen());
}

}  // namespace armsig::instruments
