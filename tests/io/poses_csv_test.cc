#include "io/poses_csv.h"

#include <gtest/gtest.h>

#include <cmath>

#include "core/error.h"
#include "test_support.h"

namespace armsig::io {

TEST(PosesCsv, ReadsAnyAngleUnitAndIgnoresExtraColumns) {
  testing::TempDir dir;
  testing::WriteText(dir.File("p.csv"),
                     "pose,q1_deg,q2_gon,q3_rad,note,x_mm,y_mm,z_mm\n"
                     "A,90,100,0.5,hello,1,2,3\n");
  const auto poses = ReadPosesCsv(dir.File("p.csv"), 3);
  ASSERT_EQ(poses.size(), 1u);
  EXPECT_NEAR(poses[0].joints_rad(0), M_PI / 2, 1e-15);
  EXPECT_NEAR(poses[0].joints_rad(1), M_PI / 2, 1e-15);
  EXPECT_NEAR(poses[0].joints_rad(2), 0.5, 1e-15);
  EXPECT_EQ(poses[0].target_in_world, Eigen::Vector3d(1, 2, 3));
}

TEST(PosesCsv, RoundTripsThroughFormat) {
  MeasuredPose p{"X1", Eigen::VectorXd::LinSpaced(6, -1.0, 1.0), {100.25, -3.5, 7.125}};
  testing::TempDir dir;
  testing::WriteText(dir.File("p.csv"), FormatPosesCsv({p}));
  const auto back = ReadPosesCsv(dir.File("p.csv"), 6);
  EXPECT_EQ(back[0].id, "X1");
  EXPECT_LT((back[0].joints_rad - p.joints_rad).norm(), 1e-11);
  EXPECT_LT((back[0].target_in_world - p.target_in_world).norm(), 1e-9);
}

TEST(PosesCsv, RejectsDuplicatesMissingJointsAndTooManyJoints) {
  testing::TempDir dir;
  testing::WriteText(dir.File("dup.csv"), "pose,q1_deg,x_mm,y_mm,z_mm\nA,1,1,2,3\nA,2,1,2,3\n");
  EXPECT_THROW(ReadPosesCsv(dir.File("dup.csv"), 1), InputError);
  EXPECT_THROW(ReadPosesCsv(dir.File("dup.csv"), 2), InputError);  // no q2
  testing::WriteText(dir.File("q7.csv"), "pose,q1_deg,q2_deg,x_mm,y_mm,z_mm\nA,1,2,1,2,3\n");
  EXPECT_THROW(ReadPosesCsv(dir.File("q7.csv"), 1), InputError);
  testing::WriteText(dir.File("empty.csv"), "pose,q1_deg,x_mm,y_mm,z_mm\n");
  EXPECT_THROW(ReadPosesCsv(dir.File("empty.csv"), 1), InputError);
}

TEST(PosesCsv, ImportsTheRealUr10FileAsItIs) {
  // ../shared/data/ur10-ipa (MIT): ';', decimal comma, named columns, rad, mm.
  const auto poses =
      ImportPoses(testing::DataPath("ur10-ipa/series_C-measurements_random_poses.csv"),
                  PoseImportOptions::UrIpa());
  EXPECT_EQ(poses.size(), 2773u);
  // First data row: joints -3,14159;-1,5708;0;-1,5708;0;0, measurement
  // 383,97123;-3240,7562;201,72621.
  EXPECT_NEAR(poses[0].joints_rad(0), -3.14159, 1e-12);
  EXPECT_NEAR(poses[0].joints_rad(1), -1.5708, 1e-12);
  EXPECT_NEAR(poses[0].target_in_world.x(), 383.97123, 1e-9);
  EXPECT_NEAR(poses[0].target_in_world.y(), -3240.7562, 1e-9);
  EXPECT_NEAR(poses[0].target_in_world.z(), 201.72621, 1e-9);
}

}  // namespace armsig::io
