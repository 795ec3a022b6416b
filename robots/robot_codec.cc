#include "robots/robot_codec.h"

#include <Eigen/LU>
#include <cctype>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <sstream>
#include <stdexcept>

#include "core/text.h"

namespace armsig::robots {

namespace {

std::vector<std::string> Tokens(std::string_view line) {
  std::vector<std::string> out;
  std::istringstream in{std::string(line)};
  for (std::string t; in >> t;) out.push_back(t);
  return out;
}

std::optional<double> Number(const std::string& t) {
  double v = 0;
  const char* b = t.data();
  if (!t.empty() && t[0] == '+') ++b;
  auto [p, ec] = std::from_chars(b, t.data() + t.size(), v);
  if (ec != std::errc() || p != t.data() + t.size() || !std::isfinite(v)) return std::nullopt;
  return v;
}

bool IsJointHeader(const std::string& t) {
  return t.rfind("JT", 0) == 0 || t.find("/JT") != std::string::npos;
}

}  // namespace

std::optional<WhereReadout> ParseWhere(std::string_view text, std::string* why) {
  std::vector<std::vector<std::string>> lines;
  size_t pos = 0;
  while (pos <= text.size()) {
    size_t end = text.find_first_of("\r\n", pos);
    if (end == std::string_view::npos) end = text.size();
    auto tokens = Tokens(text.substr(pos, end - pos));
    if (!tokens.empty()) lines.push_back(std::move(tokens));
    pos = end + 1;
  }
  WhereReadout out;
  bool have_joints = false;
  std::vector<std::vector<double>> numeric_rows;
  for (size_t i = 0; i + 1 < lines.size(); ++i) {
    const auto& header = lines[i];
    bool header_row = !header.empty() && !Number(header[0]);
    if (!header_row) continue;
    const auto& values = lines[i + 1];
    std::vector<double> numbers;
    for (const auto& t : values) {
      auto v = Number(t);
      if (!v) break;
      numbers.push_back(*v);
    }
    if (numbers.empty()) continue;
    if (numbers.size() + 1 < header.size() && numbers.size() != header.size()) {
      // VAL II puts HAND as a last header column without always a value.
    }
    const bool joints = IsJointHeader(header[0]);
    const bool combined = header[0].find('/') != std::string::npos;  // VAL II "X/JT1"
    if (combined) {
      // VAL II: first numeric row is the Cartesian pose, the second the joints.
      std::vector<double> second;
      if (i + 2 < lines.size()) {
        for (const auto& t : lines[i + 2]) {
          auto v = Number(t);
          if (!v) break;
          second.push_back(*v);
        }
      }
      if (second.empty()) {
        if (why) *why = "VAL II WHERE: expected a joint row after the Cartesian row";
        return std::nullopt;
      }
      out.pose =
          Eigen::Map<Eigen::VectorXd>(numbers.data(), std::min<Eigen::Index>(6, numbers.size()))
              .eval();
      out.joints_deg = Eigen::Map<Eigen::VectorXd>(second.data(), second.size());
      have_joints = true;
      break;
    }
    if (joints) {
      const size_t expected = header.size();
      if (numbers.size() != expected) {
        if (why)
          *why = "WHERE: " + std::to_string(expected) + " joint names but " +
                 std::to_string(numbers.size()) + " values";
        return std::nullopt;
      }
      out.joints_deg = Eigen::Map<Eigen::VectorXd>(numbers.data(), numbers.size());
      have_joints = true;
    } else if (header[0].rfind("X", 0) == 0) {
      out.pose = Eigen::Map<Eigen::VectorXd>(numbers.data(), numbers.size());
    }
  }
  if (!have_joints) {
    if (why) *why = "WHERE: no joint row (expected a header JT1 … followed by numbers)";
    return std::nullopt;
  }
  return out;
}

std::string FormatWhere(const Eigen::VectorXd& joints_deg, const Eigen::VectorXd& pose,
                        MonitorDialect dialect) {
  char buffer[32];
  std::string out;
  if (dialect == MonitorDialect::kValII) {
    if (pose.size() != 6) throw std::invalid_argument("VAL II WHERE needs a 6-value pose");
    out = "     X/JT1      Y/JT2      Z/JT3      O/JT4      A/JT5      T/JT6     HAND\r\n";
    for (int i = 0; i < 6; ++i) {
      std::snprintf(buffer, sizeof buffer, "%11.3f", pose(i));
      out += buffer;
    }
    out += "      0.000\r\n";  // HAND opening
    for (int i = 0; i < joints_deg.size(); ++i) {
      std::snprintf(buffer, sizeof buffer, "%11.3f", joints_deg(i));
      out += buffer;
    }
    return out + "\r\n";
  }
  out = " ";
  for (int i = 0; i < joints_deg.size(); ++i) {
    std::snprintf(buffer, sizeof buffer, "%9s ", ("JT" + std::to_string(i + 1)).c_str());
    out += buffer;
  }
  out += "\r\n";
  for (int i = 0; i < joints_deg.size(); ++i) {
    std::snprintf(buffer, sizeof buffer, "%9.3f ", joints_deg(i));
    out += buffer;
  }
  out += "\r\n    X[mm]     Y[mm]     Z[mm]     O[deg]    A[deg]    T[deg]\r\n";
  for (int i = 0; i < pose.size(); ++i) {
    std::snprintf(buffer, sizeof buffer, "%9.3f ", pose(i));
    out += buffer;
  }
  return out + "\r\n";
}

namespace {

std::string Upper(std::string_view s) {
  std::string out(s);
  for (char& c : out) c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
  return out;
}

}  // namespace

std::string FormatMonitorCommand(const MonitorCommand& command) {
  if (command.kind == MonitorCommand::Kind::kWhere) return "WHERE\r\n";
  std::string out = "DO JMOVE #[";
  char buffer[32];
  for (int i = 0; i < command.joints_deg.size(); ++i) {
    std::snprintf(buffer, sizeof buffer, "%s%.4f", i ? "," : "", command.joints_deg(i));
    out += buffer;
  }
  return out + "]\r\n";
}

std::optional<MonitorCommand> ParseMonitorCommand(std::string_view line, std::string* why) {
  auto fail = [&](std::string m) -> std::optional<MonitorCommand> {
    if (why) *why = std::move(m);
    return std::nullopt;
  };
  const std::string text = Upper(Trim(line, " \r\n"));
  MonitorCommand command;
  if (text == "WHERE" || text == "WH" || text == "WHERE 3") return command;
  constexpr std::string_view kJMove = "DO JMOVE #[";
  if (text.rfind(kJMove, 0) != 0)
    return fail("expected WHERE or DO JMOVE #[…], got " + Quoted(text));
  if (text.back() != ']') return fail("DO JMOVE: expected ']' at the end, got " + Quoted(text));
  const std::string_view list =
      std::string_view(text).substr(kJMove.size(), text.size() - kJMove.size() - 1);
  std::vector<double> values;
  size_t pos = 0;
  while (pos <= list.size()) {
    size_t comma = list.find(',', pos);
    if (comma == std::string_view::npos) comma = list.size();
    const std::string item(Trim(list.substr(pos, comma - pos), " \r\n"));
    auto v = Number(item);
    if (!v) {
      return fail("DO JMOVE: joint value " + std::to_string(values.size() + 1) +
                  ": expected a number of degrees, got " + Quoted(item));
    }
    values.push_back(*v);
    pos = comma + 1;
  }
  command.kind = MonitorCommand::Kind::kJMove;
  command.joints_deg = Eigen::Map<Eigen::VectorXd>(values.data(), values.size());
  return command;
}

MonitorLine ParseMonitorLine(std::string_view line) {
  MonitorLine out;
  while (!line.empty() && (line.back() == '\r' || line.back() == '\n')) line.remove_suffix(1);
  const size_t start = line.find_first_not_of(' ');
  if (start == std::string_view::npos) return out;
  out.text = std::string(line.substr(start));
  if (out.text == "." || out.text == ">") {
    out.kind = MonitorLine::Kind::kPrompt;
  } else if (out.text.rfind("(P", 0) == 0 || out.text.rfind("*", 0) == 0 ||
             out.text.rfind("Error", 0) == 0) {
    out.kind = MonitorLine::Kind::kError;
    const size_t close = out.text.find(')');
    int code = 0;
    if (out.text.rfind("(P", 0) == 0 && close != std::string::npos) {
      auto [p, ec] = std::from_chars(out.text.data() + 2, out.text.data() + close, code);
      if (ec == std::errc() && p == out.text.data() + close) out.error_code = code;
    }
  } else {
    out.kind = MonitorLine::Kind::kText;
  }
  return out;
}

std::string FormatMonitorPrompt(MonitorDialect dialect) {
  return dialect == MonitorDialect::kValII ? ".\r\n" : ">\r\n";
}

std::string FormatMonitorError(int code, std::string_view message) {
  return "(P" + std::to_string(code) + ")" + std::string(message) + "\r\n";
}

std::string FormatCounterRequest(const CounterRequest& q) {
  char buffer[32];
  if (q.value)
    std::snprintf(buffer, sizeof buffer, "%c%02X%X\n", q.kind, q.reg, *q.value);
  else
    std::snprintf(buffer, sizeof buffer, "%c%02X\n", q.kind, q.reg);
  return buffer;
}

std::optional<CounterRequest> ParseCounterRequest(std::string_view line, std::string* why) {
  auto fail = [&](std::string m) -> std::optional<CounterRequest> {
    if (why) *why = std::move(m);
    return std::nullopt;
  };
  const std::string_view text = Trim(line, " \r\n");
  CounterRequest q;
  if (text.size() < 3 || (text[0] != 'R' && text[0] != 'W' && text[0] != 'S'))
    return fail("expected R<reg>, W<reg><value> or S<reg> (reg 2 hex digits), got " +
                Quoted(std::string(text)));
  q.kind = text[0];
  unsigned reg = 0;
  auto [p, ec] = std::from_chars(text.data() + 1, text.data() + 3, reg, 16);
  if (ec != std::errc() || p != text.data() + 3)
    return fail("expected a register of 2 hex digits after " + Quoted(std::string(1, q.kind)) +
                ", got " + Quoted(std::string(text.substr(1, 2))));
  q.reg = static_cast<int>(reg);
  const std::string_view rest = text.substr(3);
  if (q.kind != 'W') {
    if (!rest.empty())
      return fail("unexpected " + Quoted(std::string(rest)) + " after " +
                  std::string(text.substr(0, 3)));
    return q;
  }
  uint32_t value = 0;
  auto [vp, vec] = std::from_chars(rest.data(), rest.data() + rest.size(), value, 16);
  if (rest.empty() || rest.size() > 8 || vec != std::errc() || vp != rest.data() + rest.size())
    return fail("W" + std::string(text.substr(1, 2)) +
                ": expected a value of 1-8 hex digits, got " + Quoted(std::string(rest)));
  q.value = value;
  return q;
}

std::optional<CounterReading> ParseCounterReply(std::string_view line, std::string* why) {
  std::string compact;
  for (char c : line) {
    if (c != ' ' && c != '\r' && c != '\n') compact += c;
  }
  auto fail = [&](std::string m) -> std::optional<CounterReading> {
    if (why) *why = std::move(m);
    return std::nullopt;
  };
  if (compact.empty()) return fail("empty reply");
  CounterReading r;
  if (compact[0] == 'e') {  // the box's error reply: data, not noise
    r.kind = 'e';
    return r;
  }
  if (compact.back() != '!') return fail("expected a reply ending in '!', got " + Quoted(compact));
  compact.pop_back();
  r.kind = compact[0];
  if (r.kind != 'r' && r.kind != 'w' && r.kind != 's')
    return fail("unknown reply kind " + Quoted(compact));
  if (compact.size() != 11 && compact.size() != 19) {
    return fail("expected <kind><reg 2 hex><data 8 hex>[<timestamp 8 hex>]!, got '" + compact +
                "!'");
  }
  unsigned reg = 0;
  uint32_t data = 0;
  auto hex = [&](size_t at, size_t n, auto& out) {
    auto [p, ec] = std::from_chars(compact.data() + at, compact.data() + at + n, out, 16);
    return ec == std::errc() && p == compact.data() + at + n;
  };
  if (!hex(1, 2, reg) || !hex(3, 8, data))
    return fail("expected hexadecimal digits in " + Quoted(compact));
  r.reg = static_cast<int>(reg);
  r.value = static_cast<int32_t>(data);  // two's complement count
  if (compact.size() == 19) {
    uint32_t ts = 0;
    if (!hex(11, 8, ts)) return fail("expected a hexadecimal timestamp in " + Quoted(compact));
    r.timestamp = ts;
  }
  return r;
}

std::string FormatCounterReply(const CounterReading& r) {
  if (r.kind == 'e') return "e!\r\n";
  char buffer[48];
  std::snprintf(buffer, sizeof buffer, "%c%02X%08X", r.kind, r.reg, static_cast<uint32_t>(r.value));
  std::string out = buffer;
  if (r.timestamp) {
    std::snprintf(buffer, sizeof buffer, "%08X", *r.timestamp);
    out += buffer;
  }
  return out + "!\r\n";
}

Eigen::VectorXd EncoderCalibration::ToJoints(const Eigen::VectorXd& counts) const {
  return coupling * counts.cwiseQuotient(counts_per_rad) + offset_rad;
}

Eigen::VectorXd EncoderCalibration::ToCounts(const Eigen::VectorXd& joints_rad) const {
  const Eigen::VectorXd uncoupled = coupling.lu().solve(joints_rad - offset_rad);
  Eigen::VectorXd counts = uncoupled.cwiseProduct(counts_per_rad);
  for (int i = 0; i < counts.size(); ++i) counts(i) = std::round(counts(i));
  return counts;
}

}  // namespace armsig::robots
