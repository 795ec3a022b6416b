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

// Calls attempt(attempt_deadline) until it returns, at most policy.attempts times and
// never past `deadline`.
template <typename F>
auto WithRetries(LineTransport& transport, const RetryPolicy& policy, Deadline deadline,
                 F&& attempt) {
  const auto start = Clock::now();
  std::string last = "no attempt before the deadline";
  int code = grc::kComTimedOut;
  int made = 0;
  for (; made < policy.attempts && Clock::now() < deadline; ++made) {
    const Deadline until = AttemptDeadline(deadline, policy.attempts - made);
    try {
      if (!transport.IsOpen()) {
        transport.Open();
        transport.Drain(Millis(20), until);
      }
      return attempt(until);
    } catch (const TransportError& e) {
      if (e.kind() == TransportError::Kind::kInterrupted) throw;
      last = e.message();
      code = CodeOf(e);
      spdlog::debug("{}: attempt {} of {} failed: {}", transport.name(), made + 1,
                    policy.attempts, last);
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
  throw InstrumentError(transport.name(), code,
                        geocom::CodeName(code) + ": " + GaveUp(made, start, last));
}

}  // namespace armsig::instruments
