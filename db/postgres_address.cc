#include "db/postgres_address.h"

#include <postgresql/libpq-fe.h>

#include <cctype>
#include <memory>
#include <optional>
#include <vector>

#include "core/error.h"

namespace armsig::db {

namespace {

bool StartsWith(std::string_view text, std::string_view prefix) {
  return text.substr(0, prefix.size()) == prefix;
}

bool IsUri(std::string_view text) {
  return StartsWith(text, "postgresql://") || StartsWith(text, "postgres://");
}

// `scheme:` at the start (RFC 3986: a letter, then letters, digits, + - .).
std::optional<std::string_view> SchemeOf(std::string_view text) {
  if (text.empty() || !std::isalpha(static_cast<unsigned char>(text[0]))) return std::nullopt;
  size_t k = 1;
  while (k < text.size() && (std::isalnum(static_cast<unsigned char>(text[k])) || text[k] == '+' ||
                             text[k] == '-' || text[k] == '.'))
    ++k;
  if (k >= text.size() || text[k] != ':') return std::nullopt;
  return text.substr(0, k);
}

// A key/value connection string: its first word is `keyword=` (spaces allowed around '=').
bool IsKeyValue(std::string_view text) {
  size_t k = 0;
  while (k < text.size() && std::isspace(static_cast<unsigned char>(text[k]))) ++k;
  const size_t start = k;
  if (k >= text.size() || !(std::isalpha(static_cast<unsigned char>(text[k])) || text[k] == '_'))
    return false;
  while (k < text.size() && (std::isalnum(static_cast<unsigned char>(text[k])) || text[k] == '_'))
    ++k;
  if (k == start) return false;
  while (k < text.size() && (text[k] == ' ' || text[k] == '\t')) ++k;
  return k < text.size() && text[k] == '=';
}

int HexValue(char c) {
  if (c >= '0' && c <= '9') return c - '0';
  if (c >= 'a' && c <= 'f') return c - 'a' + 10;
  if (c >= 'A' && c <= 'F') return c - 'A' + 10;
  return -1;
}

// %XX decoded as libpq decodes a URI (a malformed escape stays as it is).
std::string PercentDecoded(std::string_view s) {
  std::string out;
  for (size_t k = 0; k < s.size(); ++k) {
    if (s[k] == '%' && k + 2 < s.size()) {
      const int hi = HexValue(s[k + 1]), lo = HexValue(s[k + 2]);
      if (hi >= 0 && lo >= 0) {
        out += static_cast<char>(hi * 16 + lo);
        k += 2;
        continue;
      }
    }
    out += s[k];
  }
  return out;
}

// A key that names a secret in any spelling: libpq's password and sslpassword (and any
// key that contains "password", which libpq would refuse anyway), case-insensitive.
bool SecretKey(std::string_view key) {
  std::string lower = PercentDecoded(key);
  for (char& c : lower) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return lower.find("password") != std::string::npos;
}

// postgresql://user:secret@host/db?a=1&password=x → postgresql://user@host/db?a=1.
std::string RedactUri(std::string_view uri, bool& removed) {
  const size_t authority = uri.find("://") + 3;
  // libpq's rule: the user part ends at the first '@' before the first '/'.
  size_t end = authority;
  while (end < uri.size() && uri[end] != '@' && uri[end] != '/') ++end;
  std::string out(uri.substr(0, authority));
  size_t rest = authority;
  if (end < uri.size() && uri[end] == '@') {
    const std::string_view user = uri.substr(authority, end - authority);
    const size_t colon = user.find(':');
    out += user.substr(0, colon);
    if (colon != std::string_view::npos) removed = true;
    rest = end;
  }
  const size_t question = uri.find('?', rest);
  out += uri.substr(rest, question == std::string_view::npos ? question : question - rest);
  if (question == std::string_view::npos) return out;
  std::string query;
  std::string_view params = uri.substr(question + 1);
  while (!params.empty()) {
    const size_t amp = params.find('&');
    const std::string_view param = params.substr(0, amp);
    params = amp == std::string_view::npos ? std::string_view() : params.substr(amp + 1);
    if (SecretKey(param.substr(0, param.find('=')))) {
      removed = true;
      continue;
    }
    if (param.empty()) continue;
    query += (query.empty() ? "" : "&") + std::string(param);
  }
  if (!query.empty()) out += "?" + query;
  return out;
}

// host=db password='a b' dbname=x → host=db dbname=x, by libpq's key/value rules (a value
// is a word or a '…' string, backslash escapes the next character).
std::string RedactKeyValue(std::string_view text, bool& removed) {
  std::string out;
  size_t k = 0;
  auto space = [&] {
    while (k < text.size() && std::isspace(static_cast<unsigned char>(text[k]))) ++k;
  };
  for (space(); k < text.size(); space()) {
    const size_t start = k;
    while (k < text.size() && text[k] != '=' && !std::isspace(static_cast<unsigned char>(text[k])))
      ++k;
    const std::string_view key = text.substr(start, k - start);
    space();
    if (k >= text.size() || text[k] != '=') {  // malformed: libpq refuses it; show no more
      out += (out.empty() ? "" : " ") + std::string("…");
      removed |= SecretKey(key);
      return out;
    }
    ++k;
    space();
    if (k < text.size() && text[k] == '\'') {
      for (++k; k < text.size() && text[k] != '\''; ++k) {
        if (text[k] == '\\') ++k;
      }
      ++k;
    } else {
      for (; k < text.size() && !std::isspace(static_cast<unsigned char>(text[k])); ++k) {
        if (text[k] == '\\') ++k;
      }
    }
    k = std::min(k, text.size());
    if (SecretKey(key)) {
      removed = true;
      continue;
    }
    out += (out.empty() ? "" : " ") + std::string(text.substr(start, k - start));
  }
  return out;
}

struct OptionsDeleter {
  void operator()(PQconninfoOption* o) const { PQconninfoFree(o); }
};
using Options = std::unique_ptr<PQconninfoOption, OptionsDeleter>;

// libpq's reading of `address`, or nullptr with `why` set.
Options Parse(std::string_view address, std::string* why) {
  char* error = nullptr;
  Options options(PQconninfoParse(std::string(address).c_str(), &error));
  if (!options && why) {
    *why = error ? error : "out of memory";
    while (!why->empty() && (why->back() == '\n' || why->back() == ' ')) why->pop_back();
  }
  if (error) PQfreemem(error);
  return options;
}

// Whether libpq reads a secret (a parameter it marks with display character '*') from it.
bool SetsSecret(const PQconninfoOption* options) {
  for (const PQconninfoOption* o = options; o->keyword; ++o) {
    if (o->val && *o->val && o->dispchar && o->dispchar[0] == '*') return true;
  }
  return false;
}

std::string Redact(std::string_view address, bool& removed) {
  removed = false;
  if (!IsPostgresAddress(address)) return std::string(address);
  std::string out = IsUri(address) ? RedactUri(address, removed) : RedactKeyValue(address, removed);
  // What libpq itself reads from the result must hold no secret; else (a spelling the
  // text rules above do not know) the parameters libpq read, secrets left out.
  const Options redacted = Parse(out, nullptr);
  if (!redacted || !SetsSecret(redacted.get())) return out;
  removed = true;
  const Options parsed = Parse(address, nullptr);
  std::string canonical;
  for (const PQconninfoOption* o = parsed.get(); o && o->keyword; ++o) {
    if (!o->val || !*o->val || (o->dispchar && o->dispchar[0] == '*')) continue;
    canonical += (canonical.empty() ? "" : " ") + std::string(o->keyword) + "='" + o->val + "'";
  }
  return canonical;
}

[[noreturn]] void Refuse(std::string_view option, const std::string& message) {
  throw InputError({std::string(option), 0, 0, ""}, message);
}

}  // namespace

bool IsPostgresAddress(std::string_view text) { return IsUri(text) || IsKeyValue(text); }

std::string RedactedAddress(std::string_view address) {
  bool removed = false;
  return Redact(address, removed);
}

std::string StoreName(std::string_view location) { return RedactedAddress(location); }

void CheckStoreAddress(std::string_view location, std::string_view option) {
  if (!IsPostgresAddress(location)) {
    const auto scheme = SchemeOf(location);
    const bool postgres_like = scheme && (*scheme == "postgresql" || *scheme == "postgres");
    if (scheme && (postgres_like || location.substr(scheme->size(), 3) == "://")) {
      Refuse(option, "not a store address: " + RedactedAddress(location) +
                         " (expected an SQLite file, a postgresql://[user@]host[:port]/database "
                         "URI or a libpq key/value string such as 'host=HOST dbname=DB'; a file "
                         "of this name is given as ./" +
                         std::string(location.substr(0, location.find(':'))) + ":…)");
    }
    return;
  }
  bool removed = false;
  const std::string name = Redact(location, removed);
  if (removed) {
    Refuse(option,
           "the database address carries a password; armsig takes credentials only from "
           "where libpq looks for them (PGPASSWORD, ~/.pgpass, a service file), so none stands "
           "on a command line or in a log: " +
               name);
  }
  const bool uri = IsUri(location);
  std::string why;
  const Options options = Parse(location, &why);
  if (!options) {
    Refuse(option, uri ? "not a PostgreSQL connection URI (postgresql://[user@]host[:port]/"
                         "database[?param=value…]): " +
                             name + ": " + why
                       : "not a PostgreSQL connection string (key=value pairs such as 'host=HOST "
                         "dbname=DB'; an SQLite file whose name begins with 'word=' is given as "
                         "./word=…): " +
                             name + ": " + why);
  }
  if (SetsSecret(options.get())) {
    Refuse(option,
           "the database address carries a password (libpq reads one from it); "
           "armsig takes credentials only from PGPASSWORD, ~/.pgpass or a service "
           "file: " +
               name);
  }
  // Values libpq checks only as it connects, checked here too: a port that is no number.
  for (const PQconninfoOption* o = options.get(); o->keyword; ++o) {
    if (!o->val || std::string_view(o->keyword) != "port") continue;
    for (const char* c = o->val; *c; ++c) {
      if ((*c < '0' || *c > '9') && *c != ',') {
        Refuse(option, "not a usable PostgreSQL connection " + std::string(uri ? "URI" : "string") +
                           ": " + name + ": the port '" + o->val + "' is not a number");
      }
    }
  }
}

}  // namespace armsig::db
