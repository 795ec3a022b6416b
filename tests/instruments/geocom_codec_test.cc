#include "instruments/geocom_codec.h"

#include <gtest/gtest.h>

namespace armsig::instruments::geocom {

// CRC-16/ARC check value and the GeoCOM vectors of the protocol notes.
TEST(GeoComCodec, Crc16ArcVectors) {
  EXPECT_EQ(Crc16Arc("123456789"), 0xBB3D);
  EXPECT_EQ(Crc16Arc("%R1P,0,11:0"), 22896);
  EXPECT_EQ(Crc16Arc("%R1Q,0,11:"), 28925);
  EXPECT_EQ(Crc16Arc("%R1Q,0,1:"), 47813);
  EXPECT_EQ(Crc16Arc("%R1Q,2107,2:1"), 51719);
  EXPECT_EQ(Crc16Arc("%R1Q,2108,3:5000,1"), 32744);
  EXPECT_EQ(Crc16Arc("%R1Q,9028,4:0,0,0"), 56431);
  EXPECT_EQ(Crc16Arc("%R1Q,5004,5:"), 41821);
  EXPECT_EQ(Crc16Arc("%R1P,0,1:0"), 34666);
  EXPECT_EQ(Crc16Arc("%R1P,0,0:0"), 18235);
}

TEST(GeoComCodec, EncodesRequestsWithAndWithoutCrc) {
  EXPECT_EQ(EncodeRequest({2108, 3, {"5000", "1"}}, true), "\n%R1Q,2108,3,32744:5000,1\r\n");
  EXPECT_EQ(EncodeRequest({9028, 4, {"0", "0", "0"}}, false), "\n%R1Q,9028,4:0,0,0\r\n");
  EXPECT_EQ(EncodeRequest({0, 11, {}}, true), "\n%R1Q,0,11,28925:\r\n");
}

TEST(GeoComCodec, ParsesTheDocumentedReplies) {
  auto a = ParseReply("%R1P,0,11,22896:0");
  ASSERT_TRUE(a.reply);
  EXPECT_TRUE(a.had_crc);
  EXPECT_EQ(a.reply->trid, 11);
  EXPECT_EQ(a.reply->rc, 0);
  // CSV_GetDateTime from the manual: bytes in quotes.
  auto b = ParseReply("%R1P,0,0:0,1996,'07','19','10','13','2f'");
  ASSERT_TRUE(b.reply);
  ASSERT_EQ(b.reply->values.size(), 6u);
  EXPECT_EQ(DecodeByte(b.reply->values[5]), 0x2f);
  EXPECT_EQ(DecodeLong(b.reply->values[0]), 1996);
  // OpenIndy: BAP_GetMeasPrg -> 11.
  auto c = ParseReply("%R1P,0,0:0,11");
  ASSERT_TRUE(c.reply);
  EXPECT_EQ(c.reply->values, std::vector<std::string>{"11"});
}

TEST(GeoComCodec, RejectsBadCrcNoiseAndMalformedFrames) {
  EXPECT_EQ(ParseReply("%R1P,0,11,22897:0").error, ParseError::kBadCrc);
  EXPECT_EQ(ParseReply("garbage").error, ParseError::kNotAFrame);
  EXPECT_EQ(ParseReply("%R1P,0,x:0").error, ParseError::kMalformed);
  EXPECT_EQ(ParseReply("%R1P,0,1").error, ParseError::kMalformed);
  // Noise before the frame is skipped.
  auto noisy = ParseReply("\x13\xfe#%R1P,0,5:0,1");
  ASSERT_TRUE(noisy.reply);
  EXPECT_EQ(noisy.reply->trid, 5);
  // A reply cut short with the next one after it on the same line: the last frame.
  auto merged = ParseReply("%R1P,0,5:0,1.2345%R1P,0,6:0,2.5,1.5");
  ASSERT_TRUE(merged.reply);
  EXPECT_EQ(merged.reply->trid, 6);
  EXPECT_EQ(merged.reply->values, (std::vector<std::string>{"2.5", "1.5"}));
}

// On a CRC link a reply without its CRC field is refused, not accepted unchecked.
TEST(GeoComCodec, RequiredCrcRefusesRepliesWithoutOne) {
  EXPECT_TRUE(ParseReply("%R1P,0,11,22896:0", true).reply);
  const auto missing = ParseReply("%R1P,0,11:0", true);
  EXPECT_FALSE(missing.reply);
  EXPECT_EQ(missing.error, ParseError::kMissingCrc);
  EXPECT_NE(missing.why.find("expected a CRC field"), std::string::npos) << missing.why;
  EXPECT_EQ(ParseReply("%R1P,0:0", true).error, ParseError::kMissingCrc);  // no trid either
  EXPECT_EQ(ParseReply("%R1P,0,11,22897:0", true).error, ParseError::kBadCrc);
  EXPECT_TRUE(ParseReply("%R1P,0,11:0", false).reply);
}

TEST(GeoComCodec, CommunicationErrorMayCarryNoReturnCode) {
  auto r = ParseReply("%R1P,3101,0:");
  ASSERT_TRUE(r.reply);
  EXPECT_EQ(r.reply->rc_com, 3101);
}

TEST(GeoComCodec, ParsesRequestsForTheSimulator) {
  auto q = ParseRequest("%R1Q,9037:0.08,0.08,0");
  ASSERT_TRUE(q.request);
  EXPECT_EQ(q.request->rpc, 9037);
  EXPECT_FALSE(q.request->trid);
  EXPECT_EQ(q.request->params.size(), 3u);
  auto c = ParseRequest("%R1Q,2107,2,51719:1");
  ASSERT_TRUE(c.request);
  EXPECT_EQ(c.request->trid, 2);
  EXPECT_EQ(ParseRequest("%R1Q,2107,2,51718:1").error, ParseError::kBadCrc);
}

TEST(GeoComCodec, ParameterEncodings) {
  EXPECT_EQ(EncodeString("This is a \"quote\""), "\"This is a \\\"quote\\\"\"");
  EXPECT_EQ(DecodeString("\"This is a \\\"quote\\\"\""), "This is a \"quote\"");
  EXPECT_EQ(DecodeString("\"A\\x42C\""), "ABC");
  EXPECT_FALSE(DecodeString("no quotes"));
  EXPECT_EQ(DecodeLong("0x1F"), 31);
  EXPECT_EQ(DecodeDouble("4.712388980385"), 4.712388980385);
  EXPECT_FALSE(DecodeDouble("nan"));
  EXPECT_EQ(EncodeDouble(1.5, 3), "1.500");
}

// Request → text → request, with and without CRC, with and without transaction id,
// with quoted strings holding commas and negative numbers.
TEST(GeoComCodec, RequestsRoundTripWithAndWithoutCrc) {
  const Request requests[] = {
      {0, std::nullopt, {}},
      {0, 1, {}},
      {2108, 3, {"5000", "1"}},
      {9027, 32767, {EncodeDouble(-1.25), EncodeDouble(3.141592653589793), "0", "1", "0"}},
      {5004, 7, {EncodeString("a,b \"c\""), EncodeLong(-42)}},
  };
  for (bool crc : {false, true}) {
    for (const auto& q : requests) {
      const std::string text = EncodeRequest(q, crc);
      const auto parsed = ParseRequest(text);
      ASSERT_TRUE(parsed.request) << text << parsed.why;
      EXPECT_EQ(parsed.had_crc, crc);
      EXPECT_EQ(parsed.request->rpc, q.rpc);
      // With a CRC the transaction id field is always present (0 when none was given).
      EXPECT_EQ(parsed.request->trid.value_or(0), q.trid.value_or(0));
      EXPECT_EQ(parsed.request->params, q.params) << text;
    }
  }
}

TEST(GeoComCodec, RepliesRoundTripWithAndWithoutCrc) {
  const Reply replies[] = {
      {0, 0, 0, {}},
      {0, 11, 1284, {EncodeDouble(-0.5), EncodeDouble(6.2831853)}},
      {3101, 5, 0, {}},
      {0, 32767, 0, {EncodeString("TS30, \\x01"), "'2f'"}},
  };
  for (bool crc : {false, true}) {
    for (const auto& r : replies) {
      const std::string text = EncodeReply(r, crc);
      const auto parsed = ParseReply(text);
      ASSERT_TRUE(parsed.reply) << text << parsed.why;
      EXPECT_EQ(parsed.had_crc, crc);
      EXPECT_EQ(parsed.reply->rc_com, r.rc_com);
      EXPECT_EQ(parsed.reply->trid, r.trid);
      EXPECT_EQ(parsed.reply->rc, r.rc);
      EXPECT_EQ(parsed.reply->values, r.values) << text;
    }
  }
  EXPECT_EQ(EncodeReply({0, 11, 0, {}}, true), "%R1P,0,11,22896:0\r\n");  // notes §1.2
}

TEST(GeoComCodec, ParseErrorsNameTheField) {
  auto trid = ParseReply("%R1P,0,x:0");
  EXPECT_EQ(trid.error, ParseError::kMalformed);
  EXPECT_NE(trid.why.find("transaction id"), std::string::npos) << trid.why;
  EXPECT_NE(trid.why.find("'x'"), std::string::npos) << trid.why;
  auto rc = ParseReply("%R1P,0,1:abc");
  EXPECT_EQ(rc.error, ParseError::kMalformed);
  EXPECT_NE(rc.why.find("RPC return code"), std::string::npos) << rc.why;
  auto crc = ParseReply("%R1P,0,11,22897:0");
  EXPECT_EQ(crc.error, ParseError::kBadCrc);
  EXPECT_NE(crc.why.find("expected 22896"), std::string::npos) << crc.why;
  auto colon = ParseRequest("%R1Q,5004,3");
  EXPECT_EQ(colon.error, ParseError::kMalformed);
  EXPECT_NE(colon.why.find("':'"), std::string::npos) << colon.why;
  // An overflowed (negative) transaction id is still a frame.
  EXPECT_TRUE(ParseReply("%R1P,0,-32768:0").reply);
}

// Typed reply values → encoded values → typed values, negative angles included.
TEST(GeoComCodec, TypedReplyValuesRoundTrip) {
  const AngleComplete angle{4.712388980385, -0.25, 1e-6, 1000, 1e-5, -2e-5, 3e-6, 2000, 1};
  EXPECT_EQ(DecodeAngleComplete(EncodeValues(angle)), angle);
  const AngleSimple simple{0.0, 3.141592653589793};
  EXPECT_EQ(DecodeAngleSimple(EncodeValues(simple)), simple);
  // Distances are encoded to the µm.
  const SimpleMeasurement with_distance{1.5, 1.6, 12.345678};
  EXPECT_EQ(DecodeSimpleMeasurement(EncodeValues(with_distance)), with_distance);
  const SimpleMeasurement angles_only{1.5, 1.6, std::nullopt};
  EXPECT_EQ(EncodeValues(angles_only).size(), 2u);
  EXPECT_EQ(DecodeSimpleMeasurement(EncodeValues(angles_only)), angles_only);
  const DistanceAngle distance_angle{-1.0, 1.2, 0.5, 2};
  EXPECT_EQ(DecodeDistanceAngle(EncodeValues(distance_angle)), distance_angle);
  const Version version{3, 20, 7};
  EXPECT_EQ(DecodeVersion(EncodeValues(version)), version);
  EXPECT_EQ(DecodeLongValue({EncodeLong(-358123)}, "CSV_GetInstrumentNo"), -358123);
  EXPECT_EQ(DecodeStringValue({EncodeString("TDRA6000")}, "CSV_GetInstrumentName"), "TDRA6000");
}

TEST(GeoComCodec, TypedDecodersNameTheValueAndWhatWasExpected) {
  std::string why;
  EXPECT_FALSE(DecodeAngleComplete({"1.0", "2.0"}, &why));
  EXPECT_NE(why.find("TMC_GetAngle1: reply has 2 values, expected AngleAccuracy"),
            std::string::npos)
      << why;
  EXPECT_FALSE(DecodeSimpleMeasurement({"1.0", "x", "3"}, &why));
  EXPECT_NE(why.find("value 2 (V): expected a number, got 'x'"), std::string::npos) << why;
  EXPECT_FALSE(DecodeAngleComplete({"1", "2", "3", "4", "5", "6", "7", "8", "2"}, &why));
  EXPECT_NE(why.find("Face"), std::string::npos) << why;
  EXPECT_FALSE(DecodeVersion({"3", "20", "7.1"}, &why));
  EXPECT_NE(why.find("value 3 (Subversion): expected an integer"), std::string::npos) << why;
  EXPECT_FALSE(DecodeStringValue({"TS30"}, "CSV_GetInstrumentName", &why));
  EXPECT_NE(why.find("expected a quoted string"), std::string::npos) << why;
  EXPECT_FALSE(DecodeLongValue({}, "TMC_GetFace", &why));
  EXPECT_NE(why.find("TMC_GetFace: reply has 0 values"), std::string::npos) << why;
}

TEST(GeoComCodec, ReturnCodeClasses) {
  EXPECT_EQ(Classify(0), CodeClass::kOk);
  EXPECT_EQ(Classify(1283), CodeClass::kWarningDataValid);
  EXPECT_EQ(Classify(1284), CodeClass::kWarningDataValid);
  EXPECT_EQ(Classify(1285), CodeClass::kAnglesOnly);
  EXPECT_EQ(Classify(1289), CodeClass::kAnglesOnly);
  EXPECT_EQ(Classify(1293), CodeClass::kBusy);
  EXPECT_EQ(Classify(13), CodeClass::kBusy);
  EXPECT_EQ(Classify(1292), CodeClass::kError);
  EXPECT_EQ(Classify(8710), CodeClass::kError);
  EXPECT_EQ(CodeName(1284), "TMC_ACCURACY_GUARANTEE");
  EXPECT_EQ(CodeName(31999), "GRC_31999");
}

}  // namespace armsig::instruments::geocom
