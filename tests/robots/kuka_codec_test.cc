#include "robots/kuka_codec.h"

#include <gtest/gtest.h>

#include <fstream>
#include <regex>
#include <set>
#include <sstream>

namespace armsig::robots::kuka {
using instruments::FrameSplitter;
namespace {

std::string Hex(std::initializer_list<int> bytes) {
  std::string out;
  for (int b : bytes) out.push_back(static_cast<char>(b));
  return out;
}

// The sample messages of the C3 Bridge Interface protocol document (version 1 revision 5,
// §3.5.1 and §3.5.2), byte for byte: the same frames KukaVarProxy exchanges.
struct SampleFrame {
  const char* what;
  Request request;
  std::string request_bytes;
  Response response;
  std::string response_bytes;
};

TEST(KukaCodec, EncodesAndDecodesTheProtocolDocumentsSamples) {
  const SampleFrame samples[] = {
      {"read $ACCU_STATE",
       {256, MessageType::kRead, "$ACCU_STATE", ""},
       Hex({0x01, 0x00, 0x00, 0x0E, 0x00, 0x00, 0x0B, 0x24, 0x41, 0x43, 0x43, 0x55, 0x5F, 0x53,
            0x54, 0x41, 0x54, 0x45}),
       {256, 0, "#CHARGE_OK", 1, true},
       Hex({0x01, 0x00, 0x00, 0x10, 0x00, 0x00, 0x0A, 0x23, 0x43, 0x48, 0x41, 0x52, 0x47, 0x45,
            0x5F, 0x4F, 0x4B, 0x00, 0x01, 0x01})},
      {"write $OV_PRO = 35",
       {256, MessageType::kWrite, "$OV_PRO", "35"},
       Hex({0x01, 0x00, 0x00, 0x0E, 0x01, 0x00, 0x07, 0x24, 0x4F, 0x56, 0x5F, 0x50, 0x52, 0x4F,
            0x00, 0x02, 0x33, 0x35}),
       {256, 1, "35", 1, true},
       Hex({0x01, 0x00, 0x00, 0x08, 0x01, 0x00, 0x02, 0x33, 0x35, 0x00, 0x01, 0x01})},
  };
  for (const auto& s : samples) {
    SCOPED_TRACE(s.what);
    EXPECT_EQ(EncodeRequest(s.request), s.request_bytes);
    EXPECT_EQ(EncodeResponse(s.response), s.response_bytes);
    const auto request = DecodeRequest(s.request_bytes);
    ASSERT_TRUE(request.request) << request.why;
    EXPECT_EQ(request.request->tag, s.request.tag);
    EXPECT_EQ(request.request->name, s.request.name);
    EXPECT_EQ(request.request->value, s.request.value);
    const auto response = DecodeResponse(s.response_bytes);
    ASSERT_TRUE(response.response) << response.why;
    EXPECT_EQ(response.response->tag, s.response.tag);
    EXPECT_EQ(response.response->type, s.response.type);
    EXPECT_EQ(response.response->value, s.response.value);
    EXPECT_TRUE(response.response->success);
  }
}

// KukaVarProxy's answer when CrossComm fails (basMain.bas readMsg): an empty value and the
// one-byte status block 00 01 00.
TEST(KukaCodec, DecodesKukaVarProxysFailure) {
  const auto r = DecodeResponse(Hex({0x00, 0x07, 0x00, 0x06, 0x00, 0x00, 0x00, 0x00, 0x01, 0x00}));
  ASSERT_TRUE(r.response) << r.why;
  EXPECT_EQ(r.response->tag, 7);
  EXPECT_TRUE(r.response->value.empty());
  EXPECT_FALSE(r.response->success);
}

TEST(KukaCodec, RefusesMalformedFramesSayingWhy) {
  const struct {
    const char* what;
    std::string frame;
    const char* why;
  } cases[] = {
      {"too short", Hex({0x00, 0x01, 0x00, 0x02, 0x00, 0x00}), "at least 10"},
      {"length field lies", Hex({0x00, 0x01, 0x00, 0x09, 0x00, 0x00, 0x00, 0x00, 0x01, 0x01}),
       "length field 9 but 6 bytes"},
      {"value runs past the end",
       Hex({0x00, 0x01, 0x00, 0x06, 0x00, 0x00, 0x05, 0x00, 0x01, 0x01}), "runs past"},
      {"no room for the footer",
       Hex({0x00, 0x01, 0x00, 0x07, 0x00, 0x00, 0x02, 0x41, 0x42, 0x00, 0x01}), "3-byte footer"},
  };
  for (const auto& c : cases) {
    SCOPED_TRACE(c.what);
    const auto r = DecodeResponse(c.frame);
    EXPECT_FALSE(r.response);
    EXPECT_NE(r.why.find(c.why), std::string::npos) << r.why;
  }
  EXPECT_NE(DecodeRequest(Hex({0, 1, 0, 4, 2, 0, 1, 0x41})).why.find("message type 2"),
            std::string::npos);
  EXPECT_NE(DecodeRequest(Hex({0, 1, 0, 5, 0, 0, 1, 0x41, 0x42})).why.find("1 bytes after"),
            std::string::npos);
  EXPECT_THROW(EncodeRequest({1, MessageType::kRead, "", ""}), std::invalid_argument);
  EXPECT_THROW(EncodeRequest({1, MessageType::kRead, std::string(300, 'A'), ""}),
               std::invalid_argument);
}

TEST(KukaCodec, SplitterJoinsSplitFramesAndDropsALostFraming) {
  const std::string a = EncodeResponse({1, 0, "TRUE", 1, true});
  const std::string b = EncodeResponse({2, 0, "{E6AXIS: A1 1.0}", 1, true});
  FrameSplitter s(kResponseFrames);
  std::string frame;
  s.Append(a.substr(0, 3));
  EXPECT_EQ(s.Next(frame), FrameSplitter::Status::kNeedMore);
  s.Append(a.substr(3) + b.substr(0, 9));
  ASSERT_EQ(s.Next(frame), FrameSplitter::Status::kFrame);
  EXPECT_EQ(frame, a);
  EXPECT_EQ(s.Next(frame), FrameSplitter::Status::kNeedMore);
  s.Append(b.substr(9));
  ASSERT_EQ(s.Next(frame), FrameSplitter::Status::kFrame);
  EXPECT_EQ(frame, b);
  // A length below a response's minimum, and one beyond the maximum.
  for (const std::string& garbage : {Hex({0x41, 0x42, 0x00, 0x02, 0x7E}),
                                     Hex({0x41, 0x42, 0xFF, 0xFF, 0x7E})}) {
    s.Append(garbage);
    int32_t size = 0;
    EXPECT_EQ(s.Next(frame, &size), FrameSplitter::Status::kBadSize);
    EXPECT_EQ(s.buffered(), 0u);
    EXPECT_TRUE(size == 6 || size == 65539) << size;
  }
  // A request splitter takes a request's shorter minimum.
  FrameSplitter requests(kRequestFrames);
  requests.Append(EncodeRequest({9, MessageType::kRead, "X", ""}));
  EXPECT_EQ(requests.Next(frame), FrameSplitter::Status::kFrame);
}

TEST(KrlValues, ParsesScalarsAsShowVarGivesThem) {
  EXPECT_EQ(ParseBool("TRUE"), true);
  EXPECT_EQ(ParseBool(" false "), false);
  EXPECT_FALSE(ParseBool("1"));
  EXPECT_EQ(ParseInt("-42"), -42);
  EXPECT_EQ(ParseInt("2147483647"), 2147483647);
  EXPECT_FALSE(ParseInt("2147483648"));  // beyond KRL's 32-bit INT
  EXPECT_FALSE(ParseInt("4.5"));
  EXPECT_FALSE(ParseInt(""));
  EXPECT_DOUBLE_EQ(*ParseReal("-1.52587891E-05"), -1.52587891e-05);
  EXPECT_DOUBLE_EQ(*ParseReal("89.9999466"), 89.9999466);
  for (const char* bad : {"nan", "inf", "0x10", "1.0.0", "", "1e999"}) EXPECT_FALSE(ParseReal(bad)) << bad;
  EXPECT_EQ(ParseEnum("#AUT"), "AUT");
  EXPECT_EQ(ParseEnum("#p_active"), "P_ACTIVE");
  EXPECT_FALSE(ParseEnum("AUT"));
  EXPECT_EQ(ParseString("\"KR 16-2 \""), "KR 16-2");
  EXPECT_EQ(ParseString("\"\""), "");
  EXPECT_FALSE(ParseString("KR 16"));
}

// Values as KR C4 controllers show them (the $AXIS_ACT and $POS_ACT samples in public
// KukaVarProxy clients).
TEST(KrlValues, ParsesAxesAndPosesOfStructures) {
  const auto q = ParseAxes(
      "{E6AXIS: A1 0.0, A2 -90.0, A3 90.0, A4 0.0, A5 0.0, A6 0.0, E1 0.0, E2 0.0, E3 0.0, E4 "
      "0.0, E5 0.0, E6 0.0}",
      6);
  ASSERT_TRUE(q);
  EXPECT_EQ(*q, (Eigen::VectorXd(6) << 0, -90, 90, 0, 0, 0).finished());
  const auto p = ParsePose(
      "{E6POS: X 1339.90503, Y 15.9216757, Z 1787.32227, A 0.0, B 89.9999466, C -0.680795908, "
      "S 6, T 19, E1 0.0, E2 0.0, E3 0.0, E4 0.0, E5 0.0, E6 0.0}");
  ASSERT_TRUE(p);
  EXPECT_DOUBLE_EQ((*p)(0), 1339.90503);
  EXPECT_DOUBLE_EQ((*p)(5), -0.680795908);
  // Without the type, components in another order, lower case.
  const auto q2 = ParseAxes("{a2 -1.5E+01,A1 3}", 2);
  ASSERT_TRUE(q2);
  EXPECT_EQ(*q2, Eigen::Vector2d(3, -15));

  const struct {
    const char* text;
    const char* why;
  } bad[] = {
      {"{E6POS: X 1.0, Y 2.0}", "E6POS where an E6AXIS"},
      {"{E6AXIS: A1 0.0, A2 1.0}", "no component A3"},
      {"{E6AXIS: A1 0.0, A1 1.0, A2 0, A3 0}", "A1 given twice"},
      {"{E6AXIS: A1 x, A2 0, A3 0}", "A1 is 'x', no number"},
      {"E6AXIS: A1 0.0", "no structure"},
      {"{E6AXIS: A1 0.0,, A2 1, A3 2}", "is not 'NAME value'"},
      {"{}", "without components"},
  };
  for (const auto& c : bad) {
    std::string why;
    EXPECT_FALSE(ParseAxes(c.text, 3, &why)) << c.text;
    EXPECT_NE(why.find(c.why), std::string::npos) << c.text << ": " << why;
  }
}

TEST(KrlValues, FormatsWhatTheControllerReadsBackExactly) {
  EXPECT_EQ(FormatReal(-90.0), "-90.0");
  EXPECT_EQ(FormatReal(1339.90503), "1339.90503");
  EXPECT_EQ(FormatReal(-1.52587891e-05), "-1.52587891E-05");
  EXPECT_EQ(FormatAxes(Eigen::Vector3d(10.25, -90, 0.5)), "{E6AXIS: A1 10.25, A2 -90.0, A3 0.5}");
  // A target written and read back keeps 9 significant digits: 0.36 µdeg at 100°.
  const Eigen::VectorXd q = (Eigen::VectorXd(6) << 12.3456789, -91.2345678, 100.000001, -0.1,
                             170.987654, -350.0)
                                .finished();
  const auto back = ParseAxes(FormatAxes(q), 6);
  ASSERT_TRUE(back);
  EXPECT_LT((*back - q).cwiseAbs().maxCoeff(), 1e-6);
}

TEST(KrlDeclarations, ParsesDataListLines) {
  const auto decls = ParseDeclarations(
      ";FOLD x\n"
      "DECL INT ARMSIG_CMD=0 ; a comment\n"
      "  decl global e6axis T={A1 0.0,A2 -90.0}\n"
      "DECL CHAR NAME[16]\n"
      "; DECL INT COMMENTED=1\n"
      "DECL CONST REAL K = 2.5\n");
  ASSERT_EQ(decls.size(), 4u);
  EXPECT_EQ(decls[0].type, "INT");
  EXPECT_EQ(decls[0].name, "ARMSIG_CMD");
  EXPECT_EQ(decls[0].value, "0");
  EXPECT_EQ(decls[0].line, 2);
  EXPECT_EQ(decls[1].type, "E6AXIS");
  EXPECT_EQ(decls[1].value, "{A1 0.0,A2 -90.0}");
  EXPECT_EQ(decls[2].name, "NAME[]");
  EXPECT_EQ(decls[3].value, "2.5");
  EXPECT_THROW(ParseDeclarations("DECL INT X 5\n"), std::invalid_argument);
  EXPECT_THROW(ParseDeclarations("\nDECL\n"), std::invalid_argument);
}

std::string ReadFile(const std::string& path) {
  std::ifstream in(path);
  EXPECT_TRUE(in) << path;
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

// The contract the driver and the simulator follow is the one the shipped KRL files declare
// and use: every global the driver names is declared in config_globals.dat with its type (and
// nothing else is), ARMSIG.src writes every result code the driver knows and no other, and
// sets the contract version the driver expects.
TEST(KukaContract, ShippedKrlFilesDeclareAndUseWhatTheDriverNames) {
  const std::string dir = std::string(ARMSIG_SOURCE_DIR) + "/controllers/kuka/";
  const auto decls = ParseDeclarations(ReadFile(dir + "config_globals.dat"));
  ASSERT_EQ(decls.size(), std::size(contract::kGlobals));
  for (size_t i = 0; i < decls.size(); ++i) {
    EXPECT_EQ(decls[i].name, contract::kGlobals[i].name);
    EXPECT_EQ(decls[i].type, contract::kGlobals[i].type) << decls[i].name;
    if (decls[i].type != "CHAR") {  // a CHAR array gets its text by assignment, not in its DECL
      EXPECT_FALSE(decls[i].value.empty()) << decls[i].name << " has no initial value";
    }
  }
  // The programs' statements: every line without its comment (';' to the line's end). The
  // move server uses the contract's globals, the submit interpreter's part the runner's.
  const std::string src = std::regex_replace(ReadFile(dir + "ARMSIG.src"), std::regex(";[^\n]*"), "");
  const std::string sps = std::regex_replace(ReadFile(dir + "ARMSIG_SPS.sub"), std::regex(";[^\n]*"), "");
  EXPECT_NE(src.find(std::string("DEF ") + contract::kProgram + "( )"), std::string::npos);
  for (const auto& g : contract::kGlobals) {
    std::string name = g.name;
    const bool runner = name.rfind("ARMSIG_RUN_", 0) == 0;
    EXPECT_NE((runner ? sps : src).find(name), std::string::npos)
        << name << " unused in " << (runner ? "ARMSIG_SPS.sub" : "ARMSIG.src");
  }
  EXPECT_NE(sps.find("CWRITE($CMD, ARMSIG_STAT, ARMSIG_MODE, \"RUN /R1/%s()\", ARMSIG_RUN_NAME[])"), std::string::npos);

  std::set<int> written;
  const std::regex result(R"(ARMSIG_RESULT\s*=\s*(\d+))");
  for (auto it = std::sregex_iterator(src.begin(), src.end(), result); it != std::sregex_iterator();
       ++it)
    written.insert(std::stoi((*it)[1]));
  EXPECT_EQ(written, std::set<int>(std::begin(contract::kResults), std::end(contract::kResults)));
  for (int r : contract::kResults)
    EXPECT_EQ(contract::ResultMeaning(r).find("not one of"), std::string::npos);

  std::smatch version;
  ASSERT_TRUE(std::regex_search(src, version, std::regex(R"(ARMSIG_VERSION\s*=\s*(\d+))")));
  EXPECT_EQ(std::stoi(version[1]), contract::kVersion);
  // The exact stop: no approximated PTP in the program, the advance run held.
  EXPECT_EQ(src.find("C_PTP"), std::string::npos);
  EXPECT_NE(src.find("$ADVANCE = 0"), std::string::npos);
}

}  // namespace
}  // namespace armsig::robots::kuka
