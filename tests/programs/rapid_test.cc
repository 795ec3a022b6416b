#include "programs/rapid.h"

#include <gtest/gtest.h>


#include "core/error.h"
#include "test_support.h"
#include "core/units.h"

namespace armsig::programs {
namespace {

const char* kModule = R"(%%%
  VERSION:1
  LANGUAGE:ENGLISH
%%%
MODULE Cell
  PERS tooldata tGripper:=[TRUE,[[10,0,250],[1,0,0,0]],[2,[0,0,100],[1,0,0,0],0,0,0]];
  TASK PERS wobjdata wTable:=[FALSE,TRUE,"",[[1500,0,700],[0.7071068,0,0,0.7071068]],[[0,0,0],[1,0,0,0]]];
  CONST robtarget p10:=[[400,100,300],[0,0,1,0],[0,0,0,0],[9E+09,9E+09,9E+09,9E+09,9E+09,9E+09]];
  CONST robtarget p20:=[[450,-100,
                        350],[0,0.7071068,0.7071068,0],[-1,0,-1,1],[9E9,9E9,9E9,9E9,9E9,9E9]];
  CONST jointtarget jHome:=[[0,0,0,0,30,0],[9E9,9E9,9E9,9E9,9E9,9E9]];
  CONST robtarget path{2}:=[[[1,2,3],[1,0,0,0],[0,0,0,0],[9E9,9E9,9E9,9E9,9E9,9E9]],[[4,5,6],[1,0,0,0],[0,0,0,0],[9E9,9E9,9E9,9E9,9E9,9E9]]];
  VAR robtarget pHere;
  VAR num n:=1;
  PROC main()
    MoveAbsJ jHome\NoEOffs, v1000, fine, tool0;
    MoveJ p10, v1000, z50, tGripper\WObj:=wTable;
    MoveL Offs(p10,0,0,100), v100, fine, tGripper\WObj:=wTable;
    MoveL [[500,0,400],[0,0,1,0],[0,0,0,0],[9E9,9E9,9E9,9E9,9E9,9E9]], v100, fine, tGripper;
    MoveC p20, p10, v100, z10, tGripper\WObj:=wTable;
    IF n = 2 MoveL path{2}, v100, fine, tOther;
    pHere := CRobT(\Tool:=tGripper);
    MoveL pHere, v100, fine, tGripper;
    ! MoveL p99, v100, fine, tool0;
    TEST n
    CASE 1: MoveL path{1}, v100, fine, tool0;
    DEFAULT: Stop;
    ENDTEST
  ENDPROC
  PROC go(robtarget target)
    MoveL target, v100, fine, tool0;
  ENDPROC
ENDMODULE
)";

TEST(Rapid, TargetsToolsAndWorkObjects) {
  const Program p = ParseRapid({"Cell.mod", kModule});
  ASSERT_EQ(p.motions.size(), 6u);
  // MoveAbsJ jHome.
  const Target& home = p.targets.at(static_cast<std::size_t>(p.motions[0].targets[0]));
  EXPECT_EQ(home.name, "jHome");
  EXPECT_EQ(home.kind(), TargetKind::kJoints);
  EXPECT_NEAR(JointsOf(home)(4), 30 * kRadPerDeg, 1e-15);
  EXPECT_TRUE(p.motions[0].tool.transform->isApprox(Eigen::Isometry3d::Identity()));
  // MoveJ p10 with the gripper in the table's frame.
  const Motion& j = p.motions[1];
  const Target& p10 = p.targets.at(static_cast<std::size_t>(j.targets[0]));
  EXPECT_EQ(p10.name, "p10");
  EXPECT_EQ(p10.place.line, 8);
  ASSERT_TRUE(p10.config.abb_cf);
  EXPECT_NEAR(PoseOf(p10).translation().y(), 100.0, 1e-12);
  ASSERT_TRUE(j.tool.known());
  EXPECT_NEAR(j.tool.transform->translation().z(), 250.0, 1e-12);
  ASSERT_TRUE(j.base.known());
  EXPECT_NEAR(j.base.transform->translation().x(), 1500.0, 1e-12);
  EXPECT_NEAR((j.base.transform->linear() * Eigen::Vector3d::UnitX()).y(), 1.0, 1e-6);  // 90° about z
  // The inline robtarget, without \WObj: wobj0.
  const Target& inline_target = p.targets.at(static_cast<std::size_t>(p.motions[2].targets[0]));
  EXPECT_TRUE(inline_target.name.empty());
  EXPECT_TRUE(p.motions[2].base.transform->isApprox(Eigen::Isometry3d::Identity()));
  // MoveC: p20 (over two lines, its own configuration) then p10, shared with the MoveJ.
  const Motion& c = p.motions[3];
  ASSERT_EQ(c.targets.size(), 2u);
  const Target& p20 = p.targets.at(static_cast<std::size_t>(c.targets[0]));
  EXPECT_EQ(p20.config.abb_cf, (std::array<int, 4>{-1, 0, -1, 1}));
  EXPECT_EQ(c.targets[1], j.targets[0]);
  // The compact IF's motion: path{2}, its tool declared in another module.
  const Motion& compact = p.motions[4];
  EXPECT_EQ(p.targets.at(static_cast<std::size_t>(compact.targets[0])).name, "path{2}");
  EXPECT_NEAR(PoseOf(p.targets.at(static_cast<std::size_t>(compact.targets[0]))).translation().x(), 4.0, 1e-12);
  EXPECT_FALSE(compact.tool.known());
  EXPECT_NE(compact.tool.unknown_why.find("tOther is not declared in this module"), std::string::npos)
      << compact.tool.unknown_why;
  EXPECT_EQ(p.targets.at(static_cast<std::size_t>(p.motions[5].targets[0])).name, "path{1}");

  ASSERT_EQ(p.not_evaluated.size(), 3u);
  EXPECT_EQ(p.not_evaluated[0].place.line, 18);
  EXPECT_NE(p.not_evaluated[0].why.find("Offs(…) is computed"), std::string::npos) << p.not_evaluated[0].why;
  EXPECT_EQ(p.not_evaluated[1].place.line, 23);
  EXPECT_NE(p.not_evaluated[1].why.find("not a robtarget literal"), std::string::npos) << p.not_evaluated[1].why;
  EXPECT_NE(p.not_evaluated[2].why.find("target is a parameter of go"), std::string::npos) << p.not_evaluated[2].why;
}

// WaitTime with a number is a wait a controller runs where the arm stands (with \InPos or
// not), in the routine it is in; one with an expression is not a fixed wait.
TEST(Rapid, WaitTimesAndTheRoutinesOfMotions) {
  const Program p = ParseRapid({"W.mod",
                                "MODULE W\n  PROC a()\n    MoveAbsJ [[0,0,0,0,30,0],[9E9,9E9,9E9,9E9,9E9,9E9]], v100, fine, tool0;\n"
                                "    WaitTime 2.5;\n    WaitTime \\InPos, 1;\n    WaitTime t;\n  ENDPROC\n"
                                "  PROC b()\n    WaitTime 4;\n  ENDPROC\nENDMODULE\n"});
  ASSERT_EQ(p.motions.size(), 1u);
  EXPECT_EQ(p.motions[0].routine, "a");
  ASSERT_EQ(p.waits.size(), 3u);
  EXPECT_EQ(p.waits[0].seconds, 2.5);
  EXPECT_EQ(p.waits[0].place.line, 4);
  EXPECT_EQ(p.waits[0].routine, "a");
  EXPECT_EQ(p.waits[1].seconds, 1.0);
  EXPECT_EQ(p.waits[2].seconds, 4.0);
  EXPECT_EQ(p.waits[2].routine, "b");
}

TEST(Rapid, RewritesAQuaternionOfTheSameSign) {
  const Program p = ParseRapid({"Cell.mod", kModule});
  const Target& p10 = p.targets.at(static_cast<std::size_t>(p.motions[1].targets[0]));
  // Turned by 0.01° about z: the quaternion [0, 0, 1, 0] (180° about y) keeps its sign.
  Eigen::Isometry3d pose = PoseOf(p10);
  pose.linear() = Eigen::AngleAxisd(0.01 * kRadPerDeg, Eigen::Vector3d::UnitZ()) * pose.linear();
  pose.translation().x() += 0.2;
  const std::string out = ApplyEdits(p.files, RewritePose(p10, pose)).at(0);
  const Program again = ParseRapid({"Cell.mod", out});
  const Target& back = again.targets.at(static_cast<std::size_t>(again.motions[1].targets[0]));
  EXPECT_GT(back.fields[5].value, 0.99);  // q3 stays near +1
  EXPECT_LT((PoseOf(back).linear() - pose.linear()).norm(), 1e-8);
  EXPECT_NE(out.find("CONST robtarget p10:=[[400.2,100,300],"), std::string::npos) << out;
}

TEST(Rapid, RealModulesReadWholeAndRoundTrip) {
  for (const char* name : {"rapid/ROS_motion.mod", "rapid/ROS_motionServer.mod", "rapid/ROS_stateServer.mod",
                           "rapid/ROS_common.sys", "rapid/ROS_socket.sys", "rapid/ROS_messages.sys"}) {
    const std::string text = testing::ProgramData(name);
    ASSERT_FALSE(text.empty()) << name;
    const Program p = ParseRapid({name, text});
    EXPECT_EQ(ApplyEdits(p.files, {}).at(0), text) << name;
    EXPECT_TRUE(p.motions.empty()) << name;  // the driver's motions take computed joints
  }
  const Program motion = ParseRapid({"ROS_motion.mod", testing::ProgramData("rapid/ROS_motion.mod")});
  ASSERT_EQ(motion.not_evaluated.size(), 1u);
  EXPECT_NE(motion.not_evaluated[0].why.find("changed component by component"), std::string::npos)
      << motion.not_evaluated[0].why;
}

TEST(Rapid, RefusesWhatIsNotRapid) {
  try {
    ParseRapid({"bad.mod", "MODULE m\n  PROC main()\n    MoveL p10, v100, fine, tool0;\nENDMODULE\n"});
    FAIL();
  } catch (const InputError& e) {
    EXPECT_EQ(e.where().line, 4);
    EXPECT_NE(std::string(e.what()).find("ENDMODULE without the block it closes"), std::string::npos) << e.what();
  }
  EXPECT_THROW(ParseRapid({"bad.mod", "MODULE m\n  VAR string s:=\"never;\nENDMODULE\n"}), InputError);
  EXPECT_THROW(ParseRapid({"bad.mod", "MODULE m\n  VAR num n:=1\nENDMODULE\n"}), InputError);
}

}  // namespace
}  // namespace armsig::programs
