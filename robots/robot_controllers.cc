#include "robots/robot_controllers.h"

#include <spdlog/spdlog.h>

#include <numbers>

#include "instruments/line_retry.h"

namespace armsig::robots {
using instruments::CheckJoints;
namespace grc = instruments::grc;
using instruments::Clock;
using instruments::Deadline;
using instruments::InstrumentError;
using instruments::LineTransport;
using instruments::RetryPolicy;
using instruments::TransportError;

ValController::ValController(std::unique_ptr<LineTransport> transport, bool can_move,
                             RetryPolicy policy)
    : transport_(std::move(transport)), can_move_(can_move), policy_(policy) {
  transport_->SetMaxLineBytes(kMaxMonitorLineBytes);
}

std::string ValController::Command(const MonitorCommand& command, Deadline deadline) {
  const std::string line = FormatMonitorCommand(command);
  const std::string shown = line.substr(0, line.find_first_of("\r\n"));
  transport_->Write(line, deadline);
  std::string text;
  for (int lines = 0;; ++lines) {
    if (lines >= kMaxMonitorReplyLines) {
      throw InstrumentError(name(), grc::kComOverrun,
                            "no prompt after " + std::to_string(kMaxMonitorReplyLines) +
                                " lines in reply to " + shown +
                                ": the controller is not answering the command");
    }
    std::string received;
    try {
      received = transport_->ReadLine(deadline);
    } catch (const TransportError& e) {
      if (e.kind() != TransportError::Kind::kTimeout) throw;
      throw TransportError(TransportError::Kind::kTimeout, name(),
                           "no prompt after " + shown + " by the deadline");
    }
    const MonitorLine parsed = ParseMonitorLine(received);
    switch (parsed.kind) {
      case MonitorLine::Kind::kBlank:
        continue;
      case MonitorLine::Kind::kPrompt:
        return text;
      case MonitorLine::Kind::kError:
        throw InstrumentError(name(), 1, "controller: " + parsed.text);
      case MonitorLine::Kind::kText:
        text += received + "\n";
    }
  }
}

Eigen::VectorXd ValController::ReadJointsRad() {
  const Deadline deadline = Clock::now() + policy_.timeout;
  return WithRetries(*transport_, policy_, deadline, [&](Deadline until) -> Eigen::VectorXd {
    const std::string text = Command({MonitorCommand::Kind::kWhere, {}}, until);
    std::string why;
    auto where = ParseWhere(text, &why);
    if (!where) throw InstrumentError(name(), grc::kComCantDecode, why);
    const Eigen::VectorXd joints_rad = where->joints_deg * (std::numbers::pi / 180.0);
    CheckJoints(name(), joints_rad);
    return joints_rad;
  });
}

void ValController::MoveTo(const Eigen::VectorXd& joints_rad) {
  if (!can_move_) throw InstrumentError(name(), 5, "this controller is not commanded by armsig");
  const MonitorCommand move{MonitorCommand::Kind::kJMove, joints_rad * 180.0 / std::numbers::pi};
  const Deadline deadline = Clock::now() + policy_.timeout * kMoveTimeoutFactor;
  WithRetries(*transport_, policy_, deadline, [&](Deadline until) {
    Command(move, until);
    return 0;
  });
}

CounterBox::CounterBox(std::vector<std::unique_ptr<LineTransport>> channels,
                       EncoderCalibration calibration, RetryPolicy policy)
    : channels_(std::move(channels)), calibration_(std::move(calibration)), policy_(policy) {
  name_ = "counter box";
  for (const auto& c : channels_) {
    name_ += " " + c->name();
    c->SetMaxLineBytes(kMaxCounterLineBytes);
  }
}

Eigen::VectorXd CounterBox::ReadCounts() {
  const std::string read_count = FormatCounterRequest({'R', 0x0E, std::nullopt});
  Eigen::VectorXd counts(channels_.size());
  const Deadline deadline = Clock::now() + policy_.timeout;  // every channel by then
  for (size_t i = 0; i < channels_.size(); ++i) {
    LineTransport& t = *channels_[i];
    counts(i) = static_cast<double>(WithRetries(t, policy_, deadline, [&](Deadline until) -> int64_t {
      t.Write(read_count, until);
      int other = 0;  // lines skipped against the deadline
      for (;;) {
        std::string why;
        std::string line;
        try {
          line = t.ReadLine(until);
        } catch (const TransportError& e) {
          if (e.kind() != TransportError::Kind::kTimeout || other == 0) throw;
          throw TransportError(e.kind(), t.name(),
                               "no count (r0E) by the deadline: " + std::to_string(other) +
                                   " other lines skipped");
        }
        ++other;
        auto reply = ParseCounterReply(line, &why);
        if (!reply) {
          spdlog::debug("{}: skipped a line that is no counter reply: {}", t.name(), why);
          continue;  // noise
        }
        if (reply->kind == 'e') throw InstrumentError(t.name(), 1, "counter box error reply");
        if (reply->kind == 'r' && reply->reg == 0x0E) return reply->value;
      }
    }));
  }
  return counts;
}

Eigen::VectorXd CounterBox::ReadJointsRad() {
  const Eigen::VectorXd joints_rad = calibration_.ToJoints(ReadCounts());
  CheckJoints(name_, joints_rad);
  return joints_rad;
}

void CounterBox::MoveTo(const Eigen::VectorXd&) {
  throw InstrumentError(name_, 5, "an encoder-counter box cannot move the robot");
}

}  // namespace armsig::robots
