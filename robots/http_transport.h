// HTTP/1.1 request–response exchanges over one kept-alive TCP connection, plain or inside
// TLS (Boost.Beast over Boost.Asio, OpenSSL), and an in-memory fake for driver tests. The
// same deadline and interrupt semantics as the line transports (instruments/transport.h):
// an exchange, connection and TLS handshake included, ends by one absolute deadline; the
// interrupt flag ends any wait within kInterruptPoll. A reply larger than kMaxReplyBytes is
// refused (kLineTooLong: the peer is not answering the request).
//
// TLS trusts a server in one of two ways only, both stated in the lab file:
// - pinned: the SHA-256 fingerprint of the server's own certificate (what a controller's
//   self-signed certificate needs; the chain and the name are not checked, the key is);
// - a CA file: the chain must verify against it and the certificate must name the host
//   (RFC 2818).
// Anything else is refused with CertificateError, which names the fingerprint the server
// presented, so that an operator can compare it with the controller's and pin it.
#pragma once

#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "instruments/transport.h"

namespace armsig::robots {

inline constexpr size_t kMaxReplyBytes = 1 << 20;

struct HttpRequest {
  std::string method, target, body;
  std::vector<std::pair<std::string, std::string>> headers;
};

struct HttpResponse {
  unsigned status = 0;
  std::string body;
  std::vector<std::pair<std::string, std::string>> headers;
  // The first header of that name (case-insensitive), "" when absent.
  std::string Header(std::string_view name) const;
  std::vector<std::string> Headers(std::string_view name) const;
};

struct TlsSettings {
  bool enabled = false;
  std::string pinned_sha256;  // canonical "AB:CD:…" (http::CanonicalFingerprint)
  std::string ca_file;
};

// The server's certificate is not trusted (not the pinned one, not verifiable against the
// CA file, or neither was given). Never retried.
class CertificateError : public instruments::TransportError {
 public:
  CertificateError(std::string device, std::string message, std::string fingerprint)
      : instruments::TransportError(Kind::kOpen, std::move(device), std::move(message)),
        fingerprint_(std::move(fingerprint)) {}
  const std::string& fingerprint() const { return fingerprint_; }  // "" when none was seen

 private:
  std::string fingerprint_;
};

class HttpTransport : public instruments::TransportBase {
 public:
  // Sends the request (Host, Content-Length and Connection: keep-alive are added) and reads
  // the reply by `deadline`, opening the connection first when it is not open. Throws
  // TransportError (kOpen, kTimeout, kClosed, kIo, kLineTooLong, kInterrupted) or
  // CertificateError; the connection is closed after any of them.
  virtual HttpResponse Exchange(const HttpRequest& request, instruments::Deadline deadline) = 0;
  // Opens by `deadline` (connect and TLS handshake).
  virtual void OpenBy(instruments::Deadline deadline) = 0;
  void Open() override { OpenBy(instruments::Clock::now() + instruments::Millis(3000)); }
  int Drain(instruments::Millis, instruments::Deadline) override { return 0; }  // a reply is read whole or dropped
  // The SHA-256 fingerprint of the certificate the server presented last ("" for plain
  // HTTP or before a handshake).
  virtual std::string peer_fingerprint() const { return ""; }
};

std::unique_ptr<HttpTransport> MakeHttpTransport(const std::string& host, unsigned short port,
                                                 TlsSettings tls = {});

// For driver unit tests: every exchange is answered by `responder`; nullopt is a dropped
// connection (kClosed). No waiting.
class FakeHttpTransport : public HttpTransport {
 public:
  using Responder = std::function<std::optional<HttpResponse>(const HttpRequest&)>;
  explicit FakeHttpTransport(Responder responder, std::string name = "fake controller")
      : responder_(std::move(responder)), name_(std::move(name)) {}
  HttpResponse Exchange(const HttpRequest& request, instruments::Deadline deadline) override;
  void OpenBy(instruments::Deadline) override;
  void Close() override { open_ = false; }
  bool IsOpen() const override { return open_; }
  const std::string& name() const override { return name_; }
  const std::vector<HttpRequest>& requests() const { return requests_; }
  int opens() const { return opens_; }

 private:
  Responder responder_;
  std::string name_;
  bool open_ = false;
  int opens_ = 0;
  std::vector<HttpRequest> requests_;
};

}  // namespace armsig::robots
