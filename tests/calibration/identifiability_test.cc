#include "calibration/identifiability.h"

#include <gtest/gtest.h>

#include <random>

#include "calibration/estimation.h"
#include "calibration/synthetic.h"
#include "test_support.h"

namespace armsig::calibration {
namespace {

std::vector<int> Range(int n) {
  std::vector<int> v(n);
  for (int i = 0; i < n; ++i) v[i] = i;
  return v;
}

int RankOf(const RobotModel& model, const std::vector<int>& candidates, unsigned seed = 3) {
  std::mt19937 rng(seed);
  const auto joints = RandomConfigurations(model, 80, rng);
  return AnalyseIdentifiability(model, Eigen::Isometry3d::Identity(), joints, candidates).rank;
}

}  // namespace

// Paper: "out of the 39 geometric parameters, only 25 can be estimated" (target on the
// joint-6 axis); with h1…h4 all four add: 29.
TEST(Identifiability, TargetOnJointSixAxisGives25Of39And29Of43) {
  const auto model = testing::Puma();
  EXPECT_EQ(RankOf(model, Range(39)), 25);
  EXPECT_EQ(RankOf(model, Range(43)), 29);
}

// A target off the joint-6 axis makes joint 6's own parameters visible: 27 (31).
TEST(Identifiability, TargetOffTheAxisGives27Of39And31Of43) {
  auto model = testing::Puma();
  model.tool_mm = Eigen::Vector3d(40.0, -25.0, 80.0);
  EXPECT_EQ(RankOf(model, Range(39)), 27);
  EXPECT_EQ(RankOf(model, Range(43)), 31);
}

TEST(Identifiability, RankDoesNotDependOnTheMeasuringFrame) {
  const auto model = testing::Puma();
  std::mt19937 rng(5);
  const auto joints = RandomConfigurations(model, 60, rng);
  Eigen::Isometry3d far = Eigen::Isometry3d::Identity();
  far.rotate(Eigen::AngleAxisd(2.9, Eigen::Vector3d(1, 2, 3).normalized()));
  far.translation() << 1e4, -2e4, 3e3;
  EXPECT_EQ(AnalyseIdentifiability(model, far, joints, Range(43)).rank, 29);
}

TEST(Identifiability, ReportsWhatEachLeftOutParameterDependsOn) {
  const auto model = testing::Puma();
  std::mt19937 rng(3);
  const auto joints = RandomConfigurations(model, 80, rng);
  const auto report =
      AnalyseIdentifiability(model, Eigen::Isometry3d::Identity(), joints, Range(39));
  ASSERT_EQ(report.unidentified.size(), 14u);
  EXPECT_EQ(report.dependencies.size(), 14u);
  EXPECT_EQ(report.structural_rank, 25);
  for (const auto& dep : report.dependencies) {
    EXPECT_LT(dep.residual, 1e-6) << model.ParameterNames()[dep.parameter];
  }
  // With the target on the joint-6 axis, γ6 (a turn about that axis) moves nothing.
  const int gamma6 = model.IndexOf("gamma6");
  EXPECT_NE(std::find(report.unidentified.begin(), report.unidentified.end(), gamma6),
            report.unidentified.end());
}

TEST(Identifiability, FrozenJointShowsTheRankDropAndNamesAffectedParameters) {
  const auto model = testing::Puma();
  std::mt19937 rng(3);
  auto joints = RandomConfigurations(model, 80, rng);
  for (auto& q : joints) q(3) = 0.3;  // joint 4 never moves
  const auto report =
      AnalyseIdentifiability(model, Eigen::Isometry3d::Identity(), joints, Range(39));
  EXPECT_LT(report.rank, 25);
  EXPECT_EQ(report.structural_rank, 25);
  ASSERT_EQ(report.frozen_joints.size(), 1u);
  EXPECT_EQ(report.frozen_joints[0].joint, 3);
  EXPECT_FALSE(report.frozen_joints[0].affected.empty());
  // The parameters around joint 4 are among the affected ones.
  bool names_joint4 = false;
  for (int p : report.frozen_joints[0].affected) {
    const std::string name = model.ParameterNames()[p];
    names_joint4 |= name.back() == '4' || name.back() == '5';
  }
  EXPECT_TRUE(names_joint4);
}

}  // namespace armsig::calibration
