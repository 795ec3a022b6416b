#include "programs/urscript.h"

#include <gtest/gtest.h>

#include <regex>
#include <sstream>


#include "core/error.h"
#include "test_support.h"
#include "core/units.h"

namespace armsig::programs {
namespace {

// A PolyScope-style program: a TCP, waypoints as pose + joints, MoveJ through
// get_inverse_kin, a MoveL to a variable, literals in the motions, and targets that cannot be
// evaluated.
const char* kProgram = R"(def Program():
  set_tcp(p[0.0,0.0,.150000000000,0.0,0.0,0.0])
  set_payload(1.0)
  global Waypoint_1_p=p[.433025361705, -.467959205379, .522310714714, 1.500318891221, .521427297251, .530987104689]
  global Waypoint_1_q=[1.9942498207092285, -1.6684614620604457, 1.9330504576312464, -0.2718423169902344, 1.3, 0.1]
  global Waypoint_2_p=p[.5, -.4, .3, 0, 3.14, 0]
  global twice = p[.1, .2, .3, 0, 0, 0]
  # a comment with movel(p[9,9,9,9,9,9]) in it
  while (True):
    $ 1 "Robot Program"
    movej(get_inverse_kin(Waypoint_1_p, qnear=Waypoint_1_q), a=1.3962634015954636, v=1.0471975511965976)
    movel(Waypoint_2_p, a=1.2, v=0.25)
    movel(pose_trans(Plane_1, p[.1, 0, 0, 0, 0, 0]), a=1.2, v=0.25)
    movej([0, -1.57,
           1.57, 0, 1.57, 0], a=1.4, v=1.05)
    movel(twice)
    twice = p[.2, .2, .3, 0, 0, 0]
    textmsg("movel(p[1,2,3,4,5,6]) in a string")
  end
end
)";

TEST(UrScript, FindsTargetsToolsAndWhatItCannotEvaluate) {
  const Program p = ParseUrScript({"prog.script", kProgram});
  ASSERT_EQ(p.motions.size(), 3u);  // movej via get_inverse_kin, movel Waypoint_2_p, movej [..]
  ASSERT_EQ(p.not_evaluated.size(), 2u);
  EXPECT_EQ(p.not_evaluated[0].place.line, 13);
  EXPECT_NE(p.not_evaluated[0].why.find("pose_trans(…) is computed"), std::string::npos)
      << p.not_evaluated[0].why;
  EXPECT_EQ(p.not_evaluated[1].place.line, 16);
  EXPECT_NE(p.not_evaluated[1].why.find("twice is assigned at lines 7, 17"), std::string::npos)
      << p.not_evaluated[1].why;

  const Motion& j = p.motions[0];
  EXPECT_EQ(j.instruction, "movej");
  EXPECT_EQ(j.place.line, 11);
  const Target& w1 = p.targets.at(static_cast<std::size_t>(j.targets.at(0)));
  EXPECT_EQ(w1.name, "Waypoint_1_p");
  EXPECT_EQ(w1.kind(), TargetKind::kPose);
  EXPECT_EQ(w1.place.line, 4);
  ASSERT_TRUE(w1.config.near_target);
  const Target& q1 = p.targets.at(static_cast<std::size_t>(*w1.config.near_target));
  EXPECT_EQ(q1.name, "Waypoint_1_q");
  EXPECT_NEAR(JointsOf(q1)(0), 1.9942498207092285, 1e-15);
  EXPECT_NEAR(PoseOf(w1).translation().x(), 433.025361705, 1e-9);
  EXPECT_EQ(w1.fields[1].text, "-.467959205379");

  // The TCP: set_tcp's pose in mm.
  ASSERT_TRUE(j.tool.known());
  EXPECT_NEAR(j.tool.transform->translation().z(), 150.0, 1e-12);
  EXPECT_TRUE(j.base.known());

  const Target& lit = p.targets.at(static_cast<std::size_t>(p.motions[2].targets.at(0)));
  EXPECT_EQ(lit.kind(), TargetKind::kJoints);
  EXPECT_EQ(lit.place.line, 14);
  EXPECT_NEAR(JointsOf(lit)(2), 1.57, 1e-15);
}

TEST(UrScript, NoEditsGiveTheSameBytes) {
  for (const char* name : {"urscript/joint_impedance_cartesian_circle_motion.script",
                           "urscript/admittance_control.script", "urscript/external_control.urscript"}) {
    const std::string text = testing::ProgramData(name);
    ASSERT_FALSE(text.empty()) << name;
    const Program p = ParseUrScript({name, text});
    EXPECT_EQ(ApplyEdits(p.files, {}).at(0), text) << name;
  }
}

// Motion calls in a URScript text counted independently of the parser: line by line, the
// comment and the strings cut away, each motion name followed by "(".
std::size_t CountMotionCalls(const std::string& text) {
  static const std::regex call(R"(\b(movej|movel|movep|movec|optimovej|optimovel)\s*\()");
  static const std::regex string(R"("[^"]*")");
  std::istringstream lines(text);
  std::size_t count = 0;
  for (std::string line; std::getline(lines, line);) {
    line = std::regex_replace(line, string, "\"\"");
    line = line.substr(0, line.find('#'));
    count += static_cast<std::size_t>(std::distance(std::sregex_iterator(line.begin(), line.end(), call), std::sregex_iterator()));
  }
  return count;
}

TEST(UrScript, RealProgramsTheirComputedTargetsNamed) {
  // The URCap's script moves only to targets it receives: every one is named, none guessed.
  const std::string text = testing::ProgramData("urscript/external_control.urscript");
  const Program ext = ParseUrScript({"external_control.urscript", text});
  EXPECT_TRUE(ext.motions.empty());
  EXPECT_EQ(ext.not_evaluated.size(), CountMotionCalls(text));
  EXPECT_GT(ext.not_evaluated.size(), 10u);
  for (const auto& n : ext.not_evaluated) EXPECT_FALSE(n.why.empty());
  // The admittance example's motions are computed too.
  const Program adm = ParseUrScript({"admittance_control.script", testing::ProgramData("urscript/admittance_control.script")});
  EXPECT_TRUE(adm.motions.empty());
}

TEST(UrScript, RewritingKeepsEveryOtherByte) {
  const Program p = ParseUrScript({"prog.script", kProgram});
  const Target& w2 = p.targets.at(static_cast<std::size_t>(p.motions[1].targets.at(0)));
  Eigen::Isometry3d pose = PoseOf(w2);
  pose.translation() += Eigen::Vector3d(0.5, -0.25, 1.0);  // mm
  const std::string out = ApplyEdits(p.files, RewritePose(w2, pose)).at(0);
  const std::string expected_line = "  global Waypoint_2_p=p[.5005, -.40025, .301, 0, 3.14, 0]";
  EXPECT_NE(out.find(expected_line + "\n"), std::string::npos) << out;
  // Every other line is the same.
  std::string a = kProgram, b = out;
  a.erase(a.find("  global Waypoint_2_p"), std::string("  global Waypoint_2_p=p[.5, -.4, .3, 0, 3.14, 0]").size());
  b.erase(b.find(expected_line), expected_line.size());
  EXPECT_EQ(a, b);
  // Parsed again, the pose is the new one.
  const Program again = ParseUrScript({"prog.script", out});
  const Target& w2b = again.targets.at(static_cast<std::size_t>(again.motions[1].targets.at(0)));
  EXPECT_LT((PoseOf(w2b).translation() - pose.translation()).norm(), 1e-6);
  EXPECT_LT((PoseOf(w2b).linear() - pose.linear()).norm(), 1e-9);
}

TEST(UrScript, RefusesWhatIsNotUrScript) {
  try {
    ParseUrScript({"bad.script", "def f():\n  textmsg(\"never ends)\nend\n"});
    FAIL();
  } catch (const InputError& e) {
    EXPECT_EQ(e.where().line, 2);
    EXPECT_NE(std::string(e.what()).find("string"), std::string::npos);
  }
  try {
    ParseUrScript({"bad.script", "def f():\n  movej([0,0,0,0,0,0])\n"});
    FAIL();
  } catch (const InputError& e) {
    EXPECT_EQ(e.where().line, 1);
    EXPECT_NE(std::string(e.what()).find("def f is never closed"), std::string::npos) << e.what();
  }
  EXPECT_THROW(ParseUrScript({"bad.script", "movej([0,0,0,0,0,0])\nend\n"}), InputError);
}

TEST(UrScript, LocalsParametersAndStructWaypoints) {
  const char* text = R"(def move_to(target):
  movel(target)
end
def main():
  local here = p[.1, .2, .3, 0, 0, 0]
  movel(here)
  global Home = struct(p=p[.0, -.2329, 1.0794, 0, 2.2214, -2.2214], frame="base", q=[0, -1.5708, 0, -1.5708, 0, 0])
  global Side = struct(p=p[.1, .1, .1, 0, 0, 0], frame="table", q=[0, 0, 0, 0, 0, 0])
  movej(Home.q)
  movel(Home.p)
  movel(Side.p)
end
)";
  const Program p = ParseUrScript({"s.script", text});
  ASSERT_EQ(p.motions.size(), 3u);
  EXPECT_EQ(p.targets.at(static_cast<std::size_t>(p.motions[0].targets[0])).name, "here");
  EXPECT_EQ(p.targets.at(static_cast<std::size_t>(p.motions[1].targets[0])).name, "Home.q");
  EXPECT_EQ(p.targets.at(static_cast<std::size_t>(p.motions[2].targets[0])).name, "Home.p");
  ASSERT_EQ(p.not_evaluated.size(), 2u);
  EXPECT_NE(p.not_evaluated[0].why.find("target is a parameter of def move_to"), std::string::npos)
      << p.not_evaluated[0].why;
  EXPECT_NE(p.not_evaluated[1].why.find("frame \"table\""), std::string::npos) << p.not_evaluated[1].why;
}

}  // namespace
}  // namespace armsig::programs
