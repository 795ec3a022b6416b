#include "programs/krl.h"

#include <gtest/gtest.h>


#include "core/error.h"
#include "test_support.h"
#include "core/units.h"

namespace armsig::programs {
namespace {

// A KSS 8 program as the inline forms write it: ILF folds whose FDATs choose the tool and
// base, points in the .dat, an axis literal, and targets that cannot be evaluated.
const char* kSrc = R"(&ACCESS RVP
&REL 1
&PARAM TEMPLATE = C:\KRC\Roboter\Template\vorgabe
&PARAM EDITMASK = *
DEF cell_test( )
;FOLD INI;%{PE}
  ;FOLD BASISTECH INI
    GLOBAL INTERRUPT DECL 3 WHEN $STOPMESS==TRUE DO IR_STOPM ( )
    INTERRUPT ON 3
    BAS (#INITMOV,0 )
  ;ENDFOLD (BASISTECH INI)
;ENDFOLD (INI)
;FOLD PTP HOME  Vel= 100 % DEFAULT;%{PE}%MKUKATPBASIS,%CMOVE,%VPTP,%P 1:PTP, 2:HOME, 3:, 5:100, 7:DEFAULT
$BWDSTART = FALSE
PDAT_ACT=PDEFAULT
FDAT_ACT=FHOME
BAS (#PTP_PARAMS,100 )
$H_POS=XHOME
PTP  XHOME
;ENDFOLD
;FOLD PTP P1 Vel=100 % PDAT1 Tool[1]:Gripper Base[0];%{PE}%R 8.3.31,%MKUKATPBASIS,%CMOVE,%VPTP,%P 1:PTP, 2:P1, 3:, 5:100, 7:PDAT1
$BWDSTART=FALSE
PDAT_ACT=PPDAT1
FDAT_ACT=FP1
BAS(#PTP_PARAMS,100)
PTP XP1
;ENDFOLD
;FOLD LIN P2 Vel=0.2 m/s CPDAT1 Tool[1]:Gripper Base[2]:Table;%{PE}%R 8.3.31,%MKUKATPBASIS,%CMOVE,%VLIN,%P 1:LIN, 2:P2, 3:, 5:0.2, 7:CPDAT1
$BWDSTART=FALSE
LDAT_ACT=LCPDAT1
FDAT_ACT=FP2
BAS(#CP_PARAMS,0.2)
LIN XP2
;ENDFOLD
LIN {X 10} C_DIS
IF $IN[1] THEN
  PTP {A1 10, A2 -80, A3 100, A4 0, A5 30, A6 0}
ENDIF
CIRC XP3, XP4 C_DIS
PTP_REL {A1 10}
END
)";

const char* kDat = R"(&ACCESS RVP
&REL 1
DEFDAT  cell_test
;FOLD EXTERNAL DECLARATIONS;%{PE}%MKUKATPBASIS,%CEXT,%VCOMMON,%P
;ENDFOLD (EXTERNAL DECLARATIONS)
DECL BASIS_SUGG_T LAST_BASIS={POINT1[] "P2",POINT2[] "P2",CP_PARAMS[] "CPDAT1",PTP_PARAMS[] "PDAT1",CONT[] " ",CP_VEL[] "0.2",PTP_VEL[] "100"}
DECL E6POS XP1={X 1000.0,Y 200.0,Z 1200.0,A 0.0,B 90.0,C 0.0,S 6,T 50,E1 0.0,E2 0.0,E3 0.0,E4 0.0,E5 0.0,E6 0.0}
DECL FDAT FP1={TOOL_NO 1,BASE_NO 0,IPO_FRAME #BASE,POINT2[] " ",TQ_STATE FALSE}
DECL PDAT PPDAT1={VEL 100.0,ACC 100.0,APO_DIST 100.0,APO_MODE #CDIS,GEAR_JERK 50.0,EXAX_IGN 0}
DECL E6POS XP2={X 900.0,Y -100.0,Z 1100.0,A -90.0,B 45.0,C 180.0,S 2,T 35,E1 0.0,E2 0.0,E3 0.0,E4 0.0,E5 0.0,E6 0.0}
DECL FDAT FP2={TOOL_NO 1,BASE_NO 2,IPO_FRAME #BASE,POINT2[] " ",TQ_STATE FALSE}
DECL LDAT LCPDAT1={VEL 2.0,ACC 100.0,APO_DIST 100.0,ORI_TYP #VAR,CB {AUX_PT {ORI #CONSIDER,E1 #CONSIDER},TARGET_PT {ORI #INTERPOLATE,E1 #INTERPOLATE}}}
DECL E6POS XP3={X 950.0,Y 0.0,Z 1000.0,A 0.0,B 90.0,C 0.0,S 6,T 50}, XP4
ENDDAT
)";

const char* kConfig = R"(&PARAM EDITMASK = *
DEFDAT  $CONFIG
;FOLD TOOL_DATA
DECL FRAME TOOL_DATA[16]
TOOL_DATA[1]={X 10.0,Y 0.0,Z 250.0,A 0.0,B 0.0,C 0.0}
TOOL_DATA[2]={X 0.0,Y 0.0,Z 0.0,A 0.0,B 0.0,C 0.0}
;ENDFOLD
DECL FRAME BASE_DATA[32]
BASE_DATA[2]={X 1500.0,Y 0.0,Z 700.0,A 90.0,B 0.0,C 0.0}
ENDDAT
)";

TEST(Krl, InlineFormsTheirPointsToolsAndBases) {
  const KrlControllerData config = ParseKrlConfigDat({"$config.dat", kConfig});
  ASSERT_EQ(config.tools.count(1), 1u);
  EXPECT_NEAR(config.tools.at(1).translation().z(), 250.0, 1e-12);
  ASSERT_EQ(config.bases.count(2), 1u);
  EXPECT_NEAR((config.bases.at(2).linear() * Eigen::Vector3d::UnitX()).y(), 1.0, 1e-12);  // A 90

  const Program p = ParseKrl({"cell_test.src", kSrc}, ProgramFile{"cell_test.dat", kDat}, &config);
  ASSERT_EQ(p.motions.size(), 3u);  // PTP XP1, LIN XP2, PTP {A1 …}
  const Motion& ptp = p.motions[0];
  EXPECT_EQ(ptp.place.line, 26);
  const Target& xp1 = p.targets.at(static_cast<std::size_t>(ptp.targets[0]));
  EXPECT_EQ(xp1.name, "XP1");
  EXPECT_EQ(xp1.place.file, 1);
  EXPECT_EQ(xp1.place.line, 7);
  EXPECT_EQ(xp1.layout, Layout::kKrlFrame);
  EXPECT_EQ(xp1.config.kuka_status, 6);
  EXPECT_EQ(xp1.config.kuka_turn, 50);
  const Eigen::Isometry3d pose = PoseOf(xp1);
  EXPECT_NEAR(pose.translation().x(), 1000.0, 1e-12);
  EXPECT_NEAR((pose.linear() * Eigen::Vector3d::UnitX()).z(), -1.0, 1e-12);  // B 90: x down
  ASSERT_TRUE(ptp.tool.known());
  EXPECT_NEAR(ptp.tool.transform->translation().z(), 250.0, 1e-12);
  ASSERT_TRUE(ptp.base.known());
  EXPECT_TRUE(ptp.base.transform->isApprox(Eigen::Isometry3d::Identity()));

  const Motion& lin = p.motions[1];
  ASSERT_TRUE(lin.base.known());
  EXPECT_NEAR(lin.base.transform->translation().x(), 1500.0, 1e-12);
  EXPECT_EQ(lin.base.name, "BASE_DATA[2]");

  const Target& axis = p.targets.at(static_cast<std::size_t>(p.motions[2].targets[0]));
  EXPECT_EQ(axis.kind(), TargetKind::kJoints);
  EXPECT_NEAR(JointsOf(axis)(1), -80 * kRadPerDeg, 1e-15);
  EXPECT_EQ(axis.place.file, 0);

  // Named: XHOME (in $config.dat, not the program's), the partial aggregate, XP4 without a
  // value, the relative motion.
  ASSERT_EQ(p.not_evaluated.size(), 4u);
  EXPECT_EQ(p.not_evaluated[0].place.line, 19);
  EXPECT_NE(p.not_evaluated[0].why.find("XHOME has no value in the program"), std::string::npos)
      << p.not_evaluated[0].why;
  EXPECT_NE(p.not_evaluated[1].why.find("without Y, Z, A, B, C"), std::string::npos) << p.not_evaluated[1].why;
  EXPECT_NE(p.not_evaluated[2].why.find("XP4"), std::string::npos) << p.not_evaluated[2].why;
  EXPECT_NE(p.not_evaluated[3].why.find("relative motion"), std::string::npos) << p.not_evaluated[3].why;
  EXPECT_TRUE(p.notes.empty());
}

// WAIT SEC with a number is a wait a controller runs where the arm stands, in its DEF; WAIT
// FOR and a WAIT SEC of an expression are not.
TEST(Krl, WaitSecondsAndTheRoutinesOfMotions) {
  const Program p = ParseKrl({"w.src", "DEF w( )\n  PTP {A1 0, A2 -90, A3 90, A4 0, A5 30, A6 0}\n  WAIT SEC 1.5\n"
                                       "  WAIT FOR $IN[1]\n  WAIT SEC t\nEND\n"},
                             std::nullopt);
  ASSERT_EQ(p.motions.size(), 1u);
  EXPECT_EQ(p.motions[0].routine, "W");
  ASSERT_EQ(p.waits.size(), 1u);
  EXPECT_EQ(p.waits[0].seconds, 1.5);
  EXPECT_EQ(p.waits[0].place.line, 3);
  EXPECT_EQ(p.waits[0].routine, "W");
}

TEST(Krl, WithoutConfigDatTheNumberedToolIsUnknown) {
  const Program p = ParseKrl({"cell_test.src", kSrc}, ProgramFile{"cell_test.dat", kDat});
  ASSERT_EQ(p.motions.size(), 3u);
  EXPECT_FALSE(p.motions[0].tool.known());
  EXPECT_NE(p.motions[0].tool.unknown_why.find("--config-dat"), std::string::npos);
  EXPECT_TRUE(p.motions[0].base.known());  // base 0: the robot's
}

TEST(Krl, RewritesTheDatKeepingItsStyle) {
  const Program p = ParseKrl({"cell_test.src", kSrc}, ProgramFile{"cell_test.dat", kDat});
  const Target& xp2 = p.targets.at(static_cast<std::size_t>(p.motions[1].targets[0]));
  Eigen::Isometry3d pose = PoseOf(xp2);
  pose.translation().y() += 0.0372;
  const auto out = ApplyEdits(p.files, RewritePose(xp2, pose));
  EXPECT_EQ(out[0], p.files[0].text);
  EXPECT_NE(out[1].find("DECL E6POS XP2={X 900.0,Y -99.9628,Z 1100.0,A -90.0,B 45.0,C 180.0,S 2,T 35,"),
            std::string::npos)
      << out[1];
}

TEST(Krl, RealProgramsReadWholeAndRoundTrip) {
  struct Case {
    const char* src;
    const char* dat;
    std::size_t motions;
  };
  for (const Case& c : {Case{"krl/kuka_eki_hw_interface.src", "krl/kuka_eki_hw_interface.dat", 0},
                        Case{"krl/ros_rsi.src", nullptr, 2}, Case{"krl/demo_screenshot.src", "krl/demo_screenshot.dat", 4},
                        Case{"krl/perfect_code.src", nullptr, 0}}) {
    const std::string src = testing::ProgramData(c.src);
    std::optional<ProgramFile> dat;
    if (c.dat) dat = ProgramFile{c.dat, testing::ProgramData(c.dat)};
    const Program p = ParseKrl({c.src, src}, dat);
    const auto out = ApplyEdits(p.files, {});
    EXPECT_EQ(out[0], src) << c.src;
    if (dat) {
      EXPECT_EQ(out[1], dat->text) << c.dat;
    }
    if (c.motions > 0) {
      EXPECT_EQ(p.motions.size(), c.motions) << c.src;
    }
    for (const auto& n : p.not_evaluated) EXPECT_FALSE(n.why.empty());
  }
  // ros_rsi moves to an axis literal twice, the tool never set: its motions carry that.
  const Program rsi = ParseKrl({"ros_rsi.src", testing::ProgramData("krl/ros_rsi.src")}, std::nullopt);
  ASSERT_EQ(rsi.motions.size(), 2u);
  EXPECT_EQ(rsi.targets.at(static_cast<std::size_t>(rsi.motions[0].targets[0])).kind(), TargetKind::kJoints);
  EXPECT_FALSE(rsi.motions[0].tool.known());
  // eki's motion targets come from the controller ($AXIS_ACT_MEAS) and a function: named.
  const Program eki = ParseKrl({"eki.src", testing::ProgramData("krl/kuka_eki_hw_interface.src")},
                               ProgramFile{"eki.dat", testing::ProgramData("krl/kuka_eki_hw_interface.dat")});
  EXPECT_TRUE(eki.motions.empty());
  EXPECT_EQ(eki.not_evaluated.size(), 2u);
}

TEST(Krl, RefusesWhatIsNotKrl) {
  try {
    ParseKrl({"bad.src", "DEF bad()\nIF $IN[1] THEN\n  PTP {A1 0}\nEND\n"}, std::nullopt);
    FAIL();
  } catch (const InputError& e) {
    EXPECT_EQ(e.where().line, 4);
    EXPECT_NE(std::string(e.what()).find("END without the block it closes"), std::string::npos) << e.what();
  }
  try {
    ParseKrl({"bad.src", "DEF bad()\n  MSG = \"never ends\nEND\n"}, std::nullopt);
    FAIL();
  } catch (const InputError& e) {
    EXPECT_EQ(e.where().line, 2);
  }
  // An open fold is noted, not refused (the controller runs it; its editor complains).
  const Program p = ParseKrl({"f.src", "DEF f()\n;FOLD open\nPTP {A1 0,A2 0,A3 0,A4 0,A5 0,A6 0}\nEND\n"},
                             std::nullopt);
  ASSERT_EQ(p.notes.size(), 1u);
  EXPECT_EQ(p.notes[0].place.line, 2);
}

}  // namespace
}  // namespace armsig::programs
