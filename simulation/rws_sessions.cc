#include "simulation/rws_sessions.h"

#include <fmt/format.h>

#include <algorithm>
#include <cctype>

#include "robots/http_auth.h"

namespace armsig::simulation {

namespace bhttp = boost::beast::http;
namespace http = robots::http;
namespace rws = robots::rws;

namespace {

constexpr const char* kRealm = "validusers@robapi.abb";

std::string RandomHex(std::mt19937_64& rng) { return fmt::format("{:016x}", rng()); }

}  // namespace

RwsSessions::RwsSessions(rws::Version version, std::string user, std::string password)
    : version_(version), user_(std::move(user)), password_(std::move(password)) {}

std::optional<std::string> RwsSessions::Authenticate(const Request& req, Response& res) {
  if (std::optional<std::string> session = SessionOf(req)) return session;
  if (!CredentialsValid(req)) {
    if (req.find(bhttp::field::authorization) != req.end()) ++refused_logins_;
    res.set(bhttp::field::www_authenticate, Challenge());
    return std::nullopt;
  }
  const std::string id = fmt::format("{}::http.session::{}", ++next_session_, RandomHex(rng_));
  const std::string abbcx = std::to_string(next_session_);
  sessions_[id] = abbcx;
  ++logins_;
  res.insert(bhttp::field::set_cookie, "-http-session-=" + id + "; path=/; httponly");
  res.insert(bhttp::field::set_cookie, "ABBCX=" + abbcx + "; path=/; httponly");
  return id;
}

void RwsSessions::Logout(const std::string& session) { sessions_.erase(session); }

std::optional<std::string> RwsSessions::SessionOf(const Request& req) const {
  const auto it = req.find(bhttp::field::cookie);
  if (it == req.end()) return std::nullopt;
  std::string http_session, abbcx;
  for (const auto& c : http::ParseCookieHeader(std::string(it->value()))) {
    if (c.name == "-http-session-") http_session = c.value;
    if (c.name == "ABBCX") abbcx = c.value;
  }
  const auto s = sessions_.find(http_session);
  if (s == sessions_.end() || s->second != abbcx) return std::nullopt;
  return http_session;
}

bool RwsSessions::CredentialsValid(const Request& req) const {
  const auto it = req.find(bhttp::field::authorization);
  if (it == req.end()) return false;
  const std::string header(it->value());
  if (version_ == rws::Version::kRws2) {
    const auto basic = http::ParseBasicAuthorization(header);
    return basic && basic->first == user_ && basic->second == password_;
  }
  http::Challenge c;
  try {
    c = http::ParseCredentials(header);
  } catch (const http::HeaderError&) {
    return false;
  }
  std::string scheme = c.scheme;
  for (char& ch : scheme) ch = static_cast<char>(std::toupper(static_cast<unsigned char>(ch)));
  if (scheme != "DIGEST") return false;
  auto p = [&](const char* n) {
    const std::string* v = c.Param(n);
    return v ? *v : std::string();
  };
  const bool nonce_known = std::find(nonces_.begin(), nonces_.end(), p("nonce")) != nonces_.end();
  if (!nonce_known || p("realm") != kRealm || p("username") != user_ || p("qop") != "auth" ||
      p("uri") != std::string(req.target())) {
    return false;
  }
  const std::string expected =
      http::DigestResponse(user_, kRealm, password_, std::string(req.method_string()), p("uri"),
                           p("nonce"), p("nc"), p("cnonce"));
  return expected == p("response");
}

std::string RwsSessions::Challenge() {
  if (version_ == rws::Version::kRws2) return std::string("Basic realm=\"") + kRealm + "\"";
  nonces_.push_back(RandomHex(rng_) + RandomHex(rng_));
  if (nonces_.size() > 256) nonces_.pop_front();
  return fmt::format(
      "Digest realm=\"{}\", qop=\"auth\", nonce=\"{}\", opaque=\"{}\", algorithm=MD5", kRealm,
      nonces_.back(), opaque_);
}

}  // namespace armsig::simulation
