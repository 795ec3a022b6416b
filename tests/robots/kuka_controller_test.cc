// The KUKA driver's decisions against a scripted variable server (in memory): what it writes,
// in which order, and what it does with each answer of ARMSIG's contract. The driver against
// the virtual controller over TCP: tests/simulation/kuka_simulator_test.cc.
#include "robots/kuka_controller.h"

#include <gtest/gtest.h>

#include <functional>
#include <map>
#include <numbers>

namespace armsig::robots {
using instruments::ControllerError;
using instruments::FakePacketTransport;
using instruments::InstrumentError;
using instruments::Millis;
using instruments::RetryPolicy;
namespace {

using kuka::contract::kCommand;
using kuka::contract::kDone;
using kuka::contract::kResult;

// A controller's variables; `on_write` sees every write after it is stored, `on_read`
// every read before it is answered.
struct ScriptedController {
  std::map<std::string, std::string> vars = {
      {"$MODE_OP", "#AUT"},          {"$PRO_STATE1", "#P_ACTIVE"},
      {"$PRO_NAME1[]", "\"/R1/ARMSIG.SRC\""}, {"$ALARM_STOP", "TRUE"},
      {"$STOPMESS", "FALSE"},        {"$USER_SAF", "TRUE"},
      {"$PERI_RDY", "TRUE"},         {"$ROB_STOPPED", "TRUE"},
      {"ARMSIG_VERSION", "1"},       {"ARMSIG_CMD", "4"},
      {"ARMSIG_BUSY", "4"},          {"ARMSIG_DONE", "4"},
      {"ARMSIG_RESULT", "0"},        {"ARMSIG_VEL", "10"},
      {"ARMSIG_ACC", "20"},
      {"ARMSIG_TARGET", "{E6AXIS: A1 0.0, A2 -90.0, A3 90.0, A4 0.0, A5 0.0, A6 0.0}"},
      {"$AXIS_ACT", "{E6AXIS: A1 1.5, A2 -90.0, A3 90.0, A4 0.0, A5 0.0, A6 0.0, E1 0.0}"}};
  std::function<void(const std::string&, const std::string&)> on_write;
  std::function<void(const std::string&)> on_read;
  std::vector<std::pair<std::string, std::string>> writes;

  std::vector<std::string> Answer(std::string_view bytes) {
    const auto d = kuka::DecodeRequest(bytes);
    EXPECT_TRUE(d.request) << d.why;
    const kuka::Request& r = *d.request;
    kuka::Response a{r.tag, static_cast<uint8_t>(r.type), "", 1, true};
    if (r.type == kuka::MessageType::kWrite) {
      vars[r.name] = r.value;
      writes.emplace_back(r.name, r.value);
      a.value = r.value;
      if (on_write) on_write(r.name, r.value);
    } else {
      if (on_read) on_read(r.name);
      const auto it = vars.find(r.name);
      a.value = it == vars.end() ? "" : it->second;
    }
    return {kuka::EncodeResponse(a)};
  }
};

std::unique_ptr<KukaController> Driver(ScriptedController& c) {
  KukaOptions options;
  options.poll = Millis(0);
  options.accept_timeout = Millis(50);
  return std::make_unique<KukaController>(
      std::make_unique<FakePacketTransport>([&c](std::string_view b) { return c.Answer(b); },
                                            "fake KR C4", kuka::kResponseFrames),
      true, RetryPolicy{}, options);
}

Eigen::VectorXd Target() { return Eigen::Vector3d(10, -80, 95) * std::numbers::pi / 180.0; }

TEST(KukaController, WritesTheTargetAndItsVelocityBeforeTheCommandNumber) {
  ScriptedController c;
  c.on_write = [&](const std::string& name, const std::string& value) {
    if (name == kCommand) {  // ARMSIG takes it and arrives
      c.vars[kDone] = value;
      c.vars[kResult] = "0";
    }
  };
  KukaOptions o;
  o.axes = 3;
  o.velocity_percent = 35;
  o.poll = Millis(0);
  KukaController driver(
      std::make_unique<FakePacketTransport>([&c](std::string_view b) { return c.Answer(b); },
                                            "fake KR C4", kuka::kResponseFrames),
      true, RetryPolicy{}, o);
  driver.MoveTo(Target());
  ASSERT_EQ(c.writes.size(), 4u);
  EXPECT_EQ(c.writes[0].first, "ARMSIG_TARGET");
  EXPECT_EQ(c.writes[0].second, "{E6AXIS: A1 10.0, A2 -80.0, A3 95.0}");
  EXPECT_EQ(c.writes[1], std::make_pair(std::string("ARMSIG_VEL"), std::string("35")));
  EXPECT_EQ(c.writes[2].first, "ARMSIG_ACC");
  EXPECT_EQ(c.writes[3], std::make_pair(std::string(kCommand), std::string("5")));  // 4 + 1
}

TEST(KukaController, ACommandNotExecutedIsSentOnceMoreThenRefused) {
  ScriptedController c;
  int commands = 0;
  c.on_write = [&](const std::string& name, const std::string& value) {
    if (name != kCommand) return;
    ++commands;
    c.vars["ARMSIG_BUSY"] = value;
    c.vars[kDone] = value;
    c.vars[kResult] = commands == 1 ? "3" : "0";  // ARMSIG restarted under the first one
  };
  auto driver = Driver(c);
  Eigen::VectorXd q(6);
  q << 0.1, -1.5, 1.6, 0, 0, 0;
  driver->MoveTo(q);
  EXPECT_EQ(commands, 2);
  EXPECT_EQ(c.vars[kCommand], "6");
  EXPECT_EQ(driver->statistics().resent_moves, 1);

  // Not executed twice in a row: no third try, the reason named.
  commands = 0;
  c.on_write = [&](const std::string& name, const std::string& value) {
    if (name != kCommand) return;
    ++commands;
    c.vars[kDone] = value;
    c.vars[kResult] = "3";
  };
  try {
    driver->MoveTo(q);
    ADD_FAILURE();
  } catch (const ControllerError& e) {
    EXPECT_EQ(e.kind(), ControllerError::Kind::kMoveRefused);
    EXPECT_NE(std::string(e.what()).find("not executed"), std::string::npos) << e.what();
  }
  EXPECT_EQ(commands, 2);
}

TEST(KukaController, AnOpenCommandForTheSameTargetIsWaitedForNotSentAgain) {
  ScriptedController c;
  c.vars[kCommand] = "9";
  c.vars["ARMSIG_BUSY"] = "9";
  c.vars[kDone] = "8";
  c.vars["ARMSIG_TARGET"] = "{E6AXIS: A1 0.1, A2 -90.0, A3 90.0, A4 0.0, A5 0.0, A6 0.0}";
  int polls = 0;
  c.on_read = [&](const std::string& name) {
    if (name == kDone && ++polls == 3) c.vars[kDone] = "9";  // the move ends
  };
  auto driver = Driver(c);
  Eigen::VectorXd q(6);
  q << 0.1, -90, 90, 0, 0, 0;
  driver->MoveTo(q * std::numbers::pi / 180.0);
  EXPECT_TRUE(c.writes.empty());
  EXPECT_EQ(driver->statistics().resumed_moves, 1);
}

TEST(KukaController, MissingContractVariablesNameTheFileToInstall) {
  ScriptedController c;
  c.vars.erase("ARMSIG_VERSION");  // KukaVarProxy: an unknown variable reads empty
  auto driver = Driver(c);
  try {
    driver->CheckReady();
    ADD_FAILURE();
  } catch (const ControllerError& e) {
    EXPECT_EQ(e.kind(), ControllerError::Kind::kVersionRefused);
    EXPECT_NE(std::string(e.what()).find("ARMSIG_VERSION cannot be read"), std::string::npos)
        << e.what();
    EXPECT_NE(std::string(e.what()).find("$CONFIG.DAT"), std::string::npos) << e.what();
  }
  // Joints need no contract: $AXIS_ACT, A1 … A6 in degrees.
  const Eigen::VectorXd q = driver->ReadJointsRad();
  EXPECT_NEAR(q(0), 1.5 * std::numbers::pi / 180.0, 1e-15);
  EXPECT_THROW(Driver(c)->MoveTo(Eigen::VectorXd::Zero(5)), std::invalid_argument);
}

TEST(KukaController, NeverMovesARobotItDoesNotCommand) {
  ScriptedController c;
  KukaController driver(
      std::make_unique<FakePacketTransport>([&c](std::string_view b) { return c.Answer(b); },
                                            "fake KR C4", kuka::kResponseFrames),
      false);
  EXPECT_THROW(driver.MoveTo(Eigen::VectorXd::Zero(6)), InstrumentError);
  EXPECT_TRUE(c.writes.empty());
}

}  // namespace
}  // namespace armsig::robots
