#include "robots/robot_codec.h"

#include <gtest/gtest.h>

#include <numbers>

namespace armsig::robots {

// The verified Kawasaki AS transcript of the protocol notes, verbatim.
TEST(WhereParser, KawasakiAsTranscript) {
  const std::string text =
      "WHERE\r\n"
      "     JT1       JT2       JT3       JT4       JT5       JT6\r\n"
      "    -6.552    23.595   -87.421  -147.271    88.570  -167.663\r\n"
      "    X[mm]     Y[mm]     Z[mm]     O[deg]    A[deg]    T[deg]\r\n"
      "  -214.985  1355.266  -106.276  -146.040   142.521    46.437\r\n"
      ">\r\n";
  auto w = ParseWhere(text);
  ASSERT_TRUE(w);
  ASSERT_EQ(w->joints_deg.size(), 6);
  EXPECT_DOUBLE_EQ(w->joints_deg(0), -6.552);
  EXPECT_DOUBLE_EQ(w->joints_deg(5), -167.663);
  ASSERT_EQ(w->pose.size(), 6);
  EXPECT_DOUBLE_EQ(w->pose(1), 1355.266);
}

// The reported VAL II layout: combined X/JT1 headers, Cartesian row then joint row.
TEST(WhereParser, ValTwoLayout) {
  const std::string text =
      ".WHERE\r\n"
      "     X/JT1      Y/JT2      Z/JT3      O/JT4      A/JT5      T/JT6     HAND\r\n"
      "    512.300   -120.000    700.250     10.000     80.000    -35.000      0.000\r\n"
      "     12.500    -45.000    150.000      5.000     30.000     60.000\r\n"
      ".\r\n";
  auto w = ParseWhere(text);
  ASSERT_TRUE(w);
  EXPECT_DOUBLE_EQ(w->joints_deg(1), -45.0);
  EXPECT_DOUBLE_EQ(w->pose(0), 512.3);
}

TEST(WhereParser, RefusesMissingOrShortRows) {
  std::string why;
  EXPECT_FALSE(ParseWhere(
      "WHERE\r\n(P1000)Cannot execute program because motor power is OFF.\r\n>\r\n", &why));
  EXPECT_FALSE(ParseWhere("     JT1       JT2       JT3\r\n   1.0   2.0\r\n", &why));
  EXPECT_NE(why.find("3 joint names but 2 values"), std::string::npos) << why;
}

TEST(CounterCodec, ParsesQsbRepliesAndErrors) {
  auto r = ParseCounterReply("r0E0000ABCD!");
  ASSERT_TRUE(r);
  EXPECT_EQ(r->reg, 0x0E);
  EXPECT_EQ(r->value, 0xABCD);
  auto negative = ParseCounterReply("r 0E FFFFFFFE 00000010 !");
  ASSERT_TRUE(negative);
  EXPECT_EQ(negative->value, -2);
  EXPECT_EQ(negative->timestamp, 0x10u);
  std::string why;
  const auto error = ParseCounterReply("e!", &why);
  ASSERT_TRUE(error);  // the box's error reply is data, not noise
  EXPECT_EQ(error->kind, 'e');
  EXPECT_FALSE(ParseCounterReply("r0E12!", &why));
  EXPECT_NE(why.find("expected <kind><reg 2 hex>"), std::string::npos) << why;
  EXPECT_EQ(ParseCounterReply(FormatCounterReply(*r))->value, 0xABCD);
}

TEST(CounterCodec, RepliesRoundTrip) {
  CounterReading error;
  error.kind = 'e';
  const CounterReading readings[] = {
      {'r', 0x0E, 0, std::nullopt},
      {'r', 0x0E, -1, std::nullopt},                        // signed 32-bit: FFFFFFFF
      {'r', 0x0E, 2147483647, 0xFFFFFFFFu},                 // largest count, timestamp
      {'r', 0x0E, -2147483648LL, 0x10u},                    // smallest count
      {'w', 0x15, 5, std::nullopt},
      {'s', 0x0E, 123456, 42u},
      error,
  };
  for (const auto& r : readings) {
    const std::string text = FormatCounterReply(r);
    EXPECT_EQ(text.substr(text.size() - 3), "!\r\n");
    EXPECT_EQ(ParseCounterReply(text), r) << text;
  }
  EXPECT_EQ(FormatCounterReply({'r', 0x0E, -2, std::nullopt}), "r0EFFFFFFFE!\r\n");
}

TEST(CounterCodec, RequestsRoundTrip) {
  const CounterRequest requests[] = {
      {'R', 0x0E, std::nullopt}, {'S', 0x0E, std::nullopt}, {'W', 0x00, 0u},
      {'W', 0x03, 0x0Cu},        {'W', 0x08, 0x1F3u},       {'W', 0x15, 0xFFFFFFFFu},
  };
  for (const auto& q : requests) {
    const std::string text = FormatCounterRequest(q);
    EXPECT_EQ(ParseCounterRequest(text), q) << text;
  }
  // The command strings of US Digital's example program (protocol notes §4.8).
  EXPECT_EQ(FormatCounterRequest({'R', 0x0E, std::nullopt}), "R0E\n");
  EXPECT_EQ(FormatCounterRequest({'W', 0x08, 0x1F3u}), "W081F3\n");
  std::string why;
  EXPECT_FALSE(ParseCounterRequest("RZZ", &why));
  EXPECT_NE(why.find("register of 2 hex digits"), std::string::npos) << why;
  EXPECT_FALSE(ParseCounterRequest("W03", &why));
  EXPECT_NE(why.find("value of 1-8 hex digits"), std::string::npos) << why;
  EXPECT_FALSE(ParseCounterRequest("R0E12", &why));
  EXPECT_FALSE(ParseCounterRequest("X0E", &why));
}

// Joints and pose → WHERE text → joints and pose, both dialects, negative values; the
// readout has 3 decimals, so the round trip holds to 0.0005.
TEST(WhereParser, FormattedReadoutsRoundTrip) {
  Eigen::VectorXd q(6), pose(6);
  q << -6.552, 23.595, -87.421, -147.271, 88.570, -167.6634;
  pose << -214.985, 1355.266, -106.276, -146.040, 142.521, 46.437;
  for (auto dialect : {MonitorDialect::kKawasakiAs, MonitorDialect::kValII}) {
    const std::string text =
        "WHERE\r\n" + FormatWhere(q, pose, dialect) + FormatMonitorPrompt(dialect);
    const auto w = ParseWhere(text);
    ASSERT_TRUE(w) << text;
    ASSERT_EQ(w->joints_deg.size(), 6);
    ASSERT_EQ(w->pose.size(), 6);
    EXPECT_LT((w->joints_deg - q).cwiseAbs().maxCoeff(), 0.0005 + 1e-12) << text;
    EXPECT_LT((w->pose - pose).cwiseAbs().maxCoeff(), 0.0005 + 1e-12) << text;
  }
  // The VAL II header of the protocol notes, verbatim.
  EXPECT_EQ(FormatWhere(q, pose, MonitorDialect::kValII).substr(0, 76),
            "     X/JT1      Y/JT2      Z/JT3      O/JT4      A/JT5      T/JT6     HAND\r\n");
  EXPECT_THROW(FormatWhere(q, Eigen::VectorXd(3), MonitorDialect::kValII), std::invalid_argument);
}

TEST(MonitorCodec, CommandsRoundTrip) {
  MonitorCommand move;
  move.kind = MonitorCommand::Kind::kJMove;
  move.joints_deg.resize(6);
  move.joints_deg << 10.0, -20.5, 0.0, 179.9999, -180.0, 0.0001;
  const std::string text = FormatMonitorCommand(move);
  EXPECT_EQ(text, "DO JMOVE #[10.0000,-20.5000,0.0000,179.9999,-180.0000,0.0001]\r\n");
  const auto parsed = ParseMonitorCommand(text);
  ASSERT_TRUE(parsed);
  EXPECT_EQ(parsed->kind, MonitorCommand::Kind::kJMove);
  EXPECT_LT((parsed->joints_deg - move.joints_deg).cwiseAbs().maxCoeff(), 1e-12);
  EXPECT_EQ(FormatMonitorCommand({}), "WHERE\r\n");
  for (const char* where : {"WHERE", "where", "wh", "WHERE 3", "  WHERE\r\n"}) {
    const auto w = ParseMonitorCommand(where);
    ASSERT_TRUE(w) << where;
    EXPECT_EQ(w->kind, MonitorCommand::Kind::kWhere);
  }
  std::string why;
  EXPECT_FALSE(ParseMonitorCommand("DO JMOVE #[1.0,abc,3]", &why));
  EXPECT_NE(why.find("joint value 2"), std::string::npos) << why;
  EXPECT_NE(why.find("'ABC'"), std::string::npos) << why;
  EXPECT_FALSE(ParseMonitorCommand("DO JMOVE #[1.0,2.0", &why));
  EXPECT_NE(why.find("']'"), std::string::npos) << why;
  EXPECT_FALSE(ParseMonitorCommand("DO JMOVE #[]", &why));
  EXPECT_FALSE(ParseMonitorCommand("EXECUTE", &why));
}

TEST(MonitorCodec, LinesRoundTrip) {
  for (auto dialect : {MonitorDialect::kKawasakiAs, MonitorDialect::kValII}) {
    const std::string prompt = FormatMonitorPrompt(dialect);
    EXPECT_EQ(ParseMonitorLine(prompt).kind, MonitorLine::Kind::kPrompt) << prompt;
  }
  const MonitorLine error =
      ParseMonitorLine(FormatMonitorError(1000, "Cannot execute program because motor power is OFF."));
  EXPECT_EQ(error.kind, MonitorLine::Kind::kError);
  EXPECT_EQ(error.error_code, 1000);
  EXPECT_EQ(error.text, "(P1000)Cannot execute program because motor power is OFF.");
  EXPECT_EQ(ParseMonitorLine("*Unknown instruction*").kind, MonitorLine::Kind::kError);
  EXPECT_FALSE(ParseMonitorLine("*Unknown instruction*").error_code);
  EXPECT_EQ(ParseMonitorLine("     JT1       JT2").kind, MonitorLine::Kind::kText);
  EXPECT_EQ(ParseMonitorLine("     JT1       JT2").text, "JT1       JT2");
  EXPECT_EQ(ParseMonitorLine("   ").kind, MonitorLine::Kind::kBlank);
  EXPECT_EQ(ParseMonitorLine(" .").kind, MonitorLine::Kind::kPrompt);
}

// PUMA wrist: joint 6 moves with joint 5 (−0.180556), counts per degree from the notes.
TEST(CounterCodec, CountsToJointsWithCoupling) {
  EncoderCalibration c;
  const double per_deg[6] = {-173.92, 239.59, -149.18, 211.21, 199.79, 213.02};
  c.counts_per_rad.resize(6);
  for (int i = 0; i < 6; ++i) c.counts_per_rad(i) = per_deg[i] * 180.0 / std::numbers::pi;
  c.offset_rad = Eigen::VectorXd::Zero(6);
  c.coupling = Eigen::MatrixXd::Identity(6, 6);
  c.coupling(5, 4) = -0.180556;
  Eigen::VectorXd counts(6);
  counts << 0, 0, 0, 0, 1997.9, 0;  // 10° on joint 5's encoder
  const Eigen::VectorXd q = c.ToJoints(counts);
  EXPECT_NEAR(q(4) * 180 / std::numbers::pi, 10.0, 1e-9);
  EXPECT_NEAR(q(5) * 180 / std::numbers::pi, -1.80556, 1e-9);
  const Eigen::VectorXd joints = (Eigen::VectorXd(6) << 0.1, -0.2, 0.3, -0.4, 0.5, -0.6).finished();
  EXPECT_LT((c.ToJoints(c.ToCounts(joints)) - joints).cwiseAbs().maxCoeff(), 1e-4);  // one count
}

}  // namespace armsig::robots
