// The retry loop of the line-protocol drivers without transaction ids (GSI Online,
// VAL monitor, counter box), bounded by the device call's deadline: reopen a lost port,
// drain late replies after a timeout, give up with a typed error (GeoCOM client codes:
// 3077 COM_TIMEDOUT, 3100 COM_OVERRUN, 3085 COM_FAILED) after the policy's attempts or
// at the deadline, whichever comes first. An interrupt is never retried.
#pragma once

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <string>

#include "instruments/device.h"
#include "instruments/geocom_codec.h"
#include "instruments/return_codes.h"
#include "instruments/transport.h"

namespace armsig::instruments {

// Draining late replies after a timeout stops after this long on a port that never
// goes quiet (a flood), so the next attempt still gets its share of the deadline.
inline constexpr Millis kMaxDrain{100};

// The deadline of one attempt: its share of the time left before `deadline`.
inline Deadline AttemptDeadline(Deadline deadline, int attempts_left) {
  const auto now = Clock::now();
  if (now >= deadline || attempts_left <= 1) return deadline;
  return now + (deadline - now) / attempts_left;
}

// A transport failure in GeoCOM's client code space.
inline int CodeOf(const TransportError& e) {
  switch (e.kind()) {
    case TransportError::Kind::kTimeout:
      return grc::kComTimedOut;
    case TransportError::Kind::kLineTooLong:
    case TransportError::Kind::kBadFrame:
      return grc::kComOverrun;  // a line or packet beyond the maximum, or out of frame
    default:
      return grc::kComFailed;  // the port is gone or cannot be opened
  }
}

// "no usable reply after 3 attempts in 1001 ms: <why>"
inline std::string GaveUp(int attempts, Clock::time_point start, const std::string& why) {
  const auto ms = std::chrono::duration_cast<Millis>(Clock::now() - start).count();
  return fmt::format("no usable reply after {} attempt{} in {} ms: {}", attempts,
                     attempts == 1 ? "" : "s", ms, why);
}

// The bookkeeping of a driver's retry loop: attempts made, since when, the last failure.
//   Attempts a(policy, deadline);
//   for (; a.Left(); a.Next()) { … a.Until() … a.Failed(e); }
//   throw …(a.code(), a.GaveUp());
class Attempts {
 public:
  Attempts(const RetryPolicy& policy, Deadline deadline) : policy_(policy), deadline_(deadline) {}
  bool Left() const { return made_ < policy_.attempts && Clock::now() < deadline_; }
  void Next() { ++made_; }
  // This attempt's deadline: its share of the time left.
  Deadline Until() const { return AttemptDeadline(deadline_, policy_.attempts - made_); }
  void Failed(const TransportError& e) { Failed(CodeOf(e), e.message()); }
  void Failed(int code, std::string why) {
    code_ = code;
    last_ = std::move(why);
  }
  int made() const { return made_; }
  int code() const { return code_; }
  const std::string& last() const { return last_; }
  // "no usable reply after 3 attempts in 1001 ms: <the last failure>"
  std::string GaveUp() const { return instruments::GaveUp(made_, start_, last_); }

 private:
  const RetryPolicy& policy_;
  Deadline deadline_;
  Clock::time_point start_ = Clock::now();
  std::string last_ = "no attempt before the deadline";
  int code_ = grc::kComTimedOut;
  int made_ = 0;
};

// Calls attempt(attempt_deadline) until it returns, at most policy.attempts times and
// never past `deadline`.
template <typename F>
auto WithRetries(LineTransport& transport, const RetryPolicy& policy, Deadline deadline,
                 F&& attempt) {
  Attempts a(policy, deadline);
  for (; a.Left(); a.Next()) {
    const Deadline until = a.Until();
    try {
      if (!transport.IsOpen()) {
        transport.Open();
        transport.Drain(Millis(20), until);
      }
      return attempt(until);
    } catch (const TransportError& e) {
      if (e.kind() == TransportError::Kind::kInterrupted) throw;
      a.Failed(e);
      spdlog::debug("{}: attempt {} of {} failed: {}", transport.name(), a.made() + 1,
                    policy.attempts, a.last());
      if (e.kind() == TransportError::Kind::kTimeout ||
          e.kind() == TransportError::Kind::kLineTooLong) {
        try {
          // No transaction ids: clear late replies (never for long on a flooding port).
          transport.Drain(Millis(50), std::min(deadline, Clock::now() + kMaxDrain));
        } catch (const TransportError& d) {
          if (d.kind() == TransportError::Kind::kInterrupted) throw;
          transport.Close();
        }
      } else {
        transport.Close();
        transport.Pause(policy.reconnect_delay, deadline);
      }
    }
  }
  throw InstrumentError(transport.name(), a.code(), geocom::CodeName(a.code()) + ": " + a.GaveUp());
}

}  // namespace armsig::instruments
