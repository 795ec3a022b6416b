// The Robot Web Services codec: the manual's example pages (3HAC050973-001 Rev. M) and the
// JSON forms RWS 1.0 (?json=1) and RWS 2.0 (hal+json) give the same resources; every request
// of both generations is the path and body the manual / ABB's OmniCore SDK name; RAPID
// literals read and write back; what is not an RWS page is refused with DecodeError.
#include "robots/rws_codec.h"

#include <gtest/gtest.h>

namespace armsig::robots::rws {
namespace {

// Rev. M, "Get Controller State", example response (as printed).
constexpr const char* kCtrlStateXhtml = R"(<?xml version="1.0" encoding="UTF-8"?>
<html xmlns="http://www.w3.org/1999/xhtml">
<head>
<title>panel</title>
<base href= "http://localhost/rw/panel/ctrlstate/" />
</head>
<body>
<div class="state">
<a href= "" rel="self"/>
<a href= "?action=show" rel="action"/>
<ul>
<li class="pnl-ctrlstate" title="ctrlstate">
<span class="ctrlstate">motoron</span>
</li>
</ul>
</div>
</body>
</html>)";

// Rev. M, "Get robot type": two robots.
constexpr const char* kRobotTypeXhtml = R"(<?xml version="1.0" encoding="UTF-8"?>
<html xmlns="http://www.w3.org/1999/xhtml"><head><title>system</title>
<base href="http://localhost/rw/system/robottype/"/></head><body><div class="state">
<a href="" rel="self"/><ul>
<li class="sys-robottype" title="1"><span class="robot-type">IRB 120-3/0.6</span></li>
<li class="sys-robottype" title="2"><span class="robot-type">IRB 140T-5/0.8 Type C</span></li>
</ul></div></body></html>)";

// Rev. M, "System Information" (options shortened).
constexpr const char* kSystemXhtml = R"(<?xml version="1.0" encoding="UTF-8"?>
<html xmlns="http://www.w3.org/1999/xhtml"><head><title>system</title>
<base href="http://localhost/rw/system/"/></head><body><div class="state"><a href="" rel="self"/>
<ul><li class="sys-system-li" title="system">
<span class="major">6</span><span class="minor">05</span><span class="build">0047</span>
<span class="name">6.05.0047</span><span class="rwversion">6.05.0047</span>
<span class="sysid">{14C798C8-3C47-4E4C-8CD4-040EC9483A10}</span>
<span class="starttm">2016-12-09 T 17:47:42</span>
<span class="rwversionname">6.05.00.00 Internal build 0047</span></li>
<li class="sys-options-li" title="options"><a href="options" rel="self" /><ul>
<li class="sys-option-li" title="0"><span class="option">RobotWare Base</span></li>
</ul></li></ul></div></body></html>)";

// A refused request's body (the status div both generations emit).
constexpr const char* kErrorXhtml = R"(<?xml version="1.0" encoding="UTF-8"?>
<html xmlns="http://www.w3.org/1999/xhtml"><head><title>Error</title></head><body>
<div class="status"><span class="code">-1073445859</span>
<span class="msg">The user does not have required mastership &amp; must ask</span></div>
</body></html>)";

// The mechanical unit's jointtarget as RWS 1.0 ?json=1 and RWS 2.0 hal+json carry it.
constexpr const char* kJointsJson1 =
    R"({"_links":{"base":{"href":"http://localhost/rw/motionsystem/mechunits/ROB_1/"}},)"
    R"("_embedded":{"_state":[{"_type":"ms-jointtarget","_title":"ROB_1","rax_1":"1.1",)"
    R"("rax_2":"2.2","rax_3":"3.3","rax_4":"4.4","rax_5":"-5.5","rax_6":"-6.6","eax_a":"9E+09"}]}})";
constexpr const char* kJointsHal =
    R"({ "_links" : { "base" : { "href" : "https://127.0.0.1:5466/rw/motionsystem/mechunits/ROB_1/jointtarget/" }, "self" : { "href" : "" } } ,"status" : {"code":294912} , "state" : [ { "_type" : "ms-jointtarget", "_title" : "ROB_1", "rax_1" : "10", "rax_2" : "15", "rax_3" : "-10", "rax_4" : "20", "rax_5" : "30", "rax_6" : "45", "eax_a" : "0" } ]})";

TEST(RwsCodec, ReadsTheManualsExamplePages) {
  EXPECT_EQ(DecodeControllerState(ParseXhtml(kCtrlStateXhtml)), ControllerState::kMotorsOn);
  EXPECT_EQ(DecodeRobotTypes(ParseXhtml(kRobotTypeXhtml)),
            (std::vector<std::string>{"IRB 120-3/0.6", "IRB 140T-5/0.8 Type C"}));
  const SystemInfo s = DecodeSystemInfo(ParseXhtml(kSystemXhtml));
  EXPECT_EQ(s.rwversion, "6.05.0047");
  EXPECT_EQ(s.rwversionname, "6.05.00.00 Internal build 0047");
  EXPECT_EQ(s.sysid, "{14C798C8-3C47-4E4C-8CD4-040EC9483A10}");
  const Document error = ParseXhtml(kErrorXhtml);
  ASSERT_TRUE(error.status);
  EXPECT_EQ(error.status->code, code::kNoMastership);
  EXPECT_EQ(error.status->message, "The user does not have required mastership & must ask");
}

TEST(RwsCodec, JsonOfBothGenerationsGivesTheJoints) {
  const Eigen::VectorXd a = DecodeJointTargetDeg(Parse(kJointsJson1, "application/json"));
  EXPECT_EQ(a, (Eigen::VectorXd(6) << 1.1, 2.2, 3.3, 4.4, -5.5, -6.6).finished());
  const Document hal = Parse(kJointsHal, "application/hal+json;v=2.0");
  EXPECT_EQ(DecodeJointTargetDeg(hal), (Eigen::VectorXd(6) << 10, 15, -10, 20, 30, 45).finished());
  ASSERT_TRUE(hal.status);  // RWS 2.0 states a status on success too
  EXPECT_EQ(hal.status->code, 294912);
  // Error bodies: RWS 1.0 JSON nests the status in _embedded, RWS 2.0 puts it on top.
  EXPECT_EQ(ParseJson(R"({"_embedded":{"status":{"code":-1073414146,"msg":"x"}}})").status->code,
            code::kNotFound);
  EXPECT_EQ(ParseJson(R"({"status":{"code":"-1073442816","msg":"Symbol not found"}})")
                .status->code,
            code::kSymbolNotFound);
}

TEST(RwsCodec, EveryRepresentationWritesWhatItReads) {
  Document d;
  Resource inst;
  inst.type = "cfg-dt-instance-li";
  inst.title = "rob_1";
  Resource high{"cfg-ia-t-li", "robot_serial_number_high_part", {{"value", "4600"}}, {}};
  Resource low{"cfg-ia-t-li", "robot_serial_number_low_part", {{"value", " 501234"}}, {}};
  inst.children = {high, low};
  d.resources.push_back(inst);
  d.resources.push_back({"rap-data", "RAPID/T_ROB1/M/x", {{"value", "[1,\"<&>\"]"}}, {}});
  d.status = Status{-5, "a \"message\" & <more>"};
  for (Representation r : {Representation::kXhtml, Representation::kJson1,
                           Representation::kHalJson}) {
    const Document back = Parse(Format(d, r, "cfg", "http://h/rw/cfg/"), MediaType(r));
    EXPECT_EQ(DecodeRobotSerial(back), "4600-501234") << MediaType(r);
    EXPECT_EQ(DecodeSymbolValue(back), "[1,\"<&>\"]") << MediaType(r);
    ASSERT_TRUE(back.status) << MediaType(r);
    EXPECT_EQ(back.status->code, -5);
    EXPECT_EQ(back.status->message, "a \"message\" & <more>");
  }
}

TEST(RwsCodec, StatesAndModesByTheirWords) {
  const std::pair<const char*, ControllerState> states[] = {
      {"init", ControllerState::kInit},
      {"motoron", ControllerState::kMotorsOn},
      {"motoroff", ControllerState::kMotorsOff},
      {"guardstop", ControllerState::kGuardStop},
      {"emergencystop", ControllerState::kEmergencyStop},
      {"emergencystopreset", ControllerState::kEmergencyStopReset},
      {"sysfail", ControllerState::kSystemFailure}};
  for (const auto& [text, state] : states) {
    EXPECT_EQ(ControllerStateFromText(text), state);
    EXPECT_STREQ(Text(state), text);
  }
  for (const char* mode : {"INIT", "AUTO_CH", "MANF_CH", "MANR", "MANF", "AUTO", "UNDEF"}) {
    ASSERT_TRUE(OperationModeFromText(mode)) << mode;
    EXPECT_STREQ(Text(*OperationModeFromText(mode)), mode);
  }
  EXPECT_EQ(ExecutionStateFromText("running"), ExecutionState::kRunning);
  EXPECT_EQ(ExecutionStateFromText("stop"), ExecutionState::kStopped);
  EXPECT_FALSE(ControllerStateFromText("MOTORON"));
  Document unknown;
  unknown.resources.push_back({"pnl-ctrlstate", "ctrlstate", {{"ctrlstate", "flying"}}, {}});
  EXPECT_THROW(DecodeControllerState(unknown), DecodeError);
  EXPECT_THROW(DecodeOperationMode(unknown), DecodeError);  // no pnl-opmode at all
}

TEST(RwsCodec, RequestsOfBothGenerations) {
  const SymbolPath cmd{"T_ROB1", "ArmsigServer", "armsig_cmd"};
  struct Case {
    Request request;
    const char* method;
    const char* target;
    const char* body;
  };
  const Version v1 = Version::kRws1, v2 = Version::kRws2;
  const Case cases[] = {
      {GetControllerState(v1), "GET", "/rw/panel/ctrlstate", ""},
      {GetControllerState(v2), "GET", "/rw/panel/ctrl-state", ""},
      {GetOperationMode(v2), "GET", "/rw/panel/opmode", ""},
      {GetExecution(v1), "GET", "/rw/rapid/execution", ""},
      {GetIdentity(v2), "GET", "/ctrl/identity", ""},
      {GetRobotSerial(v1), "GET", "/rw/cfg/moc/ROBOT_SERIAL_NUMBER/instances", ""},
      {GetJointTarget(v2, "ROB_1"), "GET", "/rw/motionsystem/mechunits/ROB_1/jointtarget", ""},
      {GetSymbol(v1, cmd), "GET", "/rw/rapid/symbol/data/RAPID/T_ROB1/ArmsigServer/armsig_cmd", ""},
      {GetSymbol(v2, cmd), "GET", "/rw/rapid/symbol/RAPID/T_ROB1/ArmsigServer/armsig_cmd/data", ""},
      {SetSymbol(v1, cmd, "12"), "POST",
       "/rw/rapid/symbol/data/RAPID/T_ROB1/ArmsigServer/armsig_cmd?action=set", "value=12"},
      {SetSymbol(v2, cmd, "[[1,2],[3]]"), "POST",
       "/rw/rapid/symbol/RAPID/T_ROB1/ArmsigServer/armsig_cmd/data",
       "value=%5B%5B1%2C2%5D%2C%5B3%5D%5D"},
      {RequestMastership(v1), "POST", "/rw/mastership/rapid?action=request", ""},
      {RequestMastership(v2), "POST", "/rw/mastership/edit/request", ""},
      {ReleaseMastership(v2), "POST", "/rw/mastership/edit/release", ""},
      {StartExecution(v1), "POST", "/rw/rapid/execution?action=start",
       "regain=continue&execmode=continue&cycle=forever&condition=none&stopatbp=disabled&"
       "alltaskbytsp=false"},
      {StopExecution(v2), "POST", "/rw/rapid/execution/stop", "stopmode=stop&usetsp=normal"},
  };
  for (const Case& c : cases) {
    EXPECT_EQ(c.request.method, c.method) << c.target;
    EXPECT_EQ(c.request.target, c.target);
    EXPECT_EQ(c.request.body, c.body) << c.target;
  }
  EXPECT_EQ(TargetFor(GetExecution(v1), v1, Representation::kJson1), "/rw/rapid/execution?json=1");
  EXPECT_EQ(TargetFor(RequestMastership(v1), v1, Representation::kJson1),
            "/rw/mastership/rapid?action=request&json=1");
  EXPECT_EQ(TargetFor(GetExecution(v2), v2, Representation::kHalJson), "/rw/rapid/execution");
  EXPECT_STREQ(FormContentType(v2), "application/x-www-form-urlencoded;v=2.0");
  EXPECT_STREQ(AcceptHeader(Representation::kHalJson), "application/hal+json;v=2.0");
}

TEST(RwsCodec, RapidLiteralsReadAndWriteBack) {
  EXPECT_EQ(ParseRapidNum("9E+09"), 9e9);
  EXPECT_EQ(ParseRapidNum(" -1.5e2 "), -150.0);
  EXPECT_EQ(ParseRapidNum("+.5"), 0.5);
  EXPECT_EQ(FormatRapidNum(0.0), "0");
  EXPECT_EQ(FormatRapidNum(-0.0), "0");
  EXPECT_EQ(FormatRapidNum(12.0), "12");
  EXPECT_EQ(FormatRapidNum(9e9), "9E+09");
  const float f = 123.456789f;  // a controller's num: written exactly enough to come back
  EXPECT_EQ(static_cast<float>(ParseRapidNum(FormatRapidNum(f))), f);
  for (const char* bad : {"", "inf", "nan", "1e400", "1,5", "0x10", "--1", "1 2", "e5"}) {
    EXPECT_THROW(ParseRapidNum(bad), DecodeError) << bad;
  }
  const JointTarget t = ParseRapidJointTarget(
      "[[10.5,-20,30,0,45.25,-90],[9E+09,9E+09,9E+09,9E+09,9E+09,9E+09]]");
  EXPECT_EQ(t.robax_deg[4], 45.25);
  EXPECT_EQ(ParseRapidJointTarget(FormatRapidJointTarget(t)).robax_deg, t.robax_deg);
  for (const char* bad : {"[[1,2,3,4,5,6]]", "[[1,2,3,4,5],[1,2,3,4,5,6]]", "[[1,2,3,4,5,6],[1]]",
                          "[[1,2,3,4,5,6],[1,2,3,4,5,6]] x", "[[1,2,3,4,5,6],[1,2,3,4,5,6]"}) {
    EXPECT_THROW(ParseRapidJointTarget(bad), DecodeError) << bad;
  }
  const std::vector<double> q{1.0 / 3.0, -123.456789012345, 0, 1e-7};
  const std::vector<double> back = ParseRapidArray(FormatRapidArray(q));
  ASSERT_EQ(back.size(), q.size());
  for (size_t i = 0; i < q.size(); ++i) EXPECT_NEAR(back[i], q[i], 1e-14 * (1 + std::abs(q[i])));
  EXPECT_TRUE(ParseRapidArray(" [ ] ").empty());
  EXPECT_THROW(ParseRapidArray("[1,]"), DecodeError);
}

TEST(RwsCodec, FormsEncodeAndDecode) {
  EXPECT_EQ(FormEncode("a b&c=[1]~"), "a%20b%26c%3D%5B1%5D~");
  EXPECT_EQ(*FormDecode("a+b%26c%3d"), "a b&c=");
  EXPECT_FALSE(FormDecode("%"));
  EXPECT_FALSE(FormDecode("%4"));
  EXPECT_FALSE(FormDecode("%-1"));
  const auto form = ParseForm("value=%5B1%5D&json=1&empty=&flag");
  ASSERT_EQ(form.size(), 4u);
  EXPECT_EQ(form[0], (std::pair<std::string, std::string>{"value", "[1]"}));
  EXPECT_EQ(form[2].second, "");
  EXPECT_EQ(form[3], (std::pair<std::string, std::string>{"flag", ""}));
  EXPECT_THROW(ParseForm("a=%zz"), DecodeError);
}

TEST(RwsCodec, WhatIsNoRwsPageIsRefused) {
  std::string deep;
  for (int i = 0; i < 100; ++i) deep += "<div>";
  const std::string deep_json = std::string(100, '[') + std::string(100, ']');
  for (const std::string& bad : {std::string("<html><body>"), std::string("not xml at all"),
                                 deep, std::string("<li class=\"x\"><span></li>")}) {
    EXPECT_THROW(ParseXhtml(bad), DecodeError) << bad.substr(0, 40);
  }
  for (const std::string& bad :
       {std::string("[]"), std::string("{\"state\":{}}"), std::string("{\"state\":[1]}"),
        std::string("{\"status\":{\"msg\":\"no code\"}}"), std::string("{"), deep_json}) {
    EXPECT_THROW(ParseJson(bad), DecodeError) << bad.substr(0, 40);
  }
  EXPECT_THROW(DecodeJointTargetDeg(ParseXhtml(kCtrlStateXhtml)), DecodeError);
  EXPECT_THROW(DecodeRobotSerial(Document{}), DecodeError);
  Document joints_bad;
  joints_bad.resources.push_back(
      {"ms-jointtarget", "ROB_1", {{"rax_1", "1"}, {"rax_2", "x"}}, {}});
  EXPECT_THROW(DecodeJointTargetDeg(joints_bad), DecodeError);
}

}  // namespace
}  // namespace armsig::robots::rws
