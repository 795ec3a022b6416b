// The GeoCOM driver against an in-memory transport: replies that are no readings (no CRC
// on a CRC link, angles out of range or in other units, another RPC's values) are typed
// errors naming the device, the value and what was expected; nothing is returned.
#include "instruments/geocom_device.h"

#include <gtest/gtest.h>

#include <numbers>

namespace armsig::instruments {
namespace {

using namespace std::chrono_literals;

RetryPolicy GeocomFast() {
  RetryPolicy p;
  p.attempts = 2;
  p.timeout = 400ms;  // the fakes answer at once: room for a loaded machine's scheduling
  p.busy_delay = 1ms;
  p.reconnect_delay = 1ms;
  return p;
}

// A device whose instrument answers every request with `values` after rc 0, under the
// request's transaction id (and a CRC when `crc`).
std::unique_ptr<GeoComDevice> Answering(std::vector<std::string> values, bool crc_link,
                                        bool reply_crc) {
  auto fake = std::make_unique<FakeTransport>(
      [values, reply_crc](std::string_view request) -> std::string {
        const auto q = geocom::ParseRequest(request.substr(1));  // leading LF
        return geocom::EncodeReply({0, q.request->trid.value_or(0), 0, values}, reply_crc);
      },
      "TS30 on fake");
  return std::make_unique<GeoComDevice>(std::move(fake), GeocomFast(), crc_link);
}

std::vector<std::string> AngleValues(double hz_rad, double v_rad) {
  return geocom::EncodeValues(geocom::AngleComplete{hz_rad, v_rad, 1e-6, 1000, 0, 0, 1e-6, 1000, 0});
}

}  // namespace

TEST(GeoComDevice, ReplyWithoutCrcOnACrcLinkIsRefused) {
  const auto values = AngleValues(1.0, 1.5);
  EXPECT_NEAR(Answering(values, true, true)->MeasureAngles().angles.hz_rad, 1.0, 1e-12);
  auto device = Answering(values, true, false);
  try {
    device->MeasureAngles();
    FAIL() << "expected InstrumentError";
  } catch (const InstrumentError& e) {
    EXPECT_EQ(e.code(), 3110);  // COM_NO_CHECKSUM
    EXPECT_NE(std::string(e.what()).find("reply without a CRC on a CRC link"), std::string::npos)
        << e.what();
  }
  EXPECT_EQ(device->statistics().crc_errors, 2);  // refused on every attempt
  // Without CRCs on the link the same reply is a reading.
  EXPECT_NEAR(Answering(values, false, false)->MeasureAngles().angles.v_rad, 1.5, 1e-12);
}

// Hz beyond a full circle, a negative zenith angle, angles in degrees: no reading.
TEST(GeoComDevice, AnglesOutOfRangeAreTypedErrorsNamingValueAndRange) {
  struct Case {
    double hz, v;
    const char* quantity;
    double value;
  };
  for (const Case& c : {Case{7.0, 1.5, "Hz", 7.0}, Case{1.0, -0.25, "V (zenith angle)", -0.25},
                        Case{123.4, 95.0, "Hz", 123.4}, Case{1.0, 6.3, "V (zenith angle)", 6.3}}) {
    auto device = Answering(AngleValues(c.hz, c.v), false, false);
    try {
      device->MeasureAngles();
      FAIL() << "expected ReadingRangeError for " << c.hz << ", " << c.v;
    } catch (const ReadingRangeError& e) {
      EXPECT_EQ(e.code(), 3074);
      EXPECT_EQ(e.device(), "TS30 on fake");
      EXPECT_EQ(e.quantity(), c.quantity);
      EXPECT_DOUBLE_EQ(e.value(), c.value);
      EXPECT_EQ(e.min(), 0.0);
      EXPECT_DOUBLE_EQ(e.max(), 2.0 * std::numbers::pi);
      const std::string what = e.what();
      EXPECT_EQ(what.rfind("TS30 on fake: ", 0), 0u) << what;
      EXPECT_NE(what.find("expected 0 to 6.28318"), std::string::npos) << what;
    }
  }
  // The edges are readings.
  EXPECT_NO_THROW(Answering(AngleValues(0.0, 2.0 * std::numbers::pi), false, false)->MeasureAngles());
}

TEST(GeoComDevice, NegativeDistanceIsRefused) {
  auto fake = std::make_unique<FakeTransport>([](std::string_view request) -> std::string {
    const auto q = geocom::ParseRequest(request.substr(1));
    std::vector<std::string> values;
    if (q.request->rpc == geocom::rpc::kGetSimpleMea)
      values = geocom::EncodeValues(geocom::SimpleMeasurement{1.0, 1.5, -12.5});
    return geocom::EncodeReply({0, *q.request->trid, 0, values}, false);
  });
  GeoComDevice device(std::move(fake), GeocomFast());
  try {
    device.MeasureDistanceAndAngles();
    FAIL() << "expected ReadingRangeError";
  } catch (const ReadingRangeError& e) {
    EXPECT_EQ(e.quantity(), "slope distance");
    EXPECT_DOUBLE_EQ(e.value(), -12500.0);
  }
}

// The right transaction id with another RPC's values (CSV_GetFirmwareVersion's three
// longs): TMC_GetAngle1 cannot decode them, TMC_GetAngle5 reads V = 20 rad.
TEST(GeoComDevice, AnotherRpcsReplyIsNoReading) {
  auto device = Answering(geocom::EncodeValues(geocom::Version{3, 20, 7}), false, false);
  try {
    device->MeasureAngles();
    FAIL() << "expected InstrumentError";
  } catch (const InstrumentError& e) {
    EXPECT_EQ(e.code(), 3074);
    EXPECT_NE(std::string(e.what()).find("TMC_GetAngle1: reply has 3 values"), std::string::npos) << e.what();
  }
  EXPECT_THROW(device->MeasureAnglesSimple(), ReadingRangeError);
}

// A reply to an earlier attempt of the same call is that call's reply (a slow
// instrument is not failed for answering late); replies to other requests are not.
TEST(GeoComDevice, LateReplyToAnEarlierAttemptIsAccepted) {
  int requests = 0;
  auto fake = std::make_unique<FakeTransport>([&](std::string_view request) -> std::string {
    const auto q = geocom::ParseRequest(request.substr(1));
    if (++requests == 1) return "";  // slow: no reply in the first attempt's share
    // Then the late reply to the first attempt arrives, then the second's.
    return geocom::EncodeReply({0, *q.request->trid - 1, 0, AngleValues(1.0, 1.5)}, false) +
           geocom::EncodeReply({0, *q.request->trid, 0, AngleValues(1.0, 1.5)}, false);
  });
  GeoComDevice device(std::move(fake), GeocomFast());
  EXPECT_NEAR(device.MeasureAngles().angles.hz_rad, 1.0, 1e-12);
  EXPECT_EQ(device.statistics().stale_replies, 0);
  EXPECT_EQ(device.statistics().retries, 1);
}

}  // namespace armsig::instruments
