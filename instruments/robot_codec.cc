#include "instruments/robot_codec.h"

#include <Eigen/LU>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <sstream>

namespace armsig::instruments {

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

std::string FormatWhere(const Eigen::VectorXd& joints_deg, const Eigen::VectorXd& pose) {
  std::string out = " ";
  char buffer[32];
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
  if (compact[0] == 'e') return fail("counter box error reply '" + compact + "'");
  if (compact.back() != '!') return fail("expected a reply ending in '!', got '" + compact + "'");
  compact.pop_back();
  CounterReading r;
  r.kind = compact[0];
  if (r.kind != 'r' && r.kind != 'w' && r.kind != 's')
    return fail("unknown reply kind '" + compact + "'");
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
    return fail("expected hexadecimal digits in '" + compact + "'");
  r.reg = static_cast<int>(reg);
  r.value = static_cast<int32_t>(data);  // two's complement count
  if (compact.size() == 19) {
    uint32_t ts = 0;
    if (!hex(11, 8, ts)) return fail("expected a hexadecimal timestamp in '" + compact + "'");
    r.timestamp = ts;
  }
  return r;
}

std::string FormatCounterReply(const CounterReading& r) {
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

}  // namespace armsig::instruments
