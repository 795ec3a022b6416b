// The HTTP pieces Robot Web Services authenticates with, as pure functions (no I/O; the
// digests from OpenSSL's libcrypto):
// - Digest access authentication, RFC 7616 (MD5, qop=auth), which RWS 1.0 (IRC5,
//   RobotWare 6) asks for on every request without a valid session cookie;
// - Basic authentication, RFC 7617, which RWS 2.0 (OmniCore, RobotWare 7) asks for over
//   TLS;
// - the WWW-Authenticate challenge grammar of RFC 7235 section 2.1 (auth-scheme, then
//   comma-separated auth-params whose values are tokens or quoted-strings);
// - session cookies, RFC 6265 section 4.1 (only the cookie's name and value matter here);
// - Base64 (RFC 4648) and the SHA-256 fingerprint of a DER certificate, written as 32
//   colon-separated upper-case hex pairs (what `openssl x509 -fingerprint -sha256` prints).
// Both ends use them: the driver (robots/abb_controller.h) and the virtual controller
// (simulation/rws_simulator.h).
#pragma once

#include <map>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace armsig::robots::http {

// A header that does not follow its grammar (a challenge without a scheme, an unterminated
// quoted-string, Base64 with stray bytes). The only exception these functions throw.
class HeaderError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// One challenge of a WWW-Authenticate header: its scheme ("Digest", "Basic") and its
// parameters, names lower-cased ("realm", "nonce", "qop", "opaque", "algorithm", "stale").
struct Challenge {
  std::string scheme;
  std::map<std::string, std::string> params;
  const std::string* Param(const std::string& name) const;
};

// Every challenge of a WWW-Authenticate value, in order.
std::vector<Challenge> ParseChallenges(std::string_view header);
// The parameters of a credentials value after its scheme (an Authorization header:
// `Digest username="…", realm="…", …`): scheme and lower-cased parameter names.
Challenge ParseCredentials(std::string_view header);

// RFC 7616 section 3.4.1 with MD5 and qop=auth: HA1 = MD5(user:realm:password),
// HA2 = MD5(method:uri), response = MD5(HA1:nonce:nc:cnonce:qop:HA2), lower-case hex. `nc`
// is the 8-digit hex nonce count ("00000001").
std::string DigestResponse(std::string_view user, std::string_view realm,
                           std::string_view password, std::string_view method,
                           std::string_view uri, std::string_view nonce, std::string_view nc,
                           std::string_view cnonce);
// The Authorization value answering a Digest challenge (realm, nonce and, when given,
// opaque taken from it). Throws HeaderError when the challenge has no realm or nonce or
// offers neither qop=auth nor an MD5 algorithm.
std::string DigestAuthorization(const Challenge& challenge, std::string_view user,
                                std::string_view password, std::string_view method,
                                std::string_view uri, std::string_view cnonce, unsigned nc);
// `Basic base64(user:password)`.
std::string BasicAuthorization(std::string_view user, std::string_view password);
// The user and password of a Basic Authorization value; nullopt when it is not one.
std::optional<std::pair<std::string, std::string>> ParseBasicAuthorization(
    std::string_view header);

std::string Md5Hex(std::string_view data);
std::string Base64Encode(std::string_view data);
// nullopt for anything but canonical Base64 (padding included).
std::optional<std::string> Base64Decode(std::string_view text);

// The name and value of a Set-Cookie value (attributes after the first ';' ignored);
// nullopt when it has no name=value pair.
struct Cookie {
  std::string name, value;
};
std::optional<Cookie> ParseSetCookie(std::string_view header);
// name=value pairs of a Cookie request header.
std::vector<Cookie> ParseCookieHeader(std::string_view header);

// "AB:CD:…" of SHA-256(der).
std::string Sha256Fingerprint(std::string_view der);
// A fingerprint as a user may write it (colons or not, either case, spaces around) in the
// canonical form; nullopt unless it is 32 bytes of hex.
std::optional<std::string> CanonicalFingerprint(std::string_view text);

}  // namespace armsig::robots::http
