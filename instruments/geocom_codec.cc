#include "instruments/geocom_codec.h"

#include <charconv>
#include <cmath>
#include <cstdio>
#include <map>

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
};

std::optional<Header> ParseHeader(std::string_view line, std::string_view prefix,
                                  int with_trid_fields) {
  const size_t start = line.find(prefix);
  if (start == std::string_view::npos) return std::nullopt;
  line = line.substr(start);
  const size_t colon = line.find(':');
  if (colon == std::string_view::npos) return Header{{-1}, {}, false, false};
  Header h;
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
  for (auto part : parts) {
    auto v = ToInt(part);
    if (!v) return Header{{-1}, {}, false, false};
    h.fields.push_back(*v);
  }
  // fields: first (rpc or rc_com), [trid], [crc]
  if (static_cast<int>(h.fields.size()) > with_trid_fields + 1)
    return Header{{-1}, {}, false, false};
  if (static_cast<int>(h.fields.size()) == with_trid_fields + 1) {
    h.had_crc = true;
    const int crc = h.fields.back();
    h.fields.pop_back();
    std::string without = std::string(prefix) + std::to_string(h.fields[0]) + "," +
                          std::to_string(h.fields[1]) + ":" + std::string(h.body);
    h.crc_ok = Crc16Arc(without) == crc;
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
};

Frame ParseFrame(std::string_view line, std::string_view prefix) {
  while (!line.empty() && (line.back() == '\r' || line.back() == '\n' || line.back() == ' ')) {
    line.remove_suffix(1);
  }
  Frame f;
  auto h = ParseHeader(line, prefix, 2);
  if (!h) {
    f.error = ParseError::kNotAFrame;
  } else if (h->fields.empty() || h->fields[0] < 0) {
    f.error = ParseError::kMalformed;
  } else {
    f.had_crc = h->had_crc;
    if (!h->crc_ok)
      f.error = ParseError::kBadCrc;
    else
      f.header = std::move(h);
  }
  return f;
}

}  // namespace

ParsedReply ParseReply(std::string_view line) {
  ParsedReply out;
  Frame f = ParseFrame(line, "%R1P,");
  out.had_crc = f.had_crc;
  out.error = f.error;
  if (f.error) return out;
  const Header& h = *f.header;
  Reply r;
  r.rc_com = h.fields[0];
  r.trid = h.fields.size() > 1 ? h.fields[1] : 0;
  auto values = SplitValues(h.body);
  if (values.empty()) {
    // A communication error may carry no RPC return code.
    if (r.rc_com == 0) {
      out.error = ParseError::kMalformed;
      return out;
    }
  } else {
    auto rc = ToInt(values.front());
    if (!rc) {
      out.error = ParseError::kMalformed;
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
      {0, {"GRC_OK", "ok"}},
      {1, {"GRC_UNDEFINED", "unknown error"}},
      {2, {"GRC_IVPARAM", "invalid parameter"}},
      {4, {"GRC_FATAL", "fatal error"}},
      {5, {"GRC_NOT_IMPL", "not implemented on this instrument"}},
      {6, {"GRC_TIME_OUT", "function timed out on the instrument"}},
      {8, {"GRC_ABORT", "aborted"}},
      {12, {"GRC_SHUT_DOWN", "instrument is shutting down"}},
      {13, {"GRC_SYSBUSY", "system busy: retry"}},
      {16, {"GRC_LOW_POWER", "battery low"}},
      {18, {"GRC_BATT_EMPTY", "battery empty"}},
      {22, {"GRC_INSTRUMENT_TILT", "instrument tilted beyond the compensator range"}},
      {26, {"GRC_NOTOK", "not ok"}},
      {27, {"GRC_NA", "not available"}},
      {770, {"EDM_NOSIGNAL", "no EDM signal"}},
      {775, {"EDM_TIMEOUT", "EDM timeout: signal too weak or beam interrupted"}},
      {786, {"EDM_BUSY", "EDM busy: retry"}},
      {1283, {"TMC_NO_FULL_CORRECTION", "data valid, not all corrections applied"}},
      {1284, {"TMC_ACCURACY_GUARANTEE", "data valid, accuracy not guaranteed"}},
      {1285, {"TMC_ANGLE_OK", "angles valid, no distance"}},
      {1288, {"TMC_ANGLE_NO_FULL_CORRECTION", "angles only, not fully corrected"}},
      {1289, {"TMC_ANGLE_ACCURACY_GUARANTEE", "angles only, accuracy not guaranteed"}},
      {1290, {"TMC_ANGLE_ERROR", "no angle measurement"}},
      {1291, {"TMC_DIST_PPM", "wrong PPM/MM setting"}},
      {1292, {"TMC_DIST_ERROR", "distance not measured (no target)"}},
      {1293, {"TMC_BUSY", "measurement busy: retry"}},
      {1294, {"TMC_SIGNAL_ERROR", "signal error"}},
      {1793, {"MOT_BUSY", "motorisation busy: retry"}},
      {1806, {"MOT_TIMEOUT", "motorisation timeout"}},
      {3073, {"COM_CANT_ENCODE", "cannot encode"}},
      {3074, {"COM_CANT_DECODE", "cannot decode the reply"}},
      {3075, {"COM_CANT_SEND", "cannot send"}},
      {3076, {"COM_CANT_RECV", "cannot receive"}},
      {3077, {"COM_TIMEDOUT", "no reply in time"}},
      {3078, {"COM_WRONG_FORMAT", "wrong format"}},
      {3080, {"COM_CANT_DECODE_REQ", "instrument cannot decode the request"}},
      {3081, {"COM_PROC_UNAVAIL", "RPC not available on this instrument"}},
      {3085, {"COM_FAILED", "communication failed"}},
      {3093, {"COM_TR_ID_MISMATCH", "transaction id mismatch"}},
      {3094, {"COM_NOT_GEOCOM", "not a GeoCOM reply"}},
      {3101, {"COM_SRVR_RX_CHECKSUM_ERROR", "instrument received a bad checksum"}},
      {3102, {"COM_CLNT_RX_CHECKSUM_ERROR", "reply had a bad checksum"}},
      {3107, {"COM_CONS_REQ", "request sent before the previous reply: retry"}},
      {3108, {"COM_SRVR_IS_SLEEPING", "instrument asleep: retry"}},
      {3109, {"COM_SRVR_IS_OFF", "instrument is off"}},
      {3110, {"COM_NO_CHECKSUM", "no checksum in ASCII protocol"}},
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
    case 0:
      return CodeClass::kOk;
    case 1283:
    case 1284:
      return CodeClass::kWarningDataValid;
    case 1285:
    case 1288:
    case 1289:
      return CodeClass::kAnglesOnly;
    case 13:
    case 786:
    case 1293:
    case 1793:
    case 3107:
    case 3108:
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
