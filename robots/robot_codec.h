// Robot joint capture codecs (pure).
//  - VAL-family WHERE readout: a header row of names, then a row of numbers, for the
//    joints (JT1…JTn) and the Cartesian pose (X Y Z O A T), in either order, terminated
//    by the monitor prompt. Accepts the PUMA VAL II layout (X/JT1 headers, Cartesian
//    row first, joint row second) and the Kawasaki AS layout (JT1… then X[mm]…).
//  - VAL-family monitor commands (WHERE, DO JMOVE #[j1,…,jn] in Kawasaki AS syntax) and
//    the lines the monitor prints (prompt, error message, text).
//  - Quadrature counter box (US Digital QSB-style ASCII): requests "R0E", "W<reg><hex>",
//    "S<reg>"; replies "r0E<8 hex>[<8 hex ts>]!", errors "e…!".
// Every layout has a parser and a formatter. Parse failures are values (nullopt and
// `why`: the field and what was expected).
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace armsig::robots {

// The two monitor dialects: VAL II (prompt '.', combined X/JT1 WHERE headers) and
// Kawasaki AS (prompt '>', joint rows then Cartesian rows).
enum class MonitorDialect { kValII, kKawasakiAs };

// A command typed at the monitor.
struct MonitorCommand {
  enum class Kind { kWhere, kJMove };
  Kind kind = Kind::kWhere;
  Eigen::VectorXd joints_deg;  // kJMove: DO JMOVE #[j1,…,jn], degrees with 4 decimals
};
// "WHERE\r\n" or "DO JMOVE #[10.0000,-20.5000]\r\n".
std::string FormatMonitorCommand(const MonitorCommand& command);
// Case-insensitive; accepts WHERE, WH and WHERE 3 (AS: joint readout).
std::optional<MonitorCommand> ParseMonitorCommand(std::string_view line,
                                                  std::string* why = nullptr);

// One line the monitor printed.
struct MonitorLine {
  enum class Kind { kBlank, kPrompt, kError, kText };
  Kind kind = Kind::kBlank;
  std::string text;               // without leading blanks and the terminator
  std::optional<int> error_code;  // the number of "(P1000)…" error messages
};
// Prompt: "." (VAL II) or ">" (AS). Errors: "(Pnnnn)…", "*…", "Error…".
MonitorLine ParseMonitorLine(std::string_view line);
std::string FormatMonitorPrompt(MonitorDialect dialect);              // ".\r\n" / ">\r\n"
std::string FormatMonitorError(int code, std::string_view message);  // "(P1000)…\r\n"

struct WhereReadout {
  Eigen::VectorXd joints_deg;  // JT1…JTn
  Eigen::VectorXd pose;        // X, Y, Z (mm), O, A, T (deg); empty when absent
};

// Parses the lines of a WHERE reply (echo and prompt lines are ignored). nullopt and
// `why` when no joint row can be found or a row does not match its header.
std::optional<WhereReadout> ParseWhere(std::string_view text, std::string* why = nullptr);
// The readout rows (no echo, no prompt) with 3 decimals: the Kawasaki AS layout (JT row,
// then X[mm] row) or the VAL II layout (X/JT1 header, Cartesian row with HAND, joint row;
// VAL II needs a 6-value pose).
std::string FormatWhere(const Eigen::VectorXd& joints_deg, const Eigen::VectorXd& pose,
                        MonitorDialect dialect = MonitorDialect::kKawasakiAs);

struct CounterRequest {
  char kind = 'R';                 // R read, W write, S start streaming
  int reg = 0x0E;                  // register (0x0E = encoder count)
  std::optional<uint32_t> value;   // W only
  bool operator==(const CounterRequest&) const = default;
};
std::string FormatCounterRequest(const CounterRequest& request);  // "R0E\n"
std::optional<CounterRequest> ParseCounterRequest(std::string_view line,
                                                  std::string* why = nullptr);

struct CounterReading {
  char kind = 'r';                    // r, w, s; 'e' = the box's error reply ("e…!")
  int reg = 0;                        // register (0x0E = encoder count)
  int64_t value = 0;                  // signed 32-bit count
  std::optional<uint32_t> timestamp;  // units of 1.95 ms
  bool operator==(const CounterReading&) const = default;
};
std::optional<CounterReading> ParseCounterReply(std::string_view line, std::string* why = nullptr);
std::string FormatCounterReply(const CounterReading& reading);  // "r0E0000ABCD!\r\n", "e!\r\n"

// Counts → joint angles: θ = C · (scale ⊙ counts) + offset, C the coupling matrix
// (identity but for coupled joints: the PUMA's joint 6 moves with joint 5).
struct EncoderCalibration {
  Eigen::VectorXd counts_per_rad;  // per joint; negative for reversed encoders
  Eigen::VectorXd offset_rad;      // angle at count 0
  Eigen::MatrixXd coupling;        // n × n
  Eigen::VectorXd ToJoints(const Eigen::VectorXd& counts) const;
  Eigen::VectorXd ToCounts(const Eigen::VectorXd& joints_rad) const;  // for the simulator
};

}  // namespace armsig::robots
