// The ISO 9283 files: commanded and attained poses in any angle unit, with or without a
// cycle column, and every malformed row refused at its line and column.
#include "iso9283/iso9283_csv.h"

#include <gtest/gtest.h>

#include <algorithm>

#include <cmath>
#include <string>

#include "acquisition/on_the_move.h"
#include "acquisition/plan.h"
#include "core/error.h"
#include "core/units.h"
#include "test_support.h"

namespace armsig::io {
namespace {

// The message of the InputError `read` throws ("" when it throws none).
template <typename Read>
std::string Iso9283Refusal(Read read) {
  try {
    read();
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

TEST(Iso9283Csv, ReadsCommandedPosesWithOrientationInAnyUnit) {
  testing::TempDir dir;
  testing::WriteText(dir.File("c.csv"),
                     "point,x_mm,y_mm,z_mm,a_deg,b_gon,c_rad,note\n"
                     "P1,600,100,700,90,100,0.5,centre\n"
                     "P2,440,-60,860,0,0,0,\n");
  const auto c = iso9283::ReadCommandedCsv(dir.File("c.csv"));
  ASSERT_EQ(c.size(), 2u);
  EXPECT_EQ(c[0].point, "P1");
  EXPECT_EQ(c[0].position_mm, Eigen::Vector3d(600, 100, 700));
  ASSERT_TRUE(c[0].orientation_rad);
  EXPECT_NEAR(c[0].orientation_rad->x(), kPi / 2, 1e-15);
  EXPECT_NEAR(c[0].orientation_rad->y(), kPi / 2, 1e-15);
  EXPECT_NEAR(c[0].orientation_rad->z(), 0.5, 1e-15);
  EXPECT_EQ(c[1].line, 3);
  // A poses CSV serves too: `pose` names the point, the joints are ignored.
  testing::WriteText(dir.File("poses.csv"), "pose,q1_deg,x_mm,y_mm,z_mm\n7,10,1,2,3\n");
  EXPECT_EQ(iso9283::ReadCommandedCsv(dir.File("poses.csv"))[0].point, "7");
}

TEST(Iso9283Csv, AttainedCyclesAreNumberedInFileOrderWhenTheFileGivesNone) {
  testing::TempDir dir;
  testing::WriteText(dir.File("a.csv"), "point,x_mm,y_mm,z_mm\nP1,1,2,3\nP2,4,5,6\nP1,1.1,2,3\n");
  const auto a = iso9283::ReadAttainedCsv(dir.File("a.csv"));
  ASSERT_EQ(a.size(), 3u);
  EXPECT_EQ(a[0].cycle, 1);
  EXPECT_EQ(a[1].cycle, 1);
  EXPECT_EQ(a[2].cycle, 2);
  EXPECT_FALSE(a[0].orientation_rad);
  testing::WriteText(dir.File("b.csv"),
                     "point,cycle,approach,x_mm,y_mm,z_mm\nP1,4,x,1,2,3\nP1,4,y,1,2,3\n");
  const auto b = iso9283::ReadAttainedCsv(dir.File("b.csv"));
  EXPECT_EQ(b[1].approach, "y");
  EXPECT_EQ(b[1].cycle, 4);
}

TEST(Iso9283Csv, MalformedRowsAreRefusedAtTheirLine) {
  testing::TempDir dir;
  auto refusal = [&](const std::string& text, bool attained) {
    testing::WriteText(dir.File("f.csv"), text);
    return Iso9283Refusal([&] {
      attained ? (void)iso9283::ReadAttainedCsv(dir.File("f.csv"))
               : (void)iso9283::ReadCommandedCsv(dir.File("f.csv"));
    });
  };
  EXPECT_NE(refusal("point,x_mm,y_mm,z_mm\nP1,1,2,3\nP1,1,2,3\n", false).find("f.csv:3"),
            std::string::npos);
  EXPECT_NE(refusal("point,cycle,x_mm,y_mm,z_mm\nP1,1,1,2,3\nP1,1,1,2,3\n", true)
                .find("cycle 1 is given twice (first on line 2)"),
            std::string::npos);
  EXPECT_NE(refusal("point,cycle,x_mm,y_mm,z_mm\nP1,0,1,2,3\n", true).find("f.csv:2"),
            std::string::npos);
  EXPECT_NE(refusal("point,x_mm,y_mm,z_mm\nP1,1,two,3\n", false).find("f.csv:2"),
            std::string::npos);
  EXPECT_NE(
      refusal("point,x_mm,y_mm,z_mm,a_deg,b_deg\nP1,1,2,3,0,0\n", false).find("all of a, b and c"),
      std::string::npos);
  EXPECT_NE(refusal("point,x_m,y_mm,z_mm\nP1,1,2,3\n", false).find("x_m"), std::string::npos);
  EXPECT_NE(refusal("name,x_mm,y_mm,z_mm\nP1,1,2,3\n", false).find("'point'"), std::string::npos);
  EXPECT_NE(refusal("point,x_mm,y_mm,z_mm\n", true).find("no attained poses"), std::string::npos);
}

// Issue 38: the plan opened with '#' lines, which pandas and spreadsheets read as rows: it
// is the header and the rows only.
TEST(Iso9283Csv, PlanRoundTripsWithViaPointsAndOpensWithItsHeader) {
  std::vector<iso9283::Iso9283PlanRow> rows = {
      {"P1-01-x-via", "", 0, "", {700, 100, 700}, Eigen::VectorXd::LinSpaced(6, -1, 1), {}, ""},
      {"P1-01-x", "P1", 1, "x", {600, 100, 700}, Eigen::VectorXd::LinSpaced(6, -0.5, 0.5), {}, ""}};
  testing::TempDir dir;
  const std::string text = FormatIso9283PlanCsv(rows);
  EXPECT_EQ(text.rfind("pose,point,cycle,approach,x_mm,y_mm,z_mm,q1_deg,", 0), 0u) << text;
  EXPECT_EQ(text.find('#'), std::string::npos) << text;
  EXPECT_EQ(std::count(text.begin(), text.end(), '\n'), 3);
  testing::WriteText(dir.File("plan.csv"), text);
  const auto back = iso9283::ReadIso9283PlanCsv(dir.File("plan.csv"), 6);
  ASSERT_EQ(back.size(), 2u);
  EXPECT_EQ(back[0].pose, "P1-01-x-via");
  EXPECT_TRUE(back[0].point.empty());
  EXPECT_EQ(back[1].point, "P1");
  EXPECT_EQ(back[1].cycle, 1);
  EXPECT_EQ(back[1].approach, "x");
  EXPECT_LT((back[1].target_mm - rows[1].target_mm).norm(), 1e-6);
  EXPECT_LT((back[1].joints_rad - rows[1].joints_rad).cwiseAbs().maxCoeff(), 1e-9);
  EXPECT_FALSE(back[1].speed_mm_s);
}

// A path plan (`iso9283 plan --path`) adds the speed_mm_s column: empty for a cycle's first
// vertex (a joint move), the path speed for the others; the capture plan reads it as the
// linear moves it sweeps, and refuses a speed that is none and a first row that is linear.
TEST(Iso9283Csv, APathPlanCarriesItsLinearSpeedsIntoTheCapturePlan) {
  std::vector<iso9283::Iso9283PlanRow> rows = {
      {"line-01-v1", "", 0, "", {700, 100, 700}, Eigen::VectorXd::LinSpaced(6, -1, 1), {}, ""},
      {"line-01-v2", "", 0, "", {500, 300, 700}, Eigen::VectorXd::LinSpaced(6, -0.5, 0.5), 250.0, ""}};
  testing::TempDir dir;
  const std::string text = FormatIso9283PlanCsv(rows);
  EXPECT_NE(text.find(",q6_deg,speed_mm_s\n"), std::string::npos) << text;
  testing::WriteText(dir.File("path.csv"), text);
  const auto back = iso9283::ReadIso9283PlanCsv(dir.File("path.csv"), 6);
  ASSERT_EQ(back.size(), 2u);
  EXPECT_FALSE(back[0].speed_mm_s);
  ASSERT_TRUE(back[1].speed_mm_s);
  EXPECT_DOUBLE_EQ(*back[1].speed_mm_s, 250.0);
  const acquisition::Plan plan = acquisition::ReadPlanCsv(dir.File("path.csv"), 6);
  ASSERT_EQ(plan.size(), 2u);
  EXPECT_FALSE(plan[0].linear_speed_mm_s);
  ASSERT_TRUE(plan[1].linear_speed_mm_s);
  EXPECT_DOUBLE_EQ(*plan[1].linear_speed_mm_s, 250.0);
  EXPECT_TRUE(acquisition::HasLinearMoves(plan));
  // Stored with the session and read back: the same moves.
  const acquisition::Plan stored = acquisition::PlanFromJson(acquisition::PlanToJson(plan));
  ASSERT_TRUE(stored[1].linear_speed_mm_s);
  EXPECT_DOUBLE_EQ(*stored[1].linear_speed_mm_s, 250.0);
  EXPECT_FALSE(stored[0].linear_speed_mm_s);
  // Each segment of the sweep is one cycle: from its joint move through its linear moves.
  acquisition::Plan two = plan;
  two.push_back(plan[0]);
  two.back().label = "line-02-v1";
  two.push_back(plan[1]);
  two.back().label = "line-02-v2";
  const auto spans = acquisition::PathSegments(two);
  ASSERT_EQ(spans.size(), 2u);
  EXPECT_EQ(spans[0].first, 0u);
  EXPECT_EQ(spans[0].last, 1u);
  EXPECT_EQ(spans[1].first, 2u);
  EXPECT_EQ(spans[1].last, 3u);
  EXPECT_EQ(spans[1].index, 1);

  const auto refused = [&](const std::string& body, const char* what) {
    testing::WriteText(dir.File("bad.csv"),
                       "pose,q1_deg,q2_deg,q3_deg,q4_deg,q5_deg,q6_deg,speed_mm_s\n" + body);
    try {
      (void)acquisition::ReadPlanCsv(dir.File("bad.csv"), 6);
      ADD_FAILURE() << "accepted: " << body;
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find(what), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find("bad.csv:"), std::string::npos) << e.what();
    }
  };
  refused("a,0,0,90,0,30,0,250\n", "the first configuration is reached by a joint move");
  refused("a,0,0,90,0,30,0,\nb,0,0,80,0,30,0,0\n", "expected a speed above 0");
  refused("a,0,0,90,0,30,0,\nb,0,0,80,0,30,0,fast\n", "");
  refused("a,0,0,90,0,30,0,\nb,0,0,80,0,30,0,20000\n", "at most 10000");

  // A circular move: a via row, then its target; both at the path's speed.
  const std::string header = "pose,q1_deg,q2_deg,q3_deg,q4_deg,q5_deg,q6_deg,speed_mm_s,motion\n";
  testing::WriteText(dir.File("circle.csv"), header +
                                                 "s,0,0,90,0,30,0,,\n"
                                                 "v,0,10,90,0,30,0,250,via\n"
                                                 "t,0,20,80,0,30,0,250,circular\n"
                                                 "l,0,20,70,0,30,0,250,linear\n");
  const acquisition::Plan circle = acquisition::ReadPlanCsv(dir.File("circle.csv"), 6);
  ASSERT_EQ(circle.size(), 4u);
  EXPECT_TRUE(circle[1].via);
  EXPECT_FALSE(circle[2].via);
  EXPECT_FALSE(circle[3].via);
  EXPECT_TRUE(acquisition::PlanFromJson(acquisition::PlanToJson(circle))[1].via);
  const auto refused_motion = [&](const std::string& body, const char* what) {
    testing::WriteText(dir.File("bad.csv"), header + body);
    try {
      (void)acquisition::ReadPlanCsv(dir.File("bad.csv"), 6);
      ADD_FAILURE() << "accepted: " << body;
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find(what), std::string::npos) << e.what();
    }
  };
  refused_motion("s,0,0,90,0,30,0,,\nt,0,20,80,0,30,0,250,circular\n", "follows its via point");
  refused_motion("s,0,0,90,0,30,0,,\nv,0,10,90,0,30,0,250,via\n", "a via point with no target");
  refused_motion("s,0,0,90,0,30,0,,\nv,0,10,90,0,30,0,250,via\nl,0,20,70,0,30,0,250,linear\n",
                 "its circular move's target");
  refused_motion("s,0,0,90,0,30,0,,\nv,0,10,90,0,30,0,,via\n", "needs its speed_mm_s");
  refused_motion("s,0,0,90,0,30,0,,\nv,0,10,90,0,30,0,250,spline\n", "expected joint, linear");
}

}  // namespace
}  // namespace armsig::io
