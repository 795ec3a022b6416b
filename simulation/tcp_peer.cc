#include "simulation/tcp_peer.h"

#include <spdlog/spdlog.h>

#include <stdexcept>

namespace armsig::simulation {

namespace asio = boost::asio;
using tcp = asio::ip::tcp;

std::unique_ptr<tcp::acceptor> ListenTcp(asio::io_context& io, const std::string& host,
                                         unsigned short port, const std::string& device) {
  boost::system::error_code ec;
  const auto address = asio::ip::make_address(host, ec);
  if (ec) throw std::runtime_error(device + ": '" + host + "' is no IP address");
  const tcp::endpoint endpoint(address, port);
  auto acceptor = std::make_unique<tcp::acceptor>(io);
  acceptor->open(endpoint.protocol(), ec);
  if (!ec) acceptor->set_option(tcp::acceptor::reuse_address(true), ec);
  if (!ec) acceptor->bind(endpoint, ec);
  if (!ec) acceptor->listen(asio::socket_base::max_listen_connections, ec);
  if (ec) {
    throw std::runtime_error(device + ": cannot listen on " + host + ":" + std::to_string(port) +
                             " (" + ec.message() + ")");
  }
  return acceptor;
}

void TcpPeer::Close() {
  closed = true;
  out_.clear();
  boost::system::error_code ignored;
  socket.shutdown(tcp::socket::shutdown_both, ignored);
  socket.close(ignored);
}

void TcpPeer::Send(const std::shared_ptr<TcpPeer>& peer, std::vector<Step> steps) {
  if (peer->closed) return;
  for (auto& s : steps) peer->out_.push_back(std::move(s));
  if (!peer->writing_) Pump(peer);
}

void TcpPeer::Pump(std::shared_ptr<TcpPeer> peer) {
  if (peer->closed || peer->out_.empty()) {
    peer->writing_ = false;
    return;
  }
  peer->writing_ = true;
  auto step = std::make_shared<Step>(std::move(peer->out_.front()));
  peer->out_.pop_front();
  auto write = [peer, step] {
    if (peer->closed) return;
    asio::async_write(peer->socket, asio::buffer(step->bytes),
                      [peer, step](const boost::system::error_code& ec, size_t) {
                        if (ec) {
                          peer->writing_ = false;
                          return;
                        }
                        Pump(peer);
                      });
  };
  if (step->delay.count() <= 0) {
    write();
    return;
  }
  auto timer = std::make_shared<asio::steady_timer>(peer->socket.get_executor(), step->delay);
  timer->async_wait([timer, write](const boost::system::error_code& ec) {
    if (!ec) write();
  });
}

void FramedPeer::ReadFrames(const std::shared_ptr<FramedPeer>& peer, std::string device,
                            std::function<void(const std::string& frame)> on_frame) {
  peer->socket.async_read_some(
      asio::buffer(peer->chunk_),
      [peer, device = std::move(device), on_frame = std::move(on_frame)](
          const boost::system::error_code& ec, size_t n) mutable {
        if (ec || peer->closed) return;
        peer->splitter_.Append(std::string_view(peer->chunk_, n));
        std::string frame;
        for (;;) {
          int32_t size = 0;
          const auto status = peer->splitter_.Next(frame, &size);
          if (status == instruments::FrameSplitter::Status::kNeedMore) break;
          if (status == instruments::FrameSplitter::Status::kBadSize) {
            spdlog::debug("{}: dropped bytes announcing a packet of {} bytes", device, size);
            break;
          }
          on_frame(frame);
          if (peer->closed) return;
        }
        ReadFrames(peer, std::move(device), std::move(on_frame));
      });
}

}  // namespace armsig::simulation
