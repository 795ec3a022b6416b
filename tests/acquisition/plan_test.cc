// Capture plans from the command line's --plan: auto:N, single-joint:J:STEPS, a CSV file.
#include "acquisition/plan.h"
#include "acquisition/on_the_move.h"

#include <gtest/gtest.h>

#include <set>

#include "core/error.h"
#include "core/units.h"
#include "test_support.h"

namespace armsig::acquisition {
namespace {

TEST(MakePlan, AutoGivesNDistinctConfigurationsWithinTheLimits) {
  auto model = testing::Puma();
  model.joint_min_rad.assign(6, -2.0);
  model.joint_max_rad.assign(6, 2.0);
  const Plan plan = MakePlan("auto:12", model);
  ASSERT_EQ(plan.size(), 12u);
  for (size_t k = 0; k < plan.size(); ++k) {
    EXPECT_EQ(plan[k].joints_rad.size(), 6);
    EXPECT_LE(plan[k].joints_rad.cwiseAbs().maxCoeff(), 2.0) << plan[k].label;
    for (size_t j = 0; j < k; ++j)
      EXPECT_GT((plan[k].joints_rad - plan[j].joints_rad).norm(), 1e-6) << k << " = " << j;
  }
}

// auto:N draws with a seed: the same seed gives the same configurations (nights that compare
// alike), another seed another well-spread set (capture --seed).
TEST(MakePlan, AutoDrawsAnotherSetWithAnotherSeed) {
  const auto model = testing::Puma();
  const Plan a = MakePlan("auto:12", model), again = MakePlan("auto:12", model, kDefaultPlanSeed);
  const Plan other = MakePlan("auto:12", model, 2026);
  ASSERT_EQ(other.size(), 12u);
  int same = 0;
  for (size_t k = 0; k < a.size(); ++k) {
    EXPECT_EQ(a[k].joints_rad, again[k].joints_rad) << k;
    for (const auto& o : other) same += (a[k].joints_rad - o.joints_rad).norm() < 1e-9;
  }
  EXPECT_EQ(same, 0);
}

TEST(MakePlan, SingleJointSweepsOnlyThatJointOverItsRange) {
  const auto model = testing::Puma();
  const Plan plan = MakePlan("single-joint:2:5", model);
  ASSERT_EQ(plan.size(), 5u);
  EXPECT_EQ(plan[0].label, "J2-001");
  EXPECT_NEAR(plan.front().joints_rad(1), -150 * kRadPerDeg, 1e-12);
  EXPECT_NEAR(plan.back().joints_rad(1), 150 * kRadPerDeg, 1e-12);
  for (const auto& c : plan) {
    for (int j : {0, 2, 3, 4, 5}) EXPECT_EQ(c.joints_rad(j), plan[0].joints_rad(j)) << c.label;
  }
}

// Garbage, trailing text, overflow and out-of-range numbers are refused, naming --plan and
// what was expected; nothing is made of them (auto:4294967297 once became 1 configuration).
TEST(MakePlan, MalformedSpecsAreInputErrorsNamingWhatWasExpected) {
  const auto model = testing::Puma();
  for (const char* spec :
       {"auto:", "auto:0", "auto:-3", "auto:3junk", "auto: 3", "auto:4294967297", "auto:1e3",
        "single-joint:2", "single-joint:2:3x", "single-joint:0:5", "single-joint:7:5",
        "single-joint:2:1", "single-joint:x:5", "single-joint:2:99999999999"}) {
    try {
      MakePlan(spec, model);
      ADD_FAILURE() << spec << " was accepted";
    } catch (const InputError& e) {
      EXPECT_EQ(e.where().file, "--plan") << spec;
      EXPECT_NE(e.message().find("expected"), std::string::npos) << spec << ": " << e.what();
      EXPECT_NE(e.message().find(spec), std::string::npos) << spec << ": " << e.what();
    }
  }
}

// A plan file is sent to the robot as it is: a configuration outside the model's joint
// limits is refused at its line and column, in the file's own unit, before anything moves.
TEST(MakePlan, AFileRowOutsideTheJointLimitsIsRefusedAtItsCell) {
  auto model = testing::Puma();
  model.joint_min_rad.assign(6, -160 * kRadPerDeg);
  model.joint_max_rad.assign(6, 160 * kRadPerDeg);
  testing::TempDir dir;
  const std::string path = dir.File("plan.csv");
  testing::WriteText(path,
                     "pose,q1_deg,q2_deg,q3_deg,q4_deg,q5_deg,q6_deg\n"
                     "P1,0,10,90,0,20,0\n"
                     "P2,0,10,170,0,20,0\n");
  try {
    MakePlan(path, model);
    FAIL() << "a configuration beyond joint 3's limit was accepted";
  } catch (const InputError& e) {
    EXPECT_EQ(e.where().file, path);
    EXPECT_EQ(e.where().line, 3);
    EXPECT_EQ(e.where().column, 4);
    EXPECT_NE(e.message().find("joint 3 at 170 is outside the limits"), std::string::npos)
        << e.what();
    EXPECT_NE(e.message().find("-160 to 160 deg"), std::string::npos) << e.what();
  }
  // Within the limits (and without limits in the model), the same file is a plan.
  testing::WriteText(path,
                     "pose,q1_deg,q2_deg,q3_deg,q4_deg,q5_deg,q6_deg\n"
                     "P1,0,10,90,0,20,0\nP2,0,10,150,0,20,0\n");
  EXPECT_EQ(MakePlan(path, model).size(), 2u);
}

TEST(PlanJson, RoundTripsLabelsAndJointsExactly) {
  Plan plan = {{"C1", Eigen::VectorXd::LinSpaced(6, -1.0 / 3.0, 2.0)},
               {"a b", Eigen::VectorXd::Constant(6, 1e-17)}};
  const Plan back = PlanFromJson(PlanToJson(plan));
  ASSERT_EQ(back.size(), 2u);
  for (size_t k = 0; k < 2; ++k) {
    EXPECT_EQ(back[k].label, plan[k].label);
    EXPECT_EQ(back[k].joints_rad, plan[k].joints_rad);
  }
}

}  // namespace
}  // namespace armsig::acquisition

namespace armsig::acquisition {
namespace {

// A sweep's order: every configuration once, from the first, each next the nearest of those
// left; on a well-spread plan the robot's path (the largest joint turn per leg, summed) is
// shorter than the plan's own order.
TEST(SweepOrderTest, VisitsEachConfigurationOnceNearestFirst) {
  const Plan plan = WellSpreadPlan(testing::Ur10(), 30, 300, 3);
  const Plan swept = SweepOrder(plan);
  ASSERT_EQ(swept.size(), plan.size());
  std::set<std::string> labels;
  for (const auto& c : swept) labels.insert(c.label);
  EXPECT_EQ(labels.size(), plan.size());
  EXPECT_EQ(swept.front().label, plan.front().label);
  const auto length = [](const Plan& p) {
    double sum = 0.0;
    for (size_t k = 1; k < p.size(); ++k)
      sum += (p[k].joints_rad - p[k - 1].joints_rad).cwiseAbs().maxCoeff();
    return sum;
  };
  EXPECT_LT(length(swept), 0.8 * length(plan));
  // Each next is the nearest of those left (checked independently for the second leg).
  double nearest = 1e9;
  for (size_t k = 1; k < plan.size(); ++k)
    nearest = std::min(nearest, (plan[k].joints_rad - plan[0].joints_rad).cwiseAbs().maxCoeff());
  EXPECT_DOUBLE_EQ((swept[1].joints_rad - swept[0].joints_rad).cwiseAbs().maxCoeff(), nearest);
}

}  // namespace
}  // namespace armsig::acquisition
