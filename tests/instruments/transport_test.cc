// Line splitting with a maximum line length, deadlines and interrupts of the transports
// (the Asio ones over real pseudo-terminals are in tests/simulation/faults_pty_test.cc).
#include "instruments/transport.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <thread>

namespace armsig::instruments {
namespace {

using namespace std::chrono_literals;

std::vector<std::string> Lines(LineBuffer& buffer, size_t max_bytes) {
  std::vector<std::string> out;
  std::string line;
  while (buffer.Next(max_bytes, line)) out.push_back(line);
  return out;
}

}  // namespace

TEST(LineBuffer, SplitsOnCrLfAndCrLfAndKeepsPartialLines) {
  LineBuffer b;
  const std::string text = "one\r\ntwo\nthree\rfou";
  b.Append(text.data(), text.size());
  EXPECT_EQ(Lines(b, 16), (std::vector<std::string>{"one", "", "two", "three"}));
  b.Append("r\r\n", 3);
  EXPECT_EQ(Lines(b, 16), (std::vector<std::string>{"four", ""}));
  EXPECT_EQ(b.size(), 0u);
}

// 17 bytes without a terminator on a 16-byte line: an error at once (not when the line
// ends, which may be never), and the rest of that line is not taken for a line.
TEST(LineBuffer, LineLongerThanTheMaximumIsAnErrorAndItsTailIsDropped) {
  LineBuffer b;
  const std::string head(17, 'x');
  b.Append(head.data(), head.size());
  std::string line;
  try {
    b.Next(16, line);
    FAIL() << "expected std::length_error";
  } catch (const std::length_error& e) {
    EXPECT_STREQ(e.what(), "line longer than 16 bytes");
  }
  const std::string rest = "%R1P,0,1:0\r\n%R1P,0,2:0\r\n";  // the tail looks like a reply
  b.Append(rest.data(), rest.size());
  EXPECT_EQ(Lines(b, 16), (std::vector<std::string>{"", "%R1P,0,2:0", ""}));
  // A whole over-long line in one piece: the error, then the next line.
  const std::string whole = std::string(40, 'y') + "\nok\n";
  b.Append(whole.data(), whole.size());
  EXPECT_THROW(b.Next(16, line), std::length_error);
  EXPECT_EQ(Lines(b, 16), (std::vector<std::string>{"ok"}));
  // Exactly the maximum is a line.
  const std::string full = std::string(16, 'z') + "\n";
  b.Append(full.data(), full.size());
  EXPECT_EQ(Lines(b, 16), (std::vector<std::string>{std::string(16, 'z')}));
}

// 64 MiB of garbage without a line end, 512 bytes at a time. The cost is linear because
// the buffer never holds more than one limit and one chunk: each call looks at those bytes
// at most (rescanning everything held since the flood began took minutes). Checked after
// every call, not by a clock.
TEST(LineBuffer, AFloodCostsLinearTime) {
  LineBuffer b;
  const std::string chunk(512, '#');
  int errors = 0;
  size_t most_held = 0;
  std::string line;
  for (int k = 0; k < 64 * 2048; ++k) {
    b.Append(chunk.data(), chunk.size());
    most_held = std::max(most_held, b.size());
    try {
      while (b.Next(512, line)) {
      }
    } catch (const std::length_error&) {
      ++errors;
    }
    most_held = std::max(most_held, b.size());
  }
  // One endless line: an error for every 512 bytes of it past the first 512 (about one
  // per chunk), every byte of it dropped.
  EXPECT_GE(errors, 60000);
  EXPECT_LE(most_held, 512u + 512u);
  EXPECT_LE(b.size(), 512u);
}

// Bytes drained mid-line leave the line's rest to be dropped, not read as a line.
TEST(LineBuffer, DiscardMidLineDropsTheRestOfThatLine) {
  LineBuffer b;
  b.Discard("%R1P,0,7:0,1.0", 14);
  const std::string more = ",2.0\r\n%R1P,0,8:0\r\n";
  b.Append(more.data(), more.size());
  EXPECT_EQ(Lines(b, 64), (std::vector<std::string>{"", "%R1P,0,8:0", ""}));
  b.Discard("whole line\r\n", 12);
  b.Append("next\n", 5);
  EXPECT_EQ(Lines(b, 64), (std::vector<std::string>{"next"}));
}

TEST(FakeTransport, MaximumLineLengthAndInterrupt) {
  FakeTransport port([](std::string_view) { return std::string(600, 'x') + "\r\nok\r\n"; });
  port.SetMaxLineBytes(512);
  const Deadline deadline = Clock::now() + 100ms;
  port.Write("?", deadline);
  try {
    port.ReadLine(deadline);
    FAIL() << "expected TransportError";
  } catch (const TransportError& e) {
    EXPECT_EQ(e.kind(), TransportError::Kind::kLineTooLong);
    EXPECT_EQ(e.message(), "line longer than 512 bytes");
  }
  EXPECT_EQ(port.ReadLine(deadline), "ok");
  std::atomic<bool> stop{true};
  port.SetInterrupt(&stop);
  try {
    port.ReadLine(deadline);
    FAIL() << "expected TransportError";
  } catch (const TransportError& e) {
    EXPECT_EQ(e.kind(), TransportError::Kind::kInterrupted);
  }
}

// A pause ends at its deadline, or within the poll interval of an interrupt.
TEST(LineTransport, PauseEndsByItsDeadlineOrAnInterrupt) {
  FakeTransport port([](std::string_view) { return std::string(); });
  auto start = Clock::now();
  port.Pause(10s, start + 50ms);
  EXPECT_GE(Clock::now() - start, 50ms);
  EXPECT_LT(Clock::now() - start, 2s);
  std::atomic<bool> stop{false};
  port.SetInterrupt(&stop);
  std::thread raise([&] {
    std::this_thread::sleep_for(50ms);
    stop = true;
  });
  start = Clock::now();
  EXPECT_THROW(port.Pause(10s, start + 10s), TransportError);
  EXPECT_LT(Clock::now() - start, 2s);
  raise.join();
}

}  // namespace armsig::instruments
