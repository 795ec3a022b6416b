#include "instruments/geocom_codec.h"

#include <charconv>
#include <cmath>
#include <cstdio>
#include <map>
#include <span>

#include "core/text.h"

namespace armsig::instruments::geocom {

uint16_t Crc16Arc(std::string_view data) {
  uint16_t crc = 0;
  for (unsigned char byte : data) {
    crc ^= byte;
    for (int bit = 0; bit < 8; ++bit)
      crc =
          (crc & 1) ? static_cast<uint16_t>((crc >> 1) ^ 0xA001) : static_cast<uint16_t>(crc >> 1);
  }
  return crc;
}

namespace {

std::string Join(const std::vector<std::string>& items) {
  std::string out;
  for (size_t i = 0; i < items.size(); ++i) {
    if (i) out += ',';
    out += items[i];
  }
  return out;
}

std::optional<int> ToInt(std::string_view s) {
  int v = 0;
  if (s.empty()) return std::nullopt;
  auto [p, ec] = std::from_chars(s.data(), s.data() + s.size(), v);
  if (ec != std::errc() || p != s.data() + s.size()) return std::nullopt;
  return v;
}

// Splits "a,b,c" honouring double-quoted strings (with \" escapes).
std::vector<std::string> SplitValues(std::string_view s) {
  std::vector<std::string> out;
  if (s.empty()) return out;
  std::string current;
  bool quoted = false;
  for (size_t i = 0; i < s.size(); ++i) {
    const char c = s[i];
    if (quoted && c == '\\' && i + 1 < s.size()) {
      current += c;
      current += s[++i];
      continue;
    }
    if (c == '"') quoted = !quoted;
    if (c == ',' && !quoted) {
      out.push_back(current);
      current.clear();
      continue;
    }
    current += c;
  }
  out.push_back(current);
  return out;
}

// Header "<prefix>a[,b[,c]]" before ':' → fields, plus the CRC check.
struct Header {
  std::vector<int> fields;
  std::string_view body;
  bool had_crc = false;
  bool crc_ok = true;
  std::string why;  // non-empty: malformed
};

std::optional<Header> ParseHeader(std::string_view line, std::string_view prefix,
                                  int with_trid_fields) {
  // The last frame start: what comes before it is noise or a frame cut short (a '%'
  // never appears unescaped inside a frame, strings escape it as \%).
  const size_t start = line.rfind(prefix);
  if (start == std::string_view::npos) return std::nullopt;
  line = line.substr(start);
  Header h;
  const size_t colon = line.find(':');
  if (colon == std::string_view::npos) {
    h.why = "expected ':' after the header " + Quoted(std::string(line));
    return h;
  }
  h.body = line.substr(colon + 1);
  std::string_view head = line.substr(prefix.size(), colon - prefix.size());
  std::vector<std::string_view> parts;
  size_t pos = 0;
  while (true) {
    const size_t comma = head.find(',', pos);
    parts.push_back(
        head.substr(pos, comma == std::string_view::npos ? std::string_view::npos : comma - pos));
    if (comma == std::string_view::npos) break;
    pos = comma + 1;
  }
  static constexpr const char* kFieldNames[] = {"first field (RPC or RC_COM)", "transaction id",
                                                "CRC"};
  if (static_cast<int>(parts.size()) > with_trid_fields + 1) {
    h.why = "expected at most " + std::to_string(with_trid_fields + 1) +
            " header fields before ':', got " + std::to_string(parts.size());
    return h;
  }
  for (size_t i = 0; i < parts.size(); ++i) {
    auto v = ToInt(parts[i]);
    if (!v || (i == 0 && *v < 0)) {  // an overflowed transaction id may be negative
      h.why = std::string("header ") + kFieldNames[i] + ": expected " +
              (i == 0 ? "a non-negative integer" : "an integer") + ", got " +
              Quoted(std::string(parts[i]));
      return h;
    }
    h.fields.push_back(*v);
  }
  // fields: first (rpc or rc_com), [trid], [crc]
  if (static_cast<int>(h.fields.size()) == with_trid_fields + 1) {
    h.had_crc = true;
    const int crc = h.fields.back();
    h.fields.pop_back();
    std::string without = std::string(prefix) + std::to_string(h.fields[0]) + "," +
                          std::to_string(h.fields[1]) + ":" + std::string(h.body);
    const uint16_t expected = Crc16Arc(without);
    h.crc_ok = expected == crc;
    if (!h.crc_ok)
      h.why = "CRC " + std::to_string(crc) + " does not match the frame (expected " +
              std::to_string(expected) + ")";
  }
  return h;
}

}  // namespace

std::string EncodeRequest(const Request& request, bool with_crc) {
  std::string frame = "%R1Q," + std::to_string(request.rpc);
  const int trid = request.trid.value_or(0);
  if (request.trid || with_crc) frame += "," + std::to_string(trid);
  const std::string body = ":" + Join(request.params);
  if (with_crc) {
    const uint16_t crc = Crc16Arc(frame + body);
    frame += "," + std::to_string(crc);
  }
  return "\n" + frame + body + "\r\n";
}

std::string EncodeReply(const Reply& reply, bool with_crc) {
  std::string frame = "%R1P," + std::to_string(reply.rc_com) + "," + std::to_string(reply.trid);
  std::string body = ":" + std::to_string(reply.rc);
  for (const auto& v : reply.values) body += "," + v;
  if (with_crc) frame += "," + std::to_string(Crc16Arc(frame + body));
  return frame + body + "\r\n";
}

namespace {

// Terminator stripped, frame found, header fields and CRC checked.
struct Frame {
  std::optional<Header> header;
  std::optional<ParseError> error;
  bool had_crc = false;
  std::string why;
};

Frame ParseFrame(std::string_view line, std::string_view prefix) {
  while (!line.empty() && (line.back() == '\r' || line.back() == '\n' || line.back() == ' ')) {
    line.remove_suffix(1);
  }
  Frame f;
  auto h = ParseHeader(line, prefix, 2);
  if (!h) {
    f.error = ParseError::kNotAFrame;
    f.why = "expected a frame starting with " + Quoted(std::string(prefix));
  } else if (h->fields.empty() || (!h->why.empty() && h->crc_ok)) {
    f.error = ParseError::kMalformed;
    f.why = h->why.empty() ? "expected a header before ':'" : h->why;
  } else {
    f.had_crc = h->had_crc;
    if (!h->crc_ok) {
      f.error = ParseError::kBadCrc;
      f.why = h->why;
    } else {
      f.header = std::move(h);
    }
  }
  return f;
}

}  // namespace

ParsedReply ParseReply(std::string_view line, bool require_crc) {
  ParsedReply out;
  Frame f = ParseFrame(line, "%R1P,");
  out.had_crc = f.had_crc;
  out.error = f.error;
  out.why = f.why;
  if (f.error) return out;
  if (require_crc && !f.had_crc) {
    out.error = ParseError::kMissingCrc;
    out.why =
        "expected a CRC field after the transaction id (%R1P,<rc_com>,<trid>,<crc>:), "
        "got a reply without one";
    return out;
  }
  const Header& h = *f.header;
  Reply r;
  r.rc_com = h.fields[0];
  r.trid = h.fields.size() > 1 ? h.fields[1] : 0;
  auto values = SplitValues(h.body);
  if (values.empty()) {
    // A communication error may carry no RPC return code.
    if (r.rc_com == 0) {
      out.error = ParseError::kMalformed;
      out.why = "expected the RPC return code after ':'";
      return out;
    }
  } else {
    auto rc = ToInt(values.front());
    if (!rc) {
      out.error = ParseError::kMalformed;
      out.why = "RPC return code: expected an integer, got " + Quoted(values.front());
      return out;
    }
    r.rc = *rc;
    values.erase(values.begin());
  }
  r.values = std::move(values);
  out.reply = std::move(r);
  return out;
}

ParsedRequest ParseRequest(std::string_view line) {
  ParsedRequest out;
  Frame f = ParseFrame(line, "%R1Q,");
  out.had_crc = f.had_crc;
  out.error = f.error;
  out.why = f.why;
  if (f.error) return out;
  Request r;
  r.rpc = f.header->fields[0];
  if (f.header->fields.size() > 1) r.trid = f.header->fields[1];
  r.params = SplitValues(f.header->body);
  out.request = std::move(r);
  return out;
}

std::string EncodeDouble(double value, int digits) {
  char buffer[64];
  std::snprintf(buffer, sizeof buffer, "%.*f", digits, value);
  return buffer;
}

std::string EncodeString(std::string_view text) {
  std::string out = "\"";
  for (unsigned char c : text) {
    if (c == '"' || c == '\\' || c == '%' || c == '~') {
      out += '\\';
      out += static_cast<char>(c);
    } else if (c < 0x20 || c > 0x7E) {
      char buffer[8];
      std::snprintf(buffer, sizeof buffer, "\\x%02X", c);
      out += buffer;
    } else {
      out += static_cast<char>(c);
    }
  }
  return out + "\"";
}

std::string EncodeLong(long value) { return std::to_string(value); }

namespace {

// values[index] decoded by `decode`, or `why` naming the RPC, the value and the type.
template <typename T, typename Decode>
std::optional<T> ValueAt(const std::vector<std::string>& values, size_t index, std::string_view rpc,
                         std::string_view name, std::string_view type, Decode decode,
                         std::string* why) {
  if (index >= values.size()) {
    if (why)
      *why = std::string(rpc) + ": reply has " + std::to_string(values.size()) +
             " values, expected " + std::string(name) + " as value " + std::to_string(index + 1);
    return std::nullopt;
  }
  std::optional<T> v = decode(values[index]);
  if (!v && why)
    *why = std::string(rpc) + ": value " + std::to_string(index + 1) + " (" + std::string(name) +
           "): expected " + std::string(type) + ", got " + Quoted(values[index]);
  return v;
}

std::optional<double> DoubleAt(const std::vector<std::string>& values, size_t index,
                               std::string_view rpc, std::string_view name, std::string* why) {
  return ValueAt<double>(values, index, rpc, name, "a number", DecodeDouble, why);
}

std::optional<long> LongAt(const std::vector<std::string>& values, size_t index,
                           std::string_view rpc, std::string_view name, std::string* why) {
  return ValueAt<long>(values, index, rpc, name, "an integer", DecodeLong, why);
}

constexpr int kAngleDigits = 15;
constexpr int kDistanceDigits = 6;  // µm

// One value of a typed reply: its name in the GeoCOM manual and the member it fills, a
// double (encoded with `digits` decimals) or a long.
template <typename T>
struct Field {
  std::string_view name;
  double T::*real = nullptr;
  long T::*integer = nullptr;
  int digits = kAngleDigits;
  constexpr Field(std::string_view n, double T::*m, int d = kAngleDigits)
      : name(n), real(m), digits(d) {}
  constexpr Field(std::string_view n, long T::*m) : name(n), integer(m) {}
};

template <typename T>
std::vector<std::string> EncodeFields(const T& in, std::span<const Field<T>> fields) {
  std::vector<std::string> out;
  out.reserve(fields.size());
  for (const Field<T>& f : fields)
    out.push_back(f.real ? EncodeDouble(in.*f.real, f.digits) : EncodeLong(in.*f.integer));
  return out;
}

// Decodes values[0…fields) into `out` in order; nullopt (with `why` naming the RPC, the
// value and what was expected) at the first value missing or malformed.
template <typename T>
std::optional<T> DecodeFields(const std::vector<std::string>& values, std::string_view rpc,
                              std::span<const Field<T>> fields, std::string* why) {
  T out{};
  for (size_t i = 0; i < fields.size(); ++i) {
    const Field<T>& f = fields[i];
    if (f.real) {
      const auto v = DoubleAt(values, i, rpc, f.name, why);
      if (!v) return std::nullopt;
      out.*f.real = *v;
    } else {
      const auto v = LongAt(values, i, rpc, f.name, why);
      if (!v) return std::nullopt;
      out.*f.integer = *v;
    }
  }
  return out;
}

// The reply layouts (GeoCOM Reference Manual TPS1200+ v1.50, the RPCs' "Out" parameters).
constexpr Field<AngleComplete> kAngleComplete[] = {
    {"Hz", &AngleComplete::hz_rad},
    {"V", &AngleComplete::v_rad},
    {"AngleAccuracy", &AngleComplete::angle_accuracy_rad},
    {"AngleTime", &AngleComplete::angle_time_ms},
    {"CrossIncline", &AngleComplete::cross_incline_rad},
    {"LengthIncline", &AngleComplete::length_incline_rad},
    {"InclineAccuracy", &AngleComplete::incline_accuracy_rad},
    {"InclineTime", &AngleComplete::incline_time_ms},
    {"Face", &AngleComplete::face},
};
constexpr Field<AngleSimple> kAngleSimple[] = {{"Hz", &AngleSimple::hz_rad},
                                               {"V", &AngleSimple::v_rad}};
// The angles; the slope distance, optional, is read after them.
constexpr Field<SimpleMeasurement> kSimpleMeasurementAngles[] = {{"Hz", &SimpleMeasurement::hz_rad},
                                                                 {"V", &SimpleMeasurement::v_rad}};
constexpr Field<DistanceAngle> kDistanceAngle[] = {
    {"Hz", &DistanceAngle::hz_rad},
    {"V", &DistanceAngle::v_rad},
    {"SlopeDistance", &DistanceAngle::slope_distance_m, kDistanceDigits},
    {"DistMode", &DistanceAngle::dist_mode},
};
constexpr Field<Version> kVersion[] = {{"Release", &Version::release},
                                       {"Version", &Version::version},
                                       {"Subversion", &Version::subversion}};

}  // namespace

std::vector<std::string> EncodeValues(const AngleComplete& a) {
  return EncodeFields<AngleComplete>(a, kAngleComplete);
}

std::optional<AngleComplete> DecodeAngleComplete(const std::vector<std::string>& v,
                                                 std::string* why) {
  auto a = DecodeFields<AngleComplete>(v, "TMC_GetAngle1", kAngleComplete, why);
  if (a && a->face != 0 && a->face != 1) {
    if (why) *why = "TMC_GetAngle1: value 9 (Face): expected 0 or 1, got " + Quoted(v[8]);
    return std::nullopt;
  }
  return a;
}

std::vector<std::string> EncodeValues(const AngleSimple& a) {
  return EncodeFields<AngleSimple>(a, kAngleSimple);
}

std::optional<AngleSimple> DecodeAngleSimple(const std::vector<std::string>& v, std::string* why) {
  return DecodeFields<AngleSimple>(v, "TMC_GetAngle5", kAngleSimple, why);
}

std::vector<std::string> EncodeValues(const SimpleMeasurement& m) {
  auto out = EncodeFields<SimpleMeasurement>(m, kSimpleMeasurementAngles);
  if (m.slope_distance_m) out.push_back(EncodeDouble(*m.slope_distance_m, kDistanceDigits));
  return out;
}

std::optional<SimpleMeasurement> DecodeSimpleMeasurement(const std::vector<std::string>& v,
                                                         std::string* why) {
  constexpr std::string_view rpc = "TMC_GetSimpleMea";
  auto m = DecodeFields<SimpleMeasurement>(v, rpc, kSimpleMeasurementAngles, why);
  if (m && v.size() > 2) {
    m->slope_distance_m = DoubleAt(v, 2, rpc, "SlopeDistance", why);
    if (!m->slope_distance_m) return std::nullopt;
  }
  return m;
}

std::vector<std::string> EncodeValues(const DistanceAngle& d) {
  return EncodeFields<DistanceAngle>(d, kDistanceAngle);
}

std::optional<DistanceAngle> DecodeDistanceAngle(const std::vector<std::string>& v,
                                                 std::string* why) {
  return DecodeFields<DistanceAngle>(v, "BAP_MeasDistanceAngle", kDistanceAngle, why);
}

std::vector<std::string> EncodeValues(const Version& v) {
  return EncodeFields<Version>(v, kVersion);
}

std::optional<Version> DecodeVersion(const std::vector<std::string>& v, std::string* why) {
  return DecodeFields<Version>(v, "GetSWVersion", kVersion, why);
}

std::optional<std::string> DecodeStringValue(const std::vector<std::string>& values,
                                             std::string_view what, std::string* why) {
  return ValueAt<std::string>(values, 0, what, "value", "a quoted string", DecodeString, why);
}

std::optional<long> DecodeLongValue(const std::vector<std::string>& values, std::string_view what,
                                    std::string* why) {
  return LongAt(values, 0, what, "value", why);
}

std::optional<double> DecodeDouble(std::string_view text) {
  double v = 0;
  if (text.empty()) return std::nullopt;
  if (text.front() == '+') text.remove_prefix(1);
  auto [p, ec] = std::from_chars(text.data(), text.data() + text.size(), v);
  if (ec != std::errc() || p != text.data() + text.size() || !std::isfinite(v)) return std::nullopt;
  return v;
}

std::optional<long> DecodeLong(std::string_view text) {
  long v = 0;
  int base = 10;
  if (text.size() > 2 && text[0] == '0' && (text[1] == 'x' || text[1] == 'X')) {
    text.remove_prefix(2);
    base = 16;
  }
  if (text.empty()) return std::nullopt;
  auto [p, ec] = std::from_chars(text.data(), text.data() + text.size(), v, base);
  if (ec != std::errc() || p != text.data() + text.size()) return std::nullopt;
  return v;
}

std::optional<std::string> DecodeString(std::string_view text) {
  if (text.size() < 2 || text.front() != '"' || text.back() != '"') return std::nullopt;
  text = text.substr(1, text.size() - 2);
  std::string out;
  for (size_t i = 0; i < text.size(); ++i) {
    if (text[i] != '\\') {
      out += text[i];
      continue;
    }
    if (++i >= text.size()) return std::nullopt;
    if (text[i] == 'x') {
      if (i + 2 >= text.size()) return std::nullopt;
      unsigned value = 0;
      auto [p, ec] = std::from_chars(text.data() + i + 1, text.data() + i + 3, value, 16);
      if (ec != std::errc() || p != text.data() + i + 3) return std::nullopt;
      out += static_cast<char>(value);
      i += 2;
    } else {
      out += text[i];
    }
  }
  return out;
}

std::optional<int> DecodeByte(std::string_view text) {
  if (text.size() != 4 || text.front() != '\'' || text.back() != '\'') return std::nullopt;
  int v = 0;
  auto [p, ec] = std::from_chars(text.data() + 1, text.data() + 3, v, 16);
  if (ec != std::errc() || p != text.data() + 3) return std::nullopt;
  return v;
}

namespace {

struct CodeInfo {
  const char* name;
  const char* meaning;
};

const std::map<int, CodeInfo>& Codes() {
  static const std::map<int, CodeInfo> codes = {
      {grc::kOk, {"GRC_OK", "ok"}},
      {1, {"GRC_UNDEFINED", "unknown error"}},
      {grc::kIvParam, {"GRC_IVPARAM", "invalid parameter"}},
      {4, {"GRC_FATAL", "fatal error"}},
      {5, {"GRC_NOT_IMPL", "not implemented on this instrument"}},
      {6, {"GRC_TIME_OUT", "function timed out on the instrument"}},
      {8, {"GRC_ABORT", "aborted"}},
      {12, {"GRC_SHUT_DOWN", "instrument is shutting down"}},
      {grc::kSysBusy, {"GRC_SYSBUSY", "system busy: retry"}},
      {16, {"GRC_LOW_POWER", "battery low"}},
      {18, {"GRC_BATT_EMPTY", "battery empty"}},
      {22, {"GRC_INSTRUMENT_TILT", "instrument tilted beyond the compensator range"}},
      {26, {"GRC_NOTOK", "not ok"}},
      {27, {"GRC_NA", "not available"}},
      {770, {"EDM_NOSIGNAL", "no EDM signal"}},
      {775, {"EDM_TIMEOUT", "EDM timeout: signal too weak or beam interrupted"}},
      {grc::kEdmBusy, {"EDM_BUSY", "EDM busy: retry"}},
      {grc::kTmcNoFullCorrection,
       {"TMC_NO_FULL_CORRECTION", "data valid, not all corrections applied"}},
      {grc::kTmcAccuracyGuarantee,
       {"TMC_ACCURACY_GUARANTEE", "data valid, accuracy not guaranteed"}},
      {grc::kTmcAngleOk, {"TMC_ANGLE_OK", "angles valid, no distance"}},
      {grc::kTmcAngleNoFullCorrection,
       {"TMC_ANGLE_NO_FULL_CORRECTION", "angles only, not fully corrected"}},
      {grc::kTmcAngleAccuracyGuarantee,
       {"TMC_ANGLE_ACCURACY_GUARANTEE", "angles only, accuracy not guaranteed"}},
      {1290, {"TMC_ANGLE_ERROR", "no angle measurement"}},
      {1291, {"TMC_DIST_PPM", "wrong PPM/MM setting"}},
      {grc::kTmcDistError, {"TMC_DIST_ERROR", "distance not measured (no target)"}},
      {grc::kTmcBusy, {"TMC_BUSY", "measurement busy: retry"}},
      {1294, {"TMC_SIGNAL_ERROR", "signal error"}},
      {grc::kMotBusy, {"MOT_BUSY", "motorisation busy: retry"}},
      {1806, {"MOT_TIMEOUT", "motorisation timeout"}},
      {3073, {"COM_CANT_ENCODE", "cannot encode"}},
      {grc::kComCantDecode, {"COM_CANT_DECODE", "cannot decode the reply"}},
      {3075, {"COM_CANT_SEND", "cannot send"}},
      {3076, {"COM_CANT_RECV", "cannot receive"}},
      {grc::kComTimedOut, {"COM_TIMEDOUT", "no reply in time"}},
      {3078, {"COM_WRONG_FORMAT", "wrong format"}},
      {grc::kComCantDecodeReq, {"COM_CANT_DECODE_REQ", "instrument cannot decode the request"}},
      {grc::kComProcUnavail, {"COM_PROC_UNAVAIL", "RPC not available on this instrument"}},
      {grc::kComFailed, {"COM_FAILED", "communication failed"}},
      {grc::kComTrIdMismatch, {"COM_TR_ID_MISMATCH", "transaction id mismatch"}},
      {3094, {"COM_NOT_GEOCOM", "not a GeoCOM reply"}},
      {grc::kComOverrun, {"COM_OVERRUN", "line longer than the maximum"}},
      {grc::kComSrvrRxChecksumError,
       {"COM_SRVR_RX_CHECKSUM_ERROR", "instrument received a bad checksum"}},
      {grc::kComClntRxChecksumError, {"COM_CLNT_RX_CHECKSUM_ERROR", "reply had a bad checksum"}},
      {grc::kComConsReq, {"COM_CONS_REQ", "request sent before the previous reply: retry"}},
      {grc::kComSrvrIsSleeping, {"COM_SRVR_IS_SLEEPING", "instrument asleep: retry"}},
      {3109, {"COM_SRVR_IS_OFF", "instrument is off"}},
      {grc::kComNoChecksum, {"COM_NO_CHECKSUM", "no checksum in ASCII protocol"}},
      {8704, {"AUT_TIMEOUT", "position not reached"}},
      {8706, {"AUT_ANGLE_ERROR", "angle error"}},
      {8707, {"AUT_MOTOR_ERROR", "motor error"}},
      {8708, {"AUT_INCACC", "position not exactly reached"}},
      {8710, {"AUT_NO_TARGET", "ATR found no target"}},
      {8711, {"AUT_MULTIPLE_TARGETS", "multiple targets"}},
      {8712, {"AUT_BAD_ENVIRONMENT", "bad environment"}},
      {8714, {"AUT_NOT_ENABLED", "ATR/lock not enabled"}},
      {8716, {"AUT_ACCURACY", "target position not exactly reached"}},
  };
  return codes;
}

}  // namespace

CodeClass Classify(int code) {
  switch (code) {
    case grc::kOk:
      return CodeClass::kOk;
    case grc::kTmcNoFullCorrection:
    case grc::kTmcAccuracyGuarantee:
      return CodeClass::kWarningDataValid;
    case grc::kTmcAngleOk:
    case grc::kTmcAngleNoFullCorrection:
    case grc::kTmcAngleAccuracyGuarantee:
      return CodeClass::kAnglesOnly;
    case grc::kSysBusy:
    case grc::kEdmBusy:
    case grc::kTmcBusy:
    case grc::kMotBusy:
    case grc::kComConsReq:
    case grc::kComSrvrIsSleeping:
      return CodeClass::kBusy;
    default:
      return CodeClass::kError;
  }
}

std::string CodeName(int code) {
  auto it = Codes().find(code);
  return it != Codes().end() ? it->second.name : "GRC_" + std::to_string(code);
}

std::string CodeMeaning(int code) {
  auto it = Codes().find(code);
  return it != Codes().end() ? it->second.meaning : "return code " + std::to_string(code);
}

}  // namespace armsig::instruments::geocom
