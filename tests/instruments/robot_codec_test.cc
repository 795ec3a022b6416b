#include "instruments/robot_codec.h"

#include <gtest/gtest.h>

#include <numbers>

namespace armsig::instruments {

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
  EXPECT_FALSE(ParseCounterReply("e!", &why));
  EXPECT_FALSE(ParseCounterReply("r0E12!", &why));
  EXPECT_EQ(ParseCounterReply(FormatCounterReply(*r))->value, 0xABCD);
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

}  // namespace armsig::instruments
