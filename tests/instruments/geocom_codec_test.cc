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
