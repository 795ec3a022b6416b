// The VAL-family controller and the counter box against an in-memory transport: the
// exact commands they send and how they read the replies.
#include "robots/robot_controllers.h"

#include <gtest/gtest.h>

#include "core/units.h"

namespace armsig::robots {
using instruments::FakeTransport;
using instruments::InstrumentError;
using instruments::LineTransport;
using instruments::Millis;
using instruments::ReadingRangeError;
using instruments::RetryPolicy;
namespace {

RetryPolicy ControllerFast() {
  RetryPolicy p;
  p.attempts = 2;
  // Every fake here answers at once: the timeout is only the deadline that a loaded
  // machine's scheduling must fit in (10 ms was missed before the first attempt on eight
  // processes on two cores: "no usable reply after 0 attempts").
  p.timeout = Millis(500);
  p.reconnect_delay = Millis(1);
  return p;
}

}  // namespace

TEST(ValController, ReadsWhereAndSendsJMoveInDegrees) {
  auto fake = std::make_unique<FakeTransport>([](std::string_view request) -> std::string {
    if (request == "WHERE\r\n")
      return "WHERE\r\n"
             "     JT1       JT2       JT3       JT4       JT5       JT6\r\n"
             "    -6.552    23.595   -87.421  -147.271    88.570  -167.663\r\n"
             "    X[mm]     Y[mm]     Z[mm]     O[deg]    A[deg]    T[deg]\r\n"
             "  -214.985  1355.266  -106.276  -146.040   142.521    46.437\r\n"
             ">\r\n";
    return std::string(request) + ">\r\n";  // echo, prompt
  });
  FakeTransport* port = fake.get();
  ValController robot(std::move(fake), true, ControllerFast());
  const Eigen::VectorXd q = robot.ReadJointsRad();
  ASSERT_EQ(q.size(), 6);
  EXPECT_NEAR(q(0), -6.552 * kRadPerDeg, 1e-12);
  EXPECT_NEAR(q(5), -167.663 * kRadPerDeg, 1e-12);
  Eigen::VectorXd target(3);
  target << 10.0 * kRadPerDeg, -20.5 * kRadPerDeg, 0.0;
  robot.MoveTo(target);
  ASSERT_EQ(port->written().size(), 2u);
  EXPECT_EQ(port->written()[0], "WHERE\r\n");
  EXPECT_EQ(port->written()[1], "DO JMOVE #[10.0000,-20.5000,0.0000]\r\n");
}

TEST(ValController, ControllerErrorMessageIsATypedError) {
  auto fake = std::make_unique<FakeTransport>([](std::string_view) -> std::string {
    return "WHERE\r\n(P1000)Cannot execute program because motor power is OFF.\r\n>\r\n";
  });
  ValController robot(std::move(fake), false, ControllerFast());
  try {
    robot.ReadJointsRad();
    FAIL() << "expected InstrumentError";
  } catch (const InstrumentError& e) {
    EXPECT_NE(std::string(e.what()).find("(P1000)Cannot execute"), std::string::npos) << e.what();
  }
  EXPECT_THROW(robot.MoveTo(Eigen::VectorXd::Zero(6)), InstrumentError);  // not commanded
}

TEST(ValController, WhereWithoutJointRowIsACodecError) {
  auto fake = std::make_unique<FakeTransport>(
      [](std::string_view) -> std::string { return "WHERE\r\n   JT1   JT2\r\n  1.0\r\n.\r\n"; });
  ValController robot(std::move(fake), false, ControllerFast());
  try {
    robot.ReadJointsRad();
    FAIL() << "expected InstrumentError";
  } catch (const InstrumentError& e) {
    EXPECT_EQ(e.code(), 3074);
    EXPECT_NE(std::string(e.what()).find("2 joint names but 1 values"), std::string::npos)
        << e.what();
  }
}

TEST(CounterBox, ReadsSignedCountsAndTypesErrorReplies) {
  std::vector<std::unique_ptr<LineTransport>> channels;
  std::vector<FakeTransport*> ports;
  const char* replies[] = {"noise\r\nr0EFFFFFFFE!\r\n", "r0E000003E8!\r\n"};  // −2, 1000
  for (const char* reply : replies) {
    auto fake = std::make_unique<FakeTransport>([reply](std::string_view) { return reply; });
    ports.push_back(fake.get());
    channels.push_back(std::move(fake));
  }
  EncoderCalibration c;
  c.counts_per_rad = Eigen::Vector2d(1000.0, -500.0);
  c.offset_rad = Eigen::Vector2d(0.1, 0.0);
  c.coupling = Eigen::Matrix2d::Identity();
  CounterBox box(std::move(channels), c, ControllerFast());
  const Eigen::VectorXd q = box.ReadJointsRad();
  EXPECT_NEAR(q(0), -2.0 / 1000.0 + 0.1, 1e-15);
  EXPECT_NEAR(q(1), 1000.0 / -500.0, 1e-15);
  for (auto* port : ports) EXPECT_EQ(port->written().at(0), "R0E\n");

  std::vector<std::unique_ptr<LineTransport>> failing;
  failing.push_back(std::make_unique<FakeTransport>([](std::string_view) { return "e!\r\n"; }));
  CounterBox broken(std::move(failing), EncoderCalibration{}, ControllerFast());
  EXPECT_THROW(broken.ReadCounts(), InstrumentError);
}

// Joints no robot can have (a reply in other units, a corrupted row): no reading.
TEST(ValController, JointsBeyondTwoTurnsAreTypedErrors) {
  auto fake = std::make_unique<FakeTransport>(
      [](std::string_view) -> std::string {
        return "WHERE\r\n     JT1       JT2       JT3\r\n    10.000  -725.500     0.000\r\n>\r\n";
      },
      "AS controller");
  ValController robot(std::move(fake), false, ControllerFast());
  try {
    robot.ReadJointsRad();
    FAIL() << "expected ReadingRangeError";
  } catch (const ReadingRangeError& e) {
    EXPECT_EQ(e.code(), 3074);
    EXPECT_EQ(e.quantity(), "joint 2");
    EXPECT_NEAR(e.value(), -725.5, 1e-9);
    EXPECT_EQ(e.min(), -720.0);
    EXPECT_EQ(e.max(), 720.0);
    EXPECT_NE(std::string(e.what()).find("AS controller: joint 2 = -725.5 deg"), std::string::npos)
        << e.what();
  }
}

// A monitor that prints rows but never its prompt: a typed error after
// kMaxMonitorReplyLines lines, not a read until the deadline or beyond.
TEST(ValController, RowsWithoutAPromptAreATypedError) {
  auto fake = std::make_unique<FakeTransport>([](std::string_view) -> std::string {
    std::string rows;
    for (int k = 0; k < 500; ++k) rows += "   1.000   2.000\r\n";
    return rows;
  });
  ValController robot(std::move(fake), false, ControllerFast());
  try {
    robot.ReadJointsRad();
    FAIL() << "expected InstrumentError";
  } catch (const InstrumentError& e) {
    EXPECT_EQ(e.code(), 3100);
    EXPECT_NE(std::string(e.what()).find("no prompt after 64 lines"), std::string::npos)
        << e.what();
  }
}

TEST(CounterBox, CountsBeyondTwoTurnsAreTypedErrors) {
  std::vector<std::unique_ptr<LineTransport>> channels;
  channels.push_back(
      std::make_unique<FakeTransport>([](std::string_view) { return "r0E7FFFFFFF!\r\n"; }));
  EncoderCalibration c;
  c.counts_per_rad = Eigen::VectorXd::Constant(1, 10000.0);
  c.offset_rad = Eigen::VectorXd::Zero(1);
  c.coupling = Eigen::MatrixXd::Identity(1, 1);
  CounterBox box(std::move(channels), c, ControllerFast());
  EXPECT_THROW(box.ReadJointsRad(), ReadingRangeError);
}

}  // namespace armsig::robots

