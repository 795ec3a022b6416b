// The Universal Robots codec against byte sequences written out by hand from the public
// layouts (RTDE guide, support article 22229, protocol version 2; the Client Interface's
// packet tables; big-endian throughout), each annotated with its fields: decoding them must
// give the values, encoding the values the same bytes. Larger messages (a robot state with
// its KinematicsInfo) are assembled by this file's own big-endian writer, not the codec's.
// Then the dashboard's answers, URScript movej lines and movej's time.
#include "robots/ur_codec.h"

#include <gtest/gtest.h>

#include <cctype>
#include <cmath>
#include <cstring>
#include <stdexcept>
#include <string>
#include <vector>

#include "test_support.h"

namespace armsig::robots::ur {
using instruments::ControllerKinematics;
using instruments::FrameSplitter;
namespace {

using ::armsig::testing::Hex;

// This test's own big-endian writer.
struct Be {
  std::string bytes;
  Be& U8(unsigned v) {
    bytes += static_cast<char>(v & 0xff);
    return *this;
  }
  Be& U32(uint32_t v) {
    for (int s = 24; s >= 0; s -= 8) U8((v >> s) & 0xff);
    return *this;
  }
  Be& U64(uint64_t v) {
    for (int s = 56; s >= 0; s -= 8) U8(static_cast<unsigned>((v >> s) & 0xff));
    return *this;
  }
  Be& D(double v) {
    uint64_t bits;
    std::memcpy(&bits, &v, 8);
    return U64(bits);
  }
  Be& F(float v) {
    uint32_t bits;
    std::memcpy(&bits, &v, 4);
    return U32(bits);
  }
};

// --- RTDE ----------------------------------------------------------------------------------

struct RequestVector {
  const char* what;
  std::string encoded;
  std::string hex;
};

TEST(UrRtde, RequestsAreTheGuidesBytes) {
  const RequestVector vectors[] = {
      // size 5, 'V', uint16 version 2
      {"request protocol version 2", rtde::RequestProtocolVersion(2), "00 05  56  00 02"},
      // size 3, 'v'
      {"get URControl version", rtde::GetUrControlVersion(), "00 03  76"},
      // size 3 + 8 + 18: 'O', double 125.0, "timestamp,actual_q"
      {"setup outputs", rtde::SetupOutputs(125.0, {"timestamp", "actual_q"}),
       "00 1D  4F  40 5F 40 00 00 00 00 00"
       "74 69 6D 65 73 74 61 6D 70 2C 61 63 74 75 61 6C 5F 71"},
      {"start", rtde::Start(), "00 03  53"},
      {"pause", rtde::Pause(), "00 03  50"},
  };
  for (const auto& v : vectors) EXPECT_EQ(v.encoded, Hex(v.hex)) << v.what;
}

TEST(UrRtde, TheControllersAnswersDecodeToTheirValues) {
  std::string why;
  // 'V' accepted / refused: uint8.
  auto accepted = rtde::Decode(Hex("00 04 56 01"), &why);
  ASSERT_TRUE(accepted) << why;
  EXPECT_EQ(accepted->type, 'V');
  EXPECT_EQ(rtde::DecodeAccepted(accepted->payload), true);
  EXPECT_EQ(rtde::DecodeAccepted(rtde::Decode(Hex("00 04 56 00"), &why)->payload), false);
  EXPECT_EQ(rtde::Accepted(rtde::Type::kRequestProtocolVersion, false), Hex("00 04 56 00"));
  // 'v': major 5, minor 11, bugfix 1, build 108318 (0x1A71E), each uint32.
  const std::string version = Hex("00 13 76  00 00 00 05  00 00 00 0B  00 00 00 01  00 01 A7 1E");
  const auto v = rtde::DecodeUrControlVersion(rtde::Decode(version, &why)->payload);
  ASSERT_TRUE(v);
  EXPECT_EQ(v->Text(), "5.11.1.108318");
  EXPECT_TRUE(v->ESeries());
  EXPECT_EQ(rtde::UrControlVersion(*v), version);
  // 'O' answer: recipe 1, "DOUBLE,VECTOR6D".
  const std::string setup = Hex("00 13 4F 01  44 4F 55 42 4C 45 2C 56 45 43 54 4F 52 36 44");
  const auto answer = rtde::DecodeSetupOutputsAnswer(rtde::Decode(setup, &why)->payload);
  ASSERT_TRUE(answer);
  EXPECT_EQ(answer->recipe, 1);
  EXPECT_EQ(answer->types, (std::vector<std::string>{"DOUBLE", "VECTOR6D"}));
  EXPECT_EQ(rtde::SetupOutputsAnswer(*answer), setup);
  // 'M' (v2): "hi" from "RTDE", level 2 (warning).
  const std::string text = Hex("00 0C 4D  02 68 69  04 52 54 44 45  02");
  const auto t = rtde::DecodeText(rtde::Decode(text, &why)->payload);
  ASSERT_TRUE(t);
  EXPECT_EQ(t->message, "hi");
  EXPECT_EQ(t->source, "RTDE");
  EXPECT_EQ(t->level, 2);
  EXPECT_EQ(rtde::Text(*t), text);
}

TEST(UrRtde, ADataPackageCarriesTheRecipesValuesInOrder) {
  // recipe 1; DOUBLE 1.5 (3FF8…), INT32 -1, UINT32 7, VECTOR3D (0.5, -2, 0).
  const std::string frame = Hex(
      "00 2C 55 01"
      "3F F8 00 00 00 00 00 00"
      "FF FF FF FF"
      "00 00 00 07"
      "3F E0 00 00 00 00 00 00  C0 00 00 00 00 00 00 00  00 00 00 00 00 00 00 00");
  const std::vector<rtde::ValueType> types = {rtde::ValueType::kDouble, rtde::ValueType::kInt32,
                                              rtde::ValueType::kUint32, rtde::ValueType::kVector3d};
  std::string why;
  const auto package = rtde::Decode(frame, &why);
  ASSERT_TRUE(package) << why;
  const auto data = rtde::DecodeData(package->payload, types, &why);
  ASSERT_TRUE(data) << why;
  EXPECT_EQ(data->recipe, 1);
  ASSERT_EQ(data->values.size(), 4u);
  EXPECT_EQ(data->values[0], std::vector<double>{1.5});
  EXPECT_EQ(data->values[1], std::vector<double>{-1.0});
  EXPECT_EQ(data->values[2], std::vector<double>{7.0});
  EXPECT_EQ(data->values[3], (std::vector<double>{0.5, -2.0, 0.0}));
  EXPECT_EQ(rtde::EncodeData(1, types, data->values), frame);
  // One byte short of the recipe: refused, naming both lengths (1 + 8 + 4 + 4 + 24).
  EXPECT_FALSE(rtde::DecodeData(package->payload.substr(1), types, &why));
  EXPECT_NE(why.find("40 bytes, the recipe's is 41"), std::string::npos) << why;
}

TEST(UrRtde, ASizeFieldThatIsNotTheLengthIsRefused) {
  std::string why;
  EXPECT_FALSE(rtde::Decode(Hex("00 09 56 01"), &why));
  EXPECT_NE(why.find("size field 9"), std::string::npos) << why;
}

struct TypeVector {
  const char* name;
  size_t count, bytes;
};

TEST(UrRtde, TheGuidesTypesHaveTheirSizes) {
  const TypeVector table[] = {{"BOOL", 1, 1},          {"UINT8", 1, 1},   {"UINT32", 1, 4},
                              {"UINT64", 1, 8},        {"INT32", 1, 4},   {"DOUBLE", 1, 8},
                              {"VECTOR3D", 3, 24},     {"VECTOR6D", 6, 48},
                              {"VECTOR6INT32", 6, 24}, {"VECTOR6UINT32", 6, 24}};
  for (const auto& t : table) {
    const auto type = rtde::ValueTypeOf(t.name);
    ASSERT_TRUE(type) << t.name;
    EXPECT_EQ(rtde::ValueCount(*type), t.count) << t.name;
    EXPECT_EQ(rtde::ValueBytes(*type), t.bytes) << t.name;
    EXPECT_STREQ(rtde::ValueTypeName(*type), t.name);
  }
  EXPECT_FALSE(rtde::ValueTypeOf("NOT_FOUND"));
  EXPECT_EQ(rtde::OutputType("actual_q"), rtde::ValueType::kVector6d);
  EXPECT_EQ(rtde::OutputType("safety_mode"), rtde::ValueType::kInt32);
  EXPECT_EQ(rtde::OutputType("runtime_state"), rtde::ValueType::kUint32);
  EXPECT_FALSE(rtde::OutputType("actual_qq"));
}

TEST(UrRtde, ModesAreNamedAsTheDashboardNamesThem) {
  EXPECT_EQ(rtde::RobotModeName(7), "RUNNING");
  EXPECT_EQ(rtde::RobotModeName(3), "POWER_OFF");
  EXPECT_EQ(rtde::RobotModeName(-1), "NO_CONTROLLER");
  EXPECT_EQ(rtde::SafetyModeName(1), "NORMAL");
  EXPECT_EQ(rtde::SafetyModeName(3), "PROTECTIVE_STOP");
  EXPECT_EQ(rtde::SafetyModeName(7), "ROBOT_EMERGENCY_STOP");
  EXPECT_EQ(rtde::SafetyModeName(99), "");
  for (int mode = -1; mode <= 8; ++mode)
    EXPECT_EQ(rtde::RobotModeFromName(rtde::RobotModeName(mode)), mode);
  for (int mode = 1; mode <= 13; ++mode)
    EXPECT_EQ(rtde::SafetyModeFromName(rtde::SafetyModeName(mode)), mode);
}

TEST(UrFrames, RtdePackagesSplitAcrossReadsComeOutWhole) {
  const std::string stream = Hex("00 04 56 01  00 03 53  00 04 50 01");
  for (size_t cut = 0; cut <= stream.size(); ++cut) {
    FrameSplitter s(rtde::kFrames);
    std::vector<std::string> frames;
    std::string frame;
    s.Append(stream.substr(0, cut));
    while (s.Next(frame) == FrameSplitter::Status::kFrame) frames.push_back(frame);
    s.Append(stream.substr(cut));
    while (s.Next(frame) == FrameSplitter::Status::kFrame) frames.push_back(frame);
    ASSERT_EQ(frames.size(), 3u) << "cut at " << cut;
    EXPECT_EQ(frames[1], Hex("00 03 53"));
  }
  // A size below the header's 3 bytes: the framing is lost.
  FrameSplitter s(rtde::kFrames);
  s.Append(Hex("00 02 56"));
  std::string frame;
  int32_t bad = 0;
  EXPECT_EQ(s.Next(frame, &bad), FrameSplitter::Status::kBadSize);
  EXPECT_EQ(bad, 2);
}

// --- Primary / secondary --------------------------------------------------------------------

TEST(UrPrimary, TheVersionMessageDecodesAndEncodesToTheTablesBytes) {
  const std::string frame = Hex(
      "00 00 00 2E  14"                           // size 46, type 20 (robot message)
      "00 00 00 00 00 0F 42 40  FF  03"           // timestamp 1e6 µs, source -1, type 3
      "09  55 52 43 6F 6E 74 72 6F 6C"            // "URControl"
      "05  0B  00 00 00 01  00 01 A7 1E"          // 5.11, bugfix 1, build 108318
      "4E 6F 76 20 30 33 20 32 30 32 31");        // "Nov 03 2021"
  std::string why;
  const auto m = primary::Decode(frame, &why);
  ASSERT_TRUE(m) << why;
  ASSERT_TRUE(m->version);
  EXPECT_EQ(m->version->project, "URControl");
  EXPECT_EQ(m->version->major, 5);
  EXPECT_EQ(m->version->minor, 11);
  EXPECT_EQ(m->version->bugfix, 1);
  EXPECT_EQ(m->version->build, 108318);
  EXPECT_EQ(m->version->build_date, "Nov 03 2021");
  EXPECT_EQ(primary::EncodeVersion(1000000, *m->version), frame);
}

// A robot state message as the Client Interface's tables lay it out: robot mode data (46
// bytes, CB3), joint data (251), KinematicsInfo (225), and a sub-package type the codec does
// not model (masterboard data, 3), which it must skip.
std::string RobotStateBytes(const primary::KinematicsInfo& k, bool protective) {
  Be mode;
  mode.U32(46).U8(0).U64(123456789);
  for (const bool flag : {true, true, true, false, protective, true, false}) mode.U8(flag);
  mode.U8(7).U8(0).D(1.0).D(0.5).D(1.0);
  Be joints;
  joints.U32(251).U8(1);
  for (int j = 0; j < 6; ++j) {
    joints.D(0.1 * j).D(0.1 * j + 0.01).D(-0.2 * j).F(1.f).F(48.f).F(30.f).F(0.f).U8(253);
  }
  Be kin;
  kin.U32(225).U8(5);
  for (const uint32_t c : k.checksum) kin.U32(c);
  for (const auto* table : {&k.dh_theta, &k.dh_a, &k.dh_d, &k.dh_alpha})
    for (const double v : *table) kin.D(v);
  kin.U32(k.calibration_status);
  Be other;
  other.U32(9).U8(3).U32(0xdeadbeef);
  const std::string body = mode.bytes + joints.bytes + other.bytes + kin.bytes;
  Be all;
  all.U32(static_cast<uint32_t>(5 + body.size())).U8(16);
  return all.bytes + body;
}

primary::KinematicsInfo Ur10Kinematics() {
  primary::KinematicsInfo k;
  k.checksum = {0x1a2b3c4du, 2u, 3u, 4u, 5u, 0xffffffffu};
  k.dh_a = {0, -0.612, -0.5723, 0, 0, 0};
  k.dh_d = {0.1273, 0, 0, 0.163941, 0.1157, 0.0922};
  k.dh_alpha = {M_PI / 2, 0, 0, M_PI / 2, -M_PI / 2, 0};
  k.dh_theta = {1e-4, -2e-4, 0, 0, 3e-5, 0};
  k.calibration_status = 2;
  return k;
}

TEST(UrPrimary, ARobotStateGivesModeJointsAndKinematicsAndSkipsTheRest) {
  const primary::KinematicsInfo k = Ur10Kinematics();
  std::string why;
  const auto m = primary::Decode(RobotStateBytes(k, true), &why);
  ASSERT_TRUE(m) << why;
  ASSERT_TRUE(m->mode && m->joints && m->kinematics);
  EXPECT_EQ(m->mode->timestamp, 123456789u);
  EXPECT_TRUE(m->mode->protective_stopped);
  EXPECT_FALSE(m->mode->emergency_stopped);
  EXPECT_EQ(m->mode->robot_mode, 7);
  EXPECT_DOUBLE_EQ(m->mode->speed_scaling, 0.5);
  EXPECT_DOUBLE_EQ(m->joints->q_actual[5], 0.5);
  EXPECT_DOUBLE_EQ(m->joints->q_target[2], 0.21);
  EXPECT_DOUBLE_EQ(m->joints->qd_actual[3], -0.6000000000000001);
  EXPECT_EQ(m->kinematics->checksum, k.checksum);
  EXPECT_EQ(m->kinematics->dh_d, k.dh_d);
  EXPECT_EQ(m->kinematics->calibration_status, 2u);
  // As armsig keeps it: mm, and the checksums as hex words.
  const ControllerKinematics kept = m->kinematics->ToKinematics();
  EXPECT_EQ(kept.checksum, "1a2b3c4d-00000002-00000003-00000004-00000005-ffffffff");
  EXPECT_DOUBLE_EQ(kept.dh_a_mm[1], -612.0);
  EXPECT_DOUBLE_EQ(kept.dh_d_mm[3], 163.941);
  EXPECT_DOUBLE_EQ(kept.dh_theta_rad[1], -2e-4);
}

TEST(UrPrimary, OurRobotStateDecodesToWhatWasEncoded) {
  primary::RobotState s;
  s.mode.emergency_stopped = true;
  s.mode.robot_mode = 3;
  for (int j = 0; j < 6; ++j) s.joints.q_actual[j] = -1.0 + 0.25 * j;
  s.kinematics = Ur10Kinematics();
  for (const bool e_series : {false, true}) {
    s.e_series = e_series;
    std::string why;
    const auto m = primary::Decode(primary::EncodeRobotState(s), &why);
    ASSERT_TRUE(m) << why;
    EXPECT_TRUE(m->mode->emergency_stopped);
    EXPECT_EQ(m->mode->robot_mode, 3);
    EXPECT_EQ(m->joints->q_actual, s.joints.q_actual);
    EXPECT_EQ(m->kinematics->dh_alpha, s.kinematics->dh_alpha);
  }
}

TEST(UrPrimary, ASubPackageLongerThanItsMessageOrShorterThanItsTableIsRefused) {
  std::string frame = RobotStateBytes(Ur10Kinematics(), false);
  std::string why;
  // The first sub-package (robot mode data) claims 4,000 bytes.
  std::string longer = frame;
  longer[5] = 0;
  longer[6] = 0;
  longer[7] = 0x0f;
  longer[8] = static_cast<char>(0xa0);
  EXPECT_FALSE(primary::Decode(longer, &why));
  EXPECT_NE(why.find("4000"), std::string::npos) << why;
  // Robot mode data of 20 bytes: shorter than its table.
  Be shorter;
  shorter.U32(5 + 20).U8(16).U32(20).U8(0);
  for (int i = 0; i < 15; ++i) shorter.U8(0);
  EXPECT_FALSE(primary::Decode(shorter.bytes, &why));
  EXPECT_NE(why.find("too short"), std::string::npos) << why;
}

// --- Dashboard -------------------------------------------------------------------------------

TEST(UrDashboard, AnswersAreReadAsTheDocumentsWriteThem) {
  EXPECT_EQ(dashboard::Field("Robotmode: RUNNING", "Robotmode"), "RUNNING");
  EXPECT_EQ(dashboard::Field("Safetystatus: PROTECTIVE_STOP\r", "Safetystatus"), "PROTECTIVE_STOP");
  EXPECT_FALSE(dashboard::Field("Safetymode: NORMAL", "Robotmode"));
  EXPECT_FALSE(dashboard::Field("Robotmode:", "Robotmode"));
  EXPECT_EQ(dashboard::Boolean("true"), true);
  EXPECT_EQ(dashboard::Boolean("false"), false);
  EXPECT_FALSE(dashboard::Boolean("Could not understand: 'is in remote control'"));
  EXPECT_TRUE(dashboard::NotUnderstood("Could not understand: 'get serial number'"));
  const auto e = dashboard::PolyscopeVersion("URSoftware 5.11.1.108318 (Nov 03 2021)");
  ASSERT_TRUE(e);
  EXPECT_EQ(e->Text(), "5.11.1.108318");
  EXPECT_TRUE(e->AtLeast(5, 6));
  EXPECT_FALSE(e->AtLeast(5, 12));
  const auto cb3 = dashboard::PolyscopeVersion("URSoftware 3.15.7.106331 (Jun 01 2021)");
  ASSERT_TRUE(cb3);
  EXPECT_FALSE(cb3->ESeries());
  EXPECT_TRUE(cb3->AtLeast(3, 12));
  EXPECT_FALSE(dashboard::PolyscopeVersion("Robotmode: RUNNING"));
}

// --- URScript ---------------------------------------------------------------------------------

TEST(UrScript, MovejIsWrittenWithEveryDigitAMoveNeeds) {
  Eigen::VectorXd q(6);
  q << 0.1, -1.5707963267949, 2.0, 0.0, -3.25, 1e-9;
  EXPECT_EQ(MoveJ(q, 1.4, 1.05),
            "movej([0.100000000000, -1.570796326795, 2.000000000000, 0.000000000000, "
            "-3.250000000000, 0.000000001000], a=1.4, v=1.05)\n");
  std::string why;
  const auto back = ParseMove(MoveJ(q, 1.4, 1.05), &why);
  ASSERT_TRUE(back) << why;
  EXPECT_FALSE(back->linear);
  EXPECT_LT((back->joints_rad - q).cwiseAbs().maxCoeff(), 1e-12);
  EXPECT_DOUBLE_EQ(back->a, 1.4);
  EXPECT_DOUBLE_EQ(back->v, 1.05);
  // movel to joint positions: the same list, a in m/s², v in m/s.
  EXPECT_EQ(MoveL(q, 1.2, 0.25),
            "movel([0.100000000000, -1.570796326795, 2.000000000000, 0.000000000000, "
            "-3.250000000000, 0.000000001000], a=1.2, v=0.25)\n");
  const auto linear = ParseMove(MoveL(q, 1.2, 0.25), &why);
  ASSERT_TRUE(linear) << why;
  EXPECT_TRUE(linear->linear);
  EXPECT_LT((linear->joints_rad - q).cwiseAbs().maxCoeff(), 1e-12);
  EXPECT_DOUBLE_EQ(linear->a, 1.2);
  EXPECT_DOUBLE_EQ(linear->v, 0.25);
  // movec: the via point's joints, then the target's.
  const Eigen::VectorXd via = q * 0.5;
  const auto circular = ParseMove(MoveC(via, q, 1.2, 0.25), &why);
  ASSERT_TRUE(circular) << why;
  EXPECT_TRUE(circular->circular);
  EXPECT_TRUE(circular->linear);
  ASSERT_TRUE(circular->via_rad);
  EXPECT_LT((*circular->via_rad - via).cwiseAbs().maxCoeff(), 1e-12);
  EXPECT_LT((circular->joints_rad - q).cwiseAbs().maxCoeff(), 1e-12);
  EXPECT_EQ(MoveC(via, q, 1.2, 0.25).rfind("movec([0.050000000000, ", 0), 0u);
}

struct ScriptVector {
  const char* line;
  bool ok;
  double a, v;
  const char* why;  // a part of the refusal
  bool linear = false;
};

TEST(UrScript, OnlyAMovejOrMovelWithSixJointsIsAMove) {
  const ScriptVector table[] = {
      {"movej([0,0,0,0,0,0])", true, 1.4, 1.05, ""},
      {"movel([0,0,0,0,0,0])", true, 1.2, 0.25, "", true},  // URScript's movel defaults
      {"movel([1,2,3,4,5,6], v=0.1, a=0.5)", true, 0.5, 0.1, "", true},
      {"movel([1,2,3,4,5], v=0.1)", false, 0, 0, "5 joints"},
      {"  movej([1, 2, 3, 4, 5, 6], v=0.5, a=2)  ", true, 2.0, 0.5, ""},
      {"movej([1,2,3,4,5,6], a=1, v=1, r=0.01)", true, 1.0, 1.0, ""},
      {"movej([1,2,3,4,5], a=1, v=1)", false, 0, 0, "5 joints"},
      {"movej([1,2,3,4,5,x], a=1, v=1)", false, 0, 0, "joint 6"},
      {"movej([1,2,3,4,5,6], a=-1)", false, 0, 0, "a is no positive"},
      {"movej([1,2,3,4,5,6], t=2)", false, 0, 0, "unsupported argument t"},
      {"movel(p[0,0,0,0,0,0])", false, 0, 0, "movel's first argument is no joint list"},
      {"movep([0,0,0,0,0,0])", false, 0, 0, "not a movej(...), movel(...) or movec(...)"},
      {"movec([1,2,3,4,5,6], [2,3,4,5,6,7], v=0.1)", true, 1.2, 0.1, "", true},
      {"movec([1,2,3,4,5,6], v=0.1)", false, 0, 0, "movec's second argument is no joint list"},
      {"movec([1,2,3,4,5,6], [2,3,4,5,6])", false, 0, 0, "5 joints"},
      {"movej(p[0,0,0,0,0,0])", false, 0, 0, "no joint list"},
      {"movej([1,2,3,4,5,6]", false, 0, 0, "no closing ')'"},
  };
  for (const auto& t : table) {
    std::string why;
    const auto move = ParseMove(t.line, &why);
    EXPECT_EQ(move.has_value(), t.ok) << t.line;
    if (move) {
      EXPECT_EQ(move->linear, t.linear) << t.line;
      EXPECT_DOUBLE_EQ(move->a, t.a) << t.line;
      EXPECT_DOUBLE_EQ(move->v, t.v) << t.line;
    } else {
      EXPECT_NE(why.find(t.why), std::string::npos) << t.line << ": " << why;
    }
  }
}

TEST(UrScript, MovejTakesATrapezoidOnTheLeadingJoint) {
  // v²/a = 1.05²/1.4 = 0.7875 rad: shorter turns never reach v (a triangle, 2·√(d/a)).
  EXPECT_NEAR(MoveJDuration(0.1, 1.4, 1.05), 2.0 * std::sqrt(0.1 / 1.4), 1e-12);
  EXPECT_NEAR(MoveJDuration(0.7875, 1.4, 1.05), 1.5, 1e-12);  // just reaches v: 2·v/a
  EXPECT_NEAR(MoveJDuration(3.0, 1.4, 1.05), 3.0 / 1.05 + 0.75, 1e-12);
  EXPECT_NEAR(MoveJDuration(-3.0, 1.4, 1.05), 3.0 / 1.05 + 0.75, 1e-12);
  EXPECT_EQ(MoveJDuration(0.0, 1.4, 1.05), 0.0);
}

}  // namespace
}  // namespace armsig::robots::ur
