#include "robots/kuka_codec.h"

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <limits>
#include <stdexcept>

namespace armsig::robots::kuka {

namespace {

constexpr size_t kHeader = kHeaderBytes;

void PutU16(std::string& out, size_t value) {
  out.push_back(static_cast<char>((value >> 8) & 0xFF));
  out.push_back(static_cast<char>(value & 0xFF));
}

uint16_t GetU16(std::string_view bytes, size_t at) {
  return static_cast<uint16_t>((static_cast<uint8_t>(bytes[at]) << 8) |
                               static_cast<uint8_t>(bytes[at + 1]));
}

// The header of a frame: the length field must count exactly the bytes after it.
bool CheckHeader(std::string_view frame, size_t min_frame, std::string& why) {
  if (frame.size() < min_frame) {
    why = "a frame of " + std::to_string(frame.size()) + " bytes (at least " +
          std::to_string(min_frame) + " expected)";
    return false;
  }
  const size_t length = GetU16(frame, 2);
  if (length != frame.size() - kHeader) {
    why = "length field " + std::to_string(length) + " but " +
          std::to_string(frame.size() - kHeader) + " bytes follow the header";
    return false;
  }
  return true;
}

// A length-prefixed block at `at`: its text, and `at` moved past it.
std::optional<std::string> Block(std::string_view frame, size_t& at, const char* what,
                                 std::string& why) {
  if (at + 2 > frame.size()) {
    why = std::string("the frame ends before the ") + what + " length";
    return std::nullopt;
  }
  const size_t n = GetU16(frame, at);
  at += 2;
  if (at + n > frame.size()) {
    why = std::string(what) + " length " + std::to_string(n) + " runs past the frame's end (" +
          std::to_string(frame.size() - at) + " bytes left)";
    return std::nullopt;
  }
  std::string text(frame.substr(at, n));
  at += n;
  return text;
}

std::string_view Trim(std::string_view s) {
  while (!s.empty() && std::isspace(static_cast<unsigned char>(s.front()))) s.remove_prefix(1);
  while (!s.empty() && std::isspace(static_cast<unsigned char>(s.back()))) s.remove_suffix(1);
  return s;
}

std::string Upper(std::string_view s) {
  std::string out(s);
  for (char& c : out) c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
  return out;
}

bool IsNameChar(char c) {
  return std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '$';
}

}  // namespace

// --- Frames -----------------------------------------------------------------------------

std::string EncodeRequest(const Request& request) {
  if (request.name.empty()) throw std::invalid_argument("a variable server request needs a name");
  if (request.name.size() > kMaxNameBytes) {
    throw std::invalid_argument("variable name of " + std::to_string(request.name.size()) +
                                " bytes (at most " + std::to_string(kMaxNameBytes) + ")");
  }
  std::string body;
  body.push_back(static_cast<char>(request.type));
  PutU16(body, request.name.size());
  body += request.name;
  if (request.type == MessageType::kWrite) {
    PutU16(body, request.value.size());
    body += request.value;
  }
  if (kHeader + body.size() > static_cast<size_t>(kMaxFrameBytes)) {
    throw std::invalid_argument("a write of " + std::to_string(request.value.size()) +
                                " bytes does not fit one message");
  }
  std::string out;
  PutU16(out, request.tag);
  PutU16(out, body.size());
  return out + body;
}

std::string EncodeResponse(const Response& response) {
  std::string body;
  body.push_back(static_cast<char>(response.type));
  PutU16(body, response.value.size());
  body += response.value;
  PutU16(body, response.error_code);
  body.push_back(response.success ? 1 : 0);
  std::string out;
  PutU16(out, response.tag);
  PutU16(out, body.size());
  return out + body;
}

DecodedRequest DecodeRequest(std::string_view frame) {
  DecodedRequest out;
  if (!CheckHeader(frame, kMinRequestBytes, out.why)) return out;
  Request r;
  r.tag = GetU16(frame, 0);
  const auto type = static_cast<uint8_t>(frame[4]);
  if (type != 0 && type != 1) {
    out.why = "message type " + std::to_string(type) + " (0 read or 1 write expected)";
    return out;
  }
  r.type = static_cast<MessageType>(type);
  size_t at = 5;
  auto name = Block(frame, at, "variable name", out.why);
  if (!name) return out;
  if (name->empty()) {
    out.why = "an empty variable name";
    return out;
  }
  r.name = std::move(*name);
  if (r.type == MessageType::kWrite) {
    auto value = Block(frame, at, "value", out.why);
    if (!value) return out;
    r.value = std::move(*value);
  }
  if (at != frame.size()) {
    out.why = std::to_string(frame.size() - at) + " bytes after the " +
              (r.type == MessageType::kWrite ? "value" : "variable name");
    return out;
  }
  out.request = std::move(r);
  return out;
}

DecodedResponse DecodeResponse(std::string_view frame) {
  DecodedResponse out;
  if (!CheckHeader(frame, kMinResponseBytes, out.why)) return out;
  Response r;
  r.tag = GetU16(frame, 0);
  r.type = static_cast<uint8_t>(frame[4]);
  size_t at = 5;
  auto value = Block(frame, at, "value", out.why);
  if (!value) return out;
  if (frame.size() - at != 3) {
    out.why = "value length " + std::to_string(value->size()) + " leaves " +
              std::to_string(frame.size() - at) + " bytes for the 3-byte footer";
    return out;
  }
  r.value = std::move(*value);
  r.error_code = GetU16(frame, at);
  const auto flag = static_cast<uint8_t>(frame[at + 2]);
  r.success = flag != 0;  // C3 §1.5: any non-zero byte is TRUE
  out.response = std::move(r);
  return out;
}

// --- KRL value text ---------------------------------------------------------------------

std::optional<bool> ParseBool(std::string_view text) {
  const std::string t = Upper(Trim(text));
  if (t == "TRUE") return true;
  if (t == "FALSE") return false;
  return std::nullopt;
}

std::optional<int64_t> ParseInt(std::string_view text) {
  text = Trim(text);
  if (!text.empty() && text.front() == '+') text.remove_prefix(1);
  int64_t v = 0;
  const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), v);
  if (ec != std::errc() || end != text.data() + text.size() || text.empty()) return std::nullopt;
  if (v < std::numeric_limits<int32_t>::min() || v > std::numeric_limits<int32_t>::max())
    return std::nullopt;
  return v;
}

std::optional<double> ParseReal(std::string_view text) {
  text = Trim(text);
  if (text.empty() || text.size() > 64) return std::nullopt;
  // strtod on a bounded copy: it needs a terminator, and it reads "1.5E-05" as KRL writes it.
  // Only digits, signs, a point and an exponent: never "nan", "inf" or hexadecimal.
  for (char c : text) {
    if (!(std::isdigit(static_cast<unsigned char>(c)) || c == '-' || c == '+' || c == '.' ||
          c == 'e' || c == 'E'))
      return std::nullopt;
  }
  const std::string copy(text);
  char* end = nullptr;
  const double v = std::strtod(copy.c_str(), &end);
  if (end != copy.c_str() + copy.size() || !std::isfinite(v)) return std::nullopt;
  return v;
}

std::optional<std::string> ParseEnum(std::string_view text) {
  text = Trim(text);
  if (text.size() < 2 || text.front() != '#') return std::nullopt;
  text.remove_prefix(1);
  if (!std::all_of(text.begin(), text.end(), IsNameChar)) return std::nullopt;
  return Upper(text);
}

std::optional<std::string> ParseString(std::string_view text) {
  text = Trim(text);
  if (text.size() < 2 || text.front() != '"' || text.back() != '"') return std::nullopt;
  std::string_view inner = text.substr(1, text.size() - 2);
  while (!inner.empty() && (inner.back() == ' ' || inner.back() == '\0')) inner.remove_suffix(1);
  return std::string(inner);
}

const std::string* Structure::Find(std::string_view component) const {
  const std::string want = Upper(component);
  for (const auto& [name, value] : components)
    if (name == want) return &value;
  return nullptr;
}

std::optional<Structure> ParseStructure(std::string_view text, std::string* why) {
  auto fail = [&](std::string w) -> std::optional<Structure> {
    if (why) *why = std::move(w);
    return std::nullopt;
  };
  text = Trim(text);
  if (text.size() < 2 || text.front() != '{' || text.back() != '}')
    return fail("no structure: expected {…}, got '" + std::string(text.substr(0, 40)) + "'");
  std::string_view body = Trim(text.substr(1, text.size() - 2));
  Structure s;
  // "E6AXIS:" before the first component names the type.
  const size_t colon = body.find(':');
  if (colon != std::string_view::npos) {
    const std::string_view type = Trim(body.substr(0, colon));
    if (!type.empty() && std::all_of(type.begin(), type.end(), IsNameChar)) {
      s.type = Upper(type);
      body = Trim(body.substr(colon + 1));
    }
  }
  if (body.empty()) return fail("a structure without components");
  size_t at = 0;
  while (at <= body.size()) {
    // One component up to the next comma outside quotes and braces.
    size_t end = at;
    bool quoted = false;
    int depth = 0;
    for (; end < body.size(); ++end) {
      const char c = body[end];
      if (c == '"') quoted = !quoted;
      if (quoted) continue;
      if (c == '{') ++depth;
      if (c == '}') --depth;
      if (c == ',' && depth == 0) break;
    }
    if (quoted) return fail("an unterminated string in the structure");
    const std::string_view item = Trim(body.substr(at, end - at));
    size_t name_end = 0;
    while (name_end < item.size() && IsNameChar(item[name_end])) ++name_end;
    if (name_end == 0 || name_end == item.size() ||
        !std::isspace(static_cast<unsigned char>(item[name_end])))
      return fail("component '" + std::string(item.substr(0, 40)) +
                  "' is not 'NAME value'");
    std::string name = Upper(item.substr(0, name_end));
    if (s.Find(name)) return fail("component " + name + " given twice");
    s.components.emplace_back(std::move(name), std::string(Trim(item.substr(name_end))));
    if (s.components.size() > 64) return fail("more than 64 components");
    at = end + 1;
  }
  return s;
}

std::optional<Eigen::VectorXd> ParseAxes(std::string_view text, int axes, std::string* why) {
  auto fail = [&](std::string w) -> std::optional<Eigen::VectorXd> {
    if (why) *why = std::move(w);
    return std::nullopt;
  };
  if (axes < 1 || axes > 6) return fail("a KUKA robot has 1 to 6 axes, not " + std::to_string(axes));
  std::string w;
  const auto s = ParseStructure(text, &w);
  if (!s) return fail(w);
  if (!s->type.empty() && s->type != "E6AXIS" && s->type != "AXIS")
    return fail("a " + s->type + " where an E6AXIS or AXIS was expected");
  Eigen::VectorXd q(axes);
  for (int i = 0; i < axes; ++i) {
    const std::string name = "A" + std::to_string(i + 1);
    const std::string* value = s->Find(name);
    if (!value) return fail("no component " + name + " in '" + std::string(text.substr(0, 80)) + "'");
    const auto v = ParseReal(*value);
    if (!v) return fail(name + " is '" + value->substr(0, 40) + "', no number");
    q(i) = *v;
  }
  return q;
}

std::optional<Eigen::Matrix<double, 6, 1>> ParsePose(std::string_view text, std::string* why) {
  auto fail = [&](std::string w) -> std::optional<Eigen::Matrix<double, 6, 1>> {
    if (why) *why = std::move(w);
    return std::nullopt;
  };
  std::string w;
  const auto s = ParseStructure(text, &w);
  if (!s) return fail(w);
  if (!s->type.empty() && s->type != "E6POS" && s->type != "POS" && s->type != "FRAME")
    return fail("a " + s->type + " where an E6POS, POS or FRAME was expected");
  Eigen::Matrix<double, 6, 1> pose;
  const char* names[] = {"X", "Y", "Z", "A", "B", "C"};
  for (int i = 0; i < 6; ++i) {
    const std::string* value = s->Find(names[i]);
    if (!value) return fail(std::string("no component ") + names[i]);
    const auto v = ParseReal(*value);
    if (!v) return fail(std::string(names[i]) + " is '" + value->substr(0, 40) + "', no number");
    pose(i) = *v;
  }
  return pose;
}

std::string FormatReal(double value) {
  char buffer[40];
  std::snprintf(buffer, sizeof buffer, "%.9G", value);
  std::string s(buffer);
  if (s.find_first_of(".E") == std::string::npos) s += ".0";  // "-90" → "-90.0"
  return s;
}

std::string FormatBool(bool value) { return value ? "TRUE" : "FALSE"; }

std::string FormatAxes(const Eigen::VectorXd& axes_deg, std::string_view type) {
  std::string out = "{" + std::string(type) + ":";
  for (Eigen::Index i = 0; i < axes_deg.size(); ++i) {
    out += (i ? ", A" : " A") + std::to_string(i + 1) + " " + FormatReal(axes_deg(i));
  }
  return out + "}";
}

std::string FormatString(std::string_view text) { return "\"" + std::string(text) + "\""; }

// --- KRL declarations -------------------------------------------------------------------

std::vector<Declaration> ParseDeclarations(std::string_view text) {
  std::vector<Declaration> out;
  int line_no = 0;
  size_t at = 0;
  while (at < text.size()) {
    size_t end = text.find('\n', at);
    if (end == std::string_view::npos) end = text.size();
    std::string_view line = text.substr(at, end - at);
    at = end + 1;
    ++line_no;
    // A comment runs from ';' to the line's end (no string in a DECL line of ours holds one).
    const size_t semicolon = line.find(';');
    if (semicolon != std::string_view::npos) line = line.substr(0, semicolon);
    line = Trim(line);
    if (Upper(line.substr(0, 4)) != "DECL" ||
        (line.size() > 4 && !std::isspace(static_cast<unsigned char>(line[4]))))
      continue;  // not a declaration (DECLARE_X = 1 is an assignment)
    auto bad = [&](const std::string& what) {
      return std::invalid_argument("line " + std::to_string(line_no) + ": " + what + ": '" +
                                   std::string(line.substr(0, 80)) + "'");
    };
    std::string_view rest = Trim(line.substr(4));
    auto word = [&]() {
      size_t n = 0;
      while (n < rest.size() && IsNameChar(rest[n])) ++n;
      std::string w = Upper(rest.substr(0, n));
      rest = Trim(rest.substr(n));
      return w;
    };
    std::string type = word();
    while (type == "GLOBAL" || type == "CONST") type = word();
    if (type.empty()) throw bad("a DECL without a type");
    Declaration d;
    d.type = type;
    d.name = word();
    if (d.name.empty()) throw bad("a DECL without a variable name");
    if (!rest.empty() && rest.front() == '[') {  // an array: CHAR NAME[16]
      const size_t close = rest.find(']');
      if (close == std::string_view::npos) throw bad("an unclosed array bound");
      d.name += "[]";
      rest = Trim(rest.substr(close + 1));
    }
    if (!rest.empty()) {
      if (rest.front() != '=') throw bad("expected '=' or the line's end after the name");
      d.value = std::string(Trim(rest.substr(1)));
      if (d.value.empty()) throw bad("'=' without a value");
    }
    d.line = line_no;
    out.push_back(std::move(d));
  }
  return out;
}

// --- The contract -------------------------------------------------------------------------

namespace contract {
std::string ResultMeaning(int result) {
  switch (result) {
    case kReached:
      return "reached";
    case kBeyondSoftwareLimit:
      return "refused: an axis target beyond its software limit ($SOFTN_END / $SOFTP_END)";
    case kVelocityOutOfRange:
      return "refused: ARMSIG_VEL or ARMSIG_ACC outside 1 to 100 %";
    case kNotExecuted:
      return "not executed: ARMSIG started after the command was written";
    default:
      return "result " + std::to_string(result) + " (not one of ARMSIG's)";
  }
}
}  // namespace contract

}  // namespace armsig::robots::kuka
