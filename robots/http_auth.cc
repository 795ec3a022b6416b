#include "robots/http_auth.h"

#include <openssl/evp.h>

#include <algorithm>
#include <array>
#include <cctype>
#include <cstdio>

namespace armsig::robots::http {

namespace {

bool IsTchar(char c) {  // RFC 9110 section 5.6.2
  return std::isalnum(static_cast<unsigned char>(c)) ||
         std::string_view("!#$%&'*+-.^_`|~").find(c) != std::string_view::npos;
}

std::string Lower(std::string_view s) {
  std::string out(s);
  for (char& c : out) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return out;
}

class Cursor {
 public:
  explicit Cursor(std::string_view text) : text_(text) {}
  bool AtEnd() const { return at_ >= text_.size(); }
  char Peek() const { return AtEnd() ? '\0' : text_[at_]; }
  size_t at() const { return at_; }
  void Reset(size_t at) { at_ = at; }
  void SkipSpaces() {
    while (!AtEnd() && (Peek() == ' ' || Peek() == '\t')) ++at_;
  }
  void SkipSpacesAndCommas() {
    while (!AtEnd() && (Peek() == ' ' || Peek() == '\t' || Peek() == ',')) ++at_;
  }
  std::string Token() {
    const size_t start = at_;
    while (!AtEnd() && IsTchar(Peek())) ++at_;
    return std::string(text_.substr(start, at_ - start));
  }
  std::string Quoted() {  // at the opening quote
    std::string out;
    ++at_;
    while (!AtEnd()) {
      const char c = text_[at_++];
      if (c == '"') return out;
      if (c == '\\') {
        if (AtEnd()) break;
        out.push_back(text_[at_++]);
      } else {
        out.push_back(c);
      }
    }
    throw HeaderError("unterminated quoted-string in an authentication header");
  }

 private:
  std::string_view text_;
  size_t at_ = 0;
};

// The auth-params after a scheme, up to the next challenge's scheme or the end.
void ReadParams(Cursor& in, Challenge& challenge) {
  for (;;) {
    in.SkipSpacesAndCommas();
    if (in.AtEnd()) return;
    const size_t start = in.at();
    const std::string name = in.Token();
    if (name.empty()) {
      throw HeaderError(std::string("unexpected character '") + in.Peek() +
                        "' in an authentication header");
    }
    in.SkipSpaces();
    if (in.Peek() != '=') {  // the next challenge's scheme
      in.Reset(start);
      return;
    }
    in.Reset(in.at() + 1);
    in.SkipSpaces();
    std::string value = in.Peek() == '"' ? in.Quoted() : in.Token();
    challenge.params[Lower(name)] = std::move(value);
    in.SkipSpaces();
    if (!in.AtEnd() && in.Peek() != ',') {
      throw HeaderError("expected ',' between parameters of an authentication header");
    }
  }
}

std::string Hex(const unsigned char* bytes, size_t n, bool upper, bool colons) {
  static constexpr char kLower[] = "0123456789abcdef";
  static constexpr char kUpper[] = "0123456789ABCDEF";
  const char* digits = upper ? kUpper : kLower;
  std::string out;
  for (size_t i = 0; i < n; ++i) {
    if (colons && i > 0) out.push_back(':');
    out.push_back(digits[bytes[i] >> 4]);
    out.push_back(digits[bytes[i] & 15]);
  }
  return out;
}

std::string Digest(std::string_view data, const EVP_MD* md, bool upper, bool colons) {
  std::array<unsigned char, EVP_MAX_MD_SIZE> out{};
  unsigned n = 0;
  if (EVP_Digest(data.data(), data.size(), out.data(), &n, md, nullptr) != 1) {
    throw std::runtime_error("OpenSSL digest failed");
  }
  return Hex(out.data(), n, upper, colons);
}

std::string Trim(std::string_view s) {
  while (!s.empty() && (s.front() == ' ' || s.front() == '\t')) s.remove_prefix(1);
  while (!s.empty() && (s.back() == ' ' || s.back() == '\t')) s.remove_suffix(1);
  return std::string(s);
}

}  // namespace

const std::string* Challenge::Param(const std::string& name) const {
  const auto it = params.find(name);
  return it == params.end() ? nullptr : &it->second;
}

std::vector<Challenge> ParseChallenges(std::string_view header) {
  std::vector<Challenge> out;
  Cursor in(header);
  for (;;) {
    in.SkipSpacesAndCommas();
    if (in.AtEnd()) break;
    Challenge c;
    c.scheme = in.Token();
    if (c.scheme.empty()) throw HeaderError("an authentication challenge without a scheme");
    if (!in.AtEnd() && in.Peek() != ' ' && in.Peek() != '\t' && in.Peek() != ',') {
      throw HeaderError("unexpected character after the scheme " + c.scheme);
    }
    ReadParams(in, c);
    out.push_back(std::move(c));
  }
  if (out.empty()) throw HeaderError("an empty authentication header");
  return out;
}

Challenge ParseCredentials(std::string_view header) {
  Cursor in(header);
  in.SkipSpaces();
  Challenge c;
  c.scheme = in.Token();
  if (c.scheme.empty()) throw HeaderError("credentials without a scheme");
  ReadParams(in, c);
  in.SkipSpacesAndCommas();
  if (!in.AtEnd()) throw HeaderError("more than one set of credentials");
  return c;
}

std::string DigestResponse(std::string_view user, std::string_view realm,
                           std::string_view password, std::string_view method,
                           std::string_view uri, std::string_view nonce, std::string_view nc,
                           std::string_view cnonce) {
  const std::string ha1 =
      Md5Hex(std::string(user) + ":" + std::string(realm) + ":" + std::string(password));
  const std::string ha2 = Md5Hex(std::string(method) + ":" + std::string(uri));
  return Md5Hex(ha1 + ":" + std::string(nonce) + ":" + std::string(nc) + ":" +
                std::string(cnonce) + ":auth:" + ha2);
}

std::string DigestAuthorization(const Challenge& challenge, std::string_view user,
                                std::string_view password, std::string_view method,
                                std::string_view uri, std::string_view cnonce, unsigned nc) {
  const std::string* realm = challenge.Param("realm");
  const std::string* nonce = challenge.Param("nonce");
  if (!realm || !nonce) throw HeaderError("a Digest challenge without realm or nonce");
  if (const std::string* algorithm = challenge.Param("algorithm");
      algorithm && Lower(*algorithm) != "md5") {
    throw HeaderError("a Digest challenge asking for algorithm " + *algorithm +
                      " (only MD5 is implemented)");
  }
  if (const std::string* qop = challenge.Param("qop")) {
    bool auth = false;
    std::string_view rest(*qop);
    while (!rest.empty()) {
      const size_t comma = rest.find(',');
      auth |= Trim(rest.substr(0, comma)) == "auth";
      rest = comma == std::string_view::npos ? std::string_view() : rest.substr(comma + 1);
    }
    if (!auth) throw HeaderError("a Digest challenge without qop=auth");
  }
  char nc_text[16];
  std::snprintf(nc_text, sizeof nc_text, "%08x", nc);
  const std::string response =
      DigestResponse(user, *realm, password, method, uri, *nonce, nc_text, cnonce);
  auto quoted = [](std::string_view v) {
    std::string out = "\"";
    for (char c : v) {
      if (c == '"' || c == '\\') out.push_back('\\');
      out.push_back(c);
    }
    return out + "\"";
  };
  std::string out = "Digest username=" + quoted(user) + ", realm=" + quoted(*realm) +
                    ", nonce=" + quoted(*nonce) + ", uri=" + quoted(uri) +
                    ", algorithm=MD5, response=" + quoted(response) + ", qop=auth, nc=" + nc_text +
                    ", cnonce=" + quoted(cnonce);
  if (const std::string* opaque = challenge.Param("opaque")) out += ", opaque=" + quoted(*opaque);
  return out;
}

std::string BasicAuthorization(std::string_view user, std::string_view password) {
  return "Basic " + Base64Encode(std::string(user) + ":" + std::string(password));
}

std::optional<std::pair<std::string, std::string>> ParseBasicAuthorization(
    std::string_view header) {
  std::string_view h = header;
  while (!h.empty() && h.front() == ' ') h.remove_prefix(1);
  if (h.size() < 6 || Lower(h.substr(0, 6)) != "basic ") return std::nullopt;
  const auto decoded = Base64Decode(Trim(h.substr(6)));
  if (!decoded) return std::nullopt;
  const size_t colon = decoded->find(':');
  if (colon == std::string::npos) return std::nullopt;
  return std::make_pair(decoded->substr(0, colon), decoded->substr(colon + 1));
}

std::string Md5Hex(std::string_view data) { return Digest(data, EVP_md5(), false, false); }

std::string Base64Encode(std::string_view data) {
  std::string out(4 * ((data.size() + 2) / 3) + 1, '\0');
  const int n = EVP_EncodeBlock(reinterpret_cast<unsigned char*>(out.data()),
                                reinterpret_cast<const unsigned char*>(data.data()),
                                static_cast<int>(data.size()));
  out.resize(static_cast<size_t>(std::max(n, 0)));
  return out;
}

std::optional<std::string> Base64Decode(std::string_view text) {
  if (text.size() % 4 != 0) return std::nullopt;
  size_t padding = 0;
  for (size_t i = 0; i < text.size(); ++i) {
    const char c = text[i];
    if (c == '=') {
      if (i + 2 < text.size()) return std::nullopt;  // '=' only in the last two places
      ++padding;
      continue;
    }
    if (padding > 0) return std::nullopt;  // data after padding
    if (!std::isalnum(static_cast<unsigned char>(c)) && c != '+' && c != '/') return std::nullopt;
  }
  std::string out(text.size() / 4 * 3 + 1, '\0');
  const int n = EVP_DecodeBlock(reinterpret_cast<unsigned char*>(out.data()),
                                reinterpret_cast<const unsigned char*>(text.data()),
                                static_cast<int>(text.size()));
  if (n < 0 || static_cast<size_t>(n) < padding) return std::nullopt;
  out.resize(static_cast<size_t>(n) - padding);
  return out;
}

std::optional<Cookie> ParseSetCookie(std::string_view header) {
  const std::string_view pair = header.substr(0, header.find(';'));
  const size_t eq = pair.find('=');
  if (eq == std::string_view::npos) return std::nullopt;
  Cookie c{Trim(pair.substr(0, eq)), Trim(pair.substr(eq + 1))};
  if (c.name.empty()) return std::nullopt;
  return c;
}

std::vector<Cookie> ParseCookieHeader(std::string_view header) {
  std::vector<Cookie> out;
  while (!header.empty()) {
    const size_t semi = header.find(';');
    if (auto c = ParseSetCookie(header.substr(0, semi))) out.push_back(std::move(*c));
    header = semi == std::string_view::npos ? std::string_view() : header.substr(semi + 1);
  }
  return out;
}

std::string Sha256Fingerprint(std::string_view der) {
  return Digest(der, EVP_sha256(), true, true);
}

std::optional<std::string> CanonicalFingerprint(std::string_view text) {
  std::string hex;
  for (char c : text) {
    if (c == ':' || c == ' ' || c == '\t') continue;
    if (!std::isxdigit(static_cast<unsigned char>(c))) return std::nullopt;
    hex.push_back(static_cast<char>(std::toupper(static_cast<unsigned char>(c))));
  }
  if (hex.size() != 64) return std::nullopt;
  std::string out;
  for (size_t i = 0; i < hex.size(); i += 2) {
    if (i > 0) out.push_back(':');
    out += hex.substr(i, 2);
  }
  return out;
}

}  // namespace armsig::robots::http
