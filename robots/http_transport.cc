#include "robots/http_transport.h"

// clang-format off
#include <utility>  // first: Boost 1.74 Asio uses std::exchange without including it (C++20)
#include <boost/asio.hpp>
// clang-format on
#include <openssl/ssl.h>
#include <openssl/x509.h>

#include <boost/asio/ssl.hpp>
#include <boost/asio/ssl/host_name_verification.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/http.hpp>
#include <boost/beast/ssl.hpp>
#include <cctype>
#include <optional>

#include "instruments/asio_stream.h"
#include "robots/http_auth.h"

namespace armsig::robots {
namespace detail = instruments::detail;
using instruments::detail::Wait;
using instruments::Deadline;
using instruments::TransportError;

namespace {

namespace asio = boost::asio;
namespace beast = boost::beast;
namespace bhttp = boost::beast::http;
namespace ssl = boost::asio::ssl;
using tcp = asio::ip::tcp;

bool SameName(std::string_view a, std::string_view b) {
  if (a.size() != b.size()) return false;
  for (size_t i = 0; i < a.size(); ++i) {
    if (std::tolower(static_cast<unsigned char>(a[i])) !=
        std::tolower(static_cast<unsigned char>(b[i])))
      return false;
  }
  return true;
}

std::string Fingerprint(X509* cert) {
  const int n = i2d_X509(cert, nullptr);
  if (n <= 0) return "";
  std::string der(static_cast<size_t>(n), '\0');
  auto* p = reinterpret_cast<unsigned char*>(der.data());
  i2d_X509(cert, &p);
  return http::Sha256Fingerprint(der);
}

bool IsIpAddress(const std::string& host) {
  boost::system::error_code ec;
  asio::ip::make_address(host, ec);
  return !ec;
}

class BeastHttpTransport : public HttpTransport {
 public:
  BeastHttpTransport(std::string host, unsigned short port, TlsSettings tls)
      : name_(host + ":" + std::to_string(port)),
        host_(std::move(host)),
        port_(port),
        tls_(std::move(tls)),
        ssl_context_(ssl::context::tls_client) {}

  const std::string& name() const override { return name_; }
  std::string peer_fingerprint() const override { return fingerprint_; }

  bool IsOpen() const override {
    if (ssl_) return beast::get_lowest_layer(*ssl_).socket().is_open();
    return plain_ && plain_->socket().is_open();
  }

  void Close() override {
    if (ssl_) {
      beast::get_lowest_layer(*ssl_).close();
      ssl_.reset();
    }
    if (plain_) {
      plain_->close();
      plain_.reset();
    }
    buffer_.clear();
  }

  void OpenBy(Deadline deadline) override {
    Close();
    boost::system::error_code ec;
    tcp::resolver resolver(io_);
    tcp::resolver::results_type endpoints;
    bool done = false;
    resolver.async_resolve(host_, std::to_string(port_),
                           [&](const boost::system::error_code& e, tcp::resolver::results_type r) {
                             ec = e;
                             endpoints = std::move(r);
                             done = true;
                           });
    Wait why = Run(deadline, done, [&] { resolver.cancel(); });
    Finish(why, done, ec, "cannot resolve", TransportError::Kind::kOpen);

    if (tls_.enabled) {
      PrepareTls();
      ssl_.emplace(io_, ssl_context_);
    } else {
      plain_.emplace(io_);
    }
    beast::tcp_stream& lowest = Lowest();
    done = false;
    lowest.async_connect(endpoints, [&](const boost::system::error_code& e, const tcp::endpoint&) {
      ec = e;
      done = true;
    });
    why = Run(deadline, done, [&] { lowest.cancel(); });
    Finish(why, done, ec, "cannot connect", TransportError::Kind::kOpen);
    lowest.socket().set_option(tcp::no_delay(true));
    if (!tls_.enabled) return;

    if (!IsIpAddress(host_)) SSL_set_tlsext_host_name(ssl_->native_handle(), host_.c_str());
    fingerprint_.clear();
    refusal_.clear();
    ssl_->set_verify_mode(ssl::verify_peer);
    ssl_->set_verify_callback([this](bool preverified, ssl::verify_context& ctx) {
      return Verify(preverified, ctx);
    });
    done = false;
    ssl_->async_handshake(ssl::stream_base::client, [&](const boost::system::error_code& e) {
      ec = e;
      done = true;
    });
    why = Run(deadline, done, [&] { Lowest().cancel(); });
    if (!refusal_.empty()) {
      Close();
      throw CertificateError(name_, refusal_, fingerprint_);
    }
    Finish(why, done, ec, "TLS handshake failed", TransportError::Kind::kOpen);
  }

  HttpResponse Exchange(const HttpRequest& request, Deadline deadline) override {
    if (!IsOpen()) OpenBy(deadline);
    const bhttp::verb verb = bhttp::string_to_verb(request.method);
    if (verb == bhttp::verb::unknown) {
      throw std::invalid_argument("unknown HTTP method " + request.method);
    }
    bhttp::request<bhttp::string_body> req{verb, request.target, 11};
    req.set(bhttp::field::host, host_);
    req.set(bhttp::field::user_agent, "armsig");
    req.set(bhttp::field::connection, "keep-alive");
    for (const auto& [n, v] : request.headers) req.set(n, v);
    req.body() = request.body;
    req.prepare_payload();

    boost::system::error_code ec;
    bool done = false;
    auto on_io = [&](const boost::system::error_code& e, size_t) {
      ec = e;
      done = true;
    };
    if (ssl_)
      bhttp::async_write(*ssl_, req, on_io);
    else
      bhttp::async_write(*plain_, req, on_io);
    Wait why = Run(deadline, done, [&] { Lowest().cancel(); });
    Finish(why, done, ec, "write failed", TransportError::Kind::kIo);

    bhttp::response_parser<bhttp::string_body> parser;
    parser.body_limit(kMaxReplyBytes);
    parser.header_limit(16 * 1024);
    done = false;
    if (ssl_)
      bhttp::async_read(*ssl_, buffer_, parser, on_io);
    else
      bhttp::async_read(*plain_, buffer_, parser, on_io);
    why = Run(deadline, done, [&] { Lowest().cancel(); });
    Finish(why, done, ec, "read failed", TransportError::Kind::kIo);

    bhttp::response<bhttp::string_body> res = parser.release();
    HttpResponse out;
    out.status = res.result_int();
    for (const auto& field : res) {
      out.headers.emplace_back(std::string(field.name_string()), std::string(field.value()));
    }
    out.body = std::move(res.body());
    if (!res.keep_alive()) Close();
    return out;
  }

 private:
  using Wait = detail::Wait;

  beast::tcp_stream& Lowest() { return ssl_ ? beast::get_lowest_layer(*ssl_) : *plain_; }

  // Runs the io_context until `done`, the deadline or an interrupt (detail::RunUntil).
  template <typename Cancel>
  Wait Run(Deadline deadline, bool& done, Cancel&& cancel) {
    return detail::RunUntil(io_, *this, deadline, done, std::forward<Cancel>(cancel));
  }

  // Throws for anything but a completed operation without error; closes the connection.
  // (Call it with Run's result held in a variable: `done` must be read after Run.)
  void Finish(Wait why, bool done, const boost::system::error_code& ec, const std::string& what,
              TransportError::Kind failure) {
    if (why == Wait::kInterrupted) {
      Close();
      ThrowInterrupted();
    }
    if (!done || why == Wait::kDeadline || ec == asio::error::operation_aborted) {
      Close();
      throw TransportError(TransportError::Kind::kTimeout, name_, what + ": not done by the deadline");
    }
    if (!ec) return;
    Close();
    using Kind = TransportError::Kind;
    Kind kind = failure;
    if (ec == bhttp::error::body_limit || ec == bhttp::error::header_limit ||
        ec == bhttp::error::buffer_overflow) {
      kind = Kind::kLineTooLong;
    } else if (failure != Kind::kOpen &&
               (ec == bhttp::error::end_of_stream || ec == asio::error::eof ||
                ec == asio::error::connection_reset || ec == asio::error::broken_pipe ||
                ec == ssl::error::stream_truncated || ec == bhttp::error::partial_message)) {
      kind = Kind::kClosed;
    }
    throw TransportError(kind, name_, what + " (" + ec.message() + ")");
  }

  void PrepareTls() {
    if (tls_prepared_) return;
    if (!tls_.ca_file.empty()) {
      boost::system::error_code ec;
      ssl_context_.load_verify_file(tls_.ca_file, ec);
      if (ec) {
        throw CertificateError(name_,
                               "cannot read the CA file " + tls_.ca_file + " (" + ec.message() + ")",
                               "");
      }
    }
    tls_prepared_ = true;
  }

  bool Verify(bool preverified, ssl::verify_context& ctx) {
    X509_STORE_CTX* store = ctx.native_handle();
    const int depth = X509_STORE_CTX_get_error_depth(store);
    X509* cert = X509_STORE_CTX_get_current_cert(store);
    if (depth == 0 && cert) fingerprint_ = Fingerprint(cert);
    if (!tls_.pinned_sha256.empty()) {
      if (depth > 0) return true;  // the server's own certificate is what is pinned
      if (fingerprint_ == tls_.pinned_sha256) return true;
      refusal_ = "its certificate (SHA-256 " + fingerprint_ + ") is not the pinned one (" +
                 tls_.pinned_sha256 + ")";
      return false;
    }
    if (!tls_.ca_file.empty()) {
      if (!preverified) {
        refusal_ = std::string("its certificate does not verify against the CA file ") +
                   tls_.ca_file + " (" +
                   X509_verify_cert_error_string(X509_STORE_CTX_get_error(store)) + ")";
        return false;
      }
      if (depth == 0 && !ssl::host_name_verification(host_)(preverified, ctx)) {
        refusal_ = "its certificate (SHA-256 " + fingerprint_ + ") does not name " + host_;
        return false;
      }
      return true;
    }
    if (depth == 0) {
      refusal_ = "its certificate (SHA-256 " + fingerprint_ +
                 ") is not trusted: neither a pinned fingerprint nor a CA file is given";
      return false;
    }
    return true;  // the leaf decides
  }

  std::string name_, host_;
  unsigned short port_;
  TlsSettings tls_;
  asio::io_context io_;
  ssl::context ssl_context_;
  bool tls_prepared_ = false;
  std::optional<beast::tcp_stream> plain_;
  std::optional<ssl::stream<beast::tcp_stream>> ssl_;
  beast::flat_buffer buffer_;
  std::string fingerprint_, refusal_;
};

}  // namespace

std::string HttpResponse::Header(std::string_view name) const {
  for (const auto& [n, v] : headers) {
    if (SameName(n, name)) return v;
  }
  return "";
}

std::vector<std::string> HttpResponse::Headers(std::string_view name) const {
  std::vector<std::string> out;
  for (const auto& [n, v] : headers) {
    if (SameName(n, name)) out.push_back(v);
  }
  return out;
}

std::unique_ptr<HttpTransport> MakeHttpTransport(const std::string& host, unsigned short port,
                                                 TlsSettings tls) {
  return std::make_unique<BeastHttpTransport>(host, port, std::move(tls));
}

void FakeHttpTransport::OpenBy(Deadline) {
  if (Interrupted()) ThrowInterrupted();
  open_ = true;
  ++opens_;
}

HttpResponse FakeHttpTransport::Exchange(const HttpRequest& request, Deadline deadline) {
  if (Interrupted()) ThrowInterrupted();
  if (!open_) OpenBy(deadline);
  requests_.push_back(request);
  std::optional<HttpResponse> response = responder_(request);
  if (!response) {
    open_ = false;
    throw TransportError(TransportError::Kind::kClosed, name_, "connection closed by the peer");
  }
  return *response;
}

}  // namespace armsig::robots
