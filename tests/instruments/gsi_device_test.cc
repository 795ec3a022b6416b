// The GSI Online driver against an in-memory transport: the bytes it sends, the replies
// it skips, the error replies it turns into typed errors.
#include "instruments/gsi_device.h"

#include <gtest/gtest.h>

#include <cmath>

namespace armsig::instruments {
namespace {

constexpr double kGon = M_PI / 200.0;

RetryPolicy GsiFast() {
  RetryPolicy p;
  p.attempts = 2;
  // The fakes answer at once: the timeout is the deadline a loaded machine's scheduling
  // must fit in (10 ms was missed before a first attempt elsewhere, on eight processes on two
  // cores), and the one a port of other words runs into.
  p.timeout = Millis(200);
  p.reconnect_delay = Millis(1);
  return p;
}

}  // namespace

// GET/M/WI21 then GET/I/WI22, byte for byte; a stray word and an ack are skipped.
TEST(GsiOnlineDevice, SendsGetRequestsAndSkipsOtherWords) {
  auto fake = std::make_unique<FakeTransport>([](std::string_view request) -> std::string {
    if (request == "GET/M/WI21\r\n") return "?\r\n22...2+10000000 \r\n21...2+12345678 \r\n";
    if (request == "GET/I/WI22\r\n") return "*22...2+0000000030000000 \r\n";
    return "@W427\r\n";
  });
  FakeTransport* port = fake.get();
  GsiOnlineDevice device(std::move(fake), GsiFast());
  const Reading r = device.MeasureAngles();
  EXPECT_NEAR(r.angles.hz_rad, 123.45678 * kGon, 1e-12);
  EXPECT_NEAR(r.angles.v_rad, 300.0 * kGon, 1e-12);  // the GSI-16 reply
  EXPECT_EQ(r.angles.face, 2);                        // V > 200 gon
  ASSERT_EQ(port->written().size(), 2u);
  EXPECT_EQ(port->written()[0], "GET/M/WI21\r\n");
  EXPECT_EQ(port->written()[1], "GET/I/WI22\r\n");
}

TEST(GsiOnlineDevice, ErrorRepliesAreTypedErrorsWithTheirCode) {
  auto fake = std::make_unique<FakeTransport>([](std::string_view) { return "@E139\r\n"; });
  GsiOnlineDevice device(std::move(fake), GsiFast());
  try {
    device.Get('M', 21);
    FAIL() << "expected InstrumentError";
  } catch (const InstrumentError& e) {
    EXPECT_EQ(e.code(), 139);
    EXPECT_NE(std::string(e.what()).find("@E139 for GET/M/WI21"), std::string::npos) << e.what();
  }
}

// A word in a unit that is not an angle: COM_CANT_DECODE naming the word and the units.
TEST(GsiOnlineDevice, WordInTheWrongUnitIsACodecError) {
  auto fake = std::make_unique<FakeTransport>([](std::string_view request) -> std::string {
    if (request == "GET/M/WI21\r\n") return "21...0+12345678 \r\n";
    return "22...2+10000000 \r\n";
  });
  GsiOnlineDevice device(std::move(fake), GsiFast());
  try {
    device.MeasureAngles();
    FAIL() << "expected InstrumentError";
  } catch (const InstrumentError& e) {
    EXPECT_EQ(e.code(), 3074);
    EXPECT_NE(std::string(e.what()).find("WI21: unit '0' is not an angle unit"), std::string::npos)
        << e.what();
  }
}

TEST(GsiOnlineDevice, SilenceGivesUpWithATimeoutCode) {
  auto fake = std::make_unique<FakeTransport>([](std::string_view) { return std::string(); });
  FakeTransport* port = fake.get();
  GsiOnlineDevice device(std::move(fake), GsiFast());
  try {
    device.Get('I', 13);
    FAIL() << "expected InstrumentError";
  } catch (const InstrumentError& e) {
    EXPECT_EQ(e.code(), 3077);
  }
  EXPECT_EQ(port->written().size(), 2u);  // one request per attempt
}

// A negative zenith angle (or Hz beyond 400 gon) is no reading: a typed error naming the
// device, the value and the range.
TEST(GsiOnlineDevice, AnglesOutOfRangeAreTypedErrors) {
  for (const char* v_word : {"22...2-01000000 \r\n", "22...2+45000000 \r\n"}) {
    auto fake = std::make_unique<FakeTransport>(
        [v_word](std::string_view request) -> std::string {
          if (request == "GET/M/WI21\r\n") return "21...2+12345678 \r\n";
          return v_word;
        },
        "T2002");
    GsiOnlineDevice device(std::move(fake), GsiFast());
    try {
      device.MeasureAngles();
      FAIL() << "expected ReadingRangeError for " << v_word;
    } catch (const ReadingRangeError& e) {
      EXPECT_EQ(e.code(), 3074);
      EXPECT_EQ(e.quantity(), "V (zenith angle)");
      EXPECT_NE(std::string(e.what()).find("T2002: V (zenith angle) = "), std::string::npos)
          << e.what();
      EXPECT_NE(std::string(e.what()).find("expected 0 to 6.28318"), std::string::npos)
          << e.what();
    }
  }
}

// Another word than the one asked for is skipped, and a port that only sends other words
// fails with a timeout at the deadline instead of reading forever.
TEST(GsiOnlineDevice, OnlyOtherWordsGiveUpAtTheDeadline) {
  auto fake = std::make_unique<FakeTransport>([](std::string_view) -> std::string {
    std::string flood;
    for (int k = 0; k < 1000; ++k) flood += "12....+00004711 \r\n";
    return flood;
  });
  GsiOnlineDevice device(std::move(fake), GsiFast());
  try {
    device.Get('M', 21);
    FAIL() << "expected InstrumentError";
  } catch (const InstrumentError& e) {
    EXPECT_EQ(e.code(), 3077);
  }
}

}  // namespace armsig::instruments
