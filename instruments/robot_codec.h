// Robot joint capture codecs (pure).
//  - VAL-family WHERE readout: a header row of names, then a row of numbers, for the
//    joints (JT1…JTn) and the Cartesian pose (X Y Z O A T), in either order, terminated
//    by the monitor prompt. Accepts the PUMA VAL II layout (X/JT1 headers, Cartesian
//    row first, joint row second) and the Kawasaki AS layout (JT1… then X[mm]…).
//  - Quadrature counter box (US Digital QSB-style ASCII): "r0E<8 hex>[<8 hex ts>]!".
#pragma once

#include <Eigen/Core>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace armsig::instruments {

struct WhereReadout {
  Eigen::VectorXd joints_deg;  // JT1…JTn
  Eigen::VectorXd pose;        // X, Y, Z (mm), O, A, T (deg); empty when absent
};

// Parses the lines of a WHERE reply (echo and prompt lines are ignored). nullopt and
// `why` when no joint row can be found or a row does not match its header.
std::optional<WhereReadout> ParseWhere(std::string_view text, std::string* why = nullptr);
// The Kawasaki AS layout, for the simulator.
std::string FormatWhere(const Eigen::VectorXd& joints_deg, const Eigen::VectorXd& pose);

struct CounterReading {
  char kind = 'r';                    // r, w, s
  int reg = 0;                        // register (0x0E = encoder count)
  int64_t value = 0;                  // signed 32-bit count
  std::optional<uint32_t> timestamp;  // units of 1.95 ms
};
std::optional<CounterReading> ParseCounterReply(std::string_view line, std::string* why = nullptr);
std::string FormatCounterReply(const CounterReading& reading);

// Counts → joint angles: θ = C · (scale ⊙ counts) + offset, C the coupling matrix
// (identity but for coupled joints: the PUMA's joint 6 moves with joint 5).
struct EncoderCalibration {
  Eigen::VectorXd counts_per_rad;  // per joint; negative for reversed encoders
  Eigen::VectorXd offset_rad;      // angle at count 0
  Eigen::MatrixXd coupling;        // n × n
  Eigen::VectorXd ToJoints(const Eigen::VectorXd& counts) const;
  Eigen::VectorXd ToCounts(const Eigen::VectorXd& joints_rad) const;  // for the simulator
};

}  // namespace armsig::instruments
