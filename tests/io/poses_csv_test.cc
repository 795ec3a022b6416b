#include "io/poses_csv.h"

#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "core/error.h"
#include "core/units.h"
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
  // …and the T-Mac's orientation: measurement_rx/ry/rz -90,179563;-20,112975;-90,157388 (deg)
  // with std 0,0024569;0,0065397;0,008348 (deg), R = Rx(rx)·Ry(ry)·Rz(rz).
  ASSERT_TRUE(poses[0].orientation);
  const double deg = M_PI / 180.0;
  const Eigen::Matrix3d expected =
      (Eigen::AngleAxisd(-90.179563 * deg, Eigen::Vector3d::UnitX()) *
       Eigen::AngleAxisd(-20.112975 * deg, Eigen::Vector3d::UnitY()) *
       Eigen::AngleAxisd(-90.157388 * deg, Eigen::Vector3d::UnitZ()))
          .toRotationMatrix();
  EXPECT_LT((poses[0].orientation->world_from_target - expected).norm(), 1e-12);
  ASSERT_TRUE(poses[0].orientation->sigma_rad);
  EXPECT_LT((*poses[0].orientation->sigma_rad -
             Eigen::Vector3d(0.0024569, 0.0065397, 0.008348) * deg)
                .norm(),
            1e-15);
  for (const auto& p : poses) EXPECT_TRUE(p.orientation && p.orientation->sigma_rad) << p.id;
}

namespace {
Eigen::Matrix3d RxRyRz(double rx, double ry, double rz) {
  return (Eigen::AngleAxisd(rx, Eigen::Vector3d::UnitX()) *
          Eigen::AngleAxisd(ry, Eigen::Vector3d::UnitY()) *
          Eigen::AngleAxisd(rz, Eigen::Vector3d::UnitZ()))
      .toRotationMatrix();
}
}  // namespace

TEST(PosesCsv, ReadsTheMeasuredOrientationAndItsSigmasInAnyAngleUnit) {
  testing::TempDir dir;
  testing::WriteText(dir.File("p.csv"),
                     "pose,q1_deg,x_mm,y_mm,z_mm,rx_deg,ry_gon,rz_rad,sigma_rx_arcsec,"
                     "sigma_ry_arcsec,sigma_rz_arcsec\n"
                     "A,10,1,2,3,30,50,0.25,3.6,7.2,10.8\n"
                     "B,20,1,2,3,,,,,,\n"
                     "C,30,1,2,3,-90,0,3.141592653589793,,,\n");
  const auto poses = ReadPosesCsv(dir.File("p.csv"), 1);
  ASSERT_EQ(poses.size(), 3u);
  ASSERT_TRUE(poses[0].orientation);
  EXPECT_LT((poses[0].orientation->world_from_target - RxRyRz(M_PI / 6, M_PI / 4, 0.25)).norm(),
            1e-14);
  ASSERT_TRUE(poses[0].orientation->sigma_rad);
  EXPECT_LT((*poses[0].orientation->sigma_rad - Eigen::Vector3d(3.6, 7.2, 10.8) * kRadPerArcsec)
                .norm(),
            1e-18);
  EXPECT_FALSE(poses[1].orientation);  // position-only: every orientation field empty
  ASSERT_TRUE(poses[2].orientation);
  EXPECT_FALSE(poses[2].orientation->sigma_rad);
  EXPECT_LT((poses[2].orientation->world_from_target - RxRyRz(-M_PI / 2, 0, M_PI)).norm(), 1e-14);
}

TEST(PosesCsv, RefusesPartOfAnOrientation) {
  testing::TempDir dir;
  auto refused = [&](const std::string& text, const std::string& expected) {
    testing::WriteText(dir.File("p.csv"), text);
    try {
      ReadPosesCsv(dir.File("p.csv"), 1);
      ADD_FAILURE() << "accepted: " << text;
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find(expected), std::string::npos) << e.what();
    }
  };
  refused("pose,q1_deg,x_mm,y_mm,z_mm,rx_deg,ry_deg\nA,1,1,2,3,4,5\n", "2 of the orientation");
  refused("pose,q1_deg,x_mm,y_mm,z_mm,rx_deg,ry_deg,rz_deg\nA,1,1,2,3,4,,6\n", "p.csv:2:7");
  refused("pose,q1_deg,x_mm,y_mm,z_mm,rx,ry_deg,rz_deg\nA,1,1,2,3,4,5,6\n", "has no unit");
  refused(
      "pose,q1_deg,x_mm,y_mm,z_mm,rx_deg,ry_deg,rz_deg,sigma_rx_deg,sigma_ry_deg,sigma_rz_deg\n"
      "A,1,1,2,3,4,5,6,1,1,1\n",
      "expected sigma_rx_arcsec");
  refused("pose,q1_deg,x_mm,y_mm,z_mm,sigma_rx_arcsec,sigma_ry_arcsec,sigma_rz_arcsec\n"
          "A,1,1,2,3,1,1,1\n",
          "without the angles");
  refused(
      "pose,q1_deg,x_mm,y_mm,z_mm,rx_deg,ry_deg,rz_deg,sigma_rx_arcsec,sigma_ry_arcsec,"
      "sigma_rz_arcsec\nA,1,1,2,3,,,,1,1,1\n",
      "whose angles are empty");
  refused(
      "pose,q1_deg,x_mm,y_mm,z_mm,rx_deg,ry_deg,rz_deg,sigma_rx_arcsec,sigma_ry_arcsec,"
      "sigma_rz_arcsec\nA,1,1,2,3,1,2,3,1,0,1\n",
      "angular sigma");
}

TEST(PosesCsv, OrientationRoundTripsThroughFormat) {
  MeasuredPose a{"A", Eigen::VectorXd::LinSpaced(6, -1.0, 1.0), {100.25, -3.5, 7.125}};
  a.orientation = MeasuredOrientation{RxRyRz(-1.5739, -0.3510, 1.2), Eigen::Vector3d(1e-5, 2e-5, 3e-5)};
  MeasuredPose b{"B", Eigen::VectorXd::LinSpaced(6, 1.0, -1.0), {1, 2, 3}};  // position only
  MeasuredPose c = b;
  c.id = "C";
  c.orientation = MeasuredOrientation{RxRyRz(3.0, 1.2, -3.0), std::nullopt};
  testing::TempDir dir;
  const std::string text = FormatPosesCsv({a, b, c});
  EXPECT_EQ(text.substr(0, text.find('\n')),
            "pose,q1_deg,q2_deg,q3_deg,q4_deg,q5_deg,q6_deg,x_mm,y_mm,z_mm,rx_deg,ry_deg,rz_deg,"
            "sigma_rx_arcsec,sigma_ry_arcsec,sigma_rz_arcsec");
  testing::WriteText(dir.File("p.csv"), text);
  const auto back = ReadPosesCsv(dir.File("p.csv"), 6);
  ASSERT_EQ(back.size(), 3u);
  ASSERT_TRUE(back[0].orientation && back[0].orientation->sigma_rad);
  EXPECT_LT((back[0].orientation->world_from_target - a.orientation->world_from_target).norm(),
            1e-11);
  EXPECT_LT((*back[0].orientation->sigma_rad - *a.orientation->sigma_rad).norm(), 1e-13);
  EXPECT_FALSE(back[1].orientation);
  ASSERT_TRUE(back[2].orientation);
  EXPECT_FALSE(back[2].orientation->sigma_rad);
  EXPECT_LT((back[2].orientation->world_from_target - c.orientation->world_from_target).norm(),
            1e-11);
  // Position-only poses keep the position-only header.
  const std::string plain = FormatPosesCsv({b});
  EXPECT_EQ(plain.substr(0, plain.find('\n')),
            "pose,q1_deg,q2_deg,q3_deg,q4_deg,q5_deg,q6_deg,x_mm,y_mm,z_mm");
}

TEST(PoseImport, OrientationColumnsNeedAUnitAndComeInThrees) {
  testing::TempDir dir;
  testing::WriteText(dir.File("t.csv"), "j1;x;y;z;a;b;c;sa;sb;sc\n0,5;1;2;3;90;0;0;0,01;0,01;0,01\n");
  PoseImportOptions o;
  o.joint_columns = {"j1"};
  o.xyz_columns = {"x", "y", "z"};
  o.rotation_columns = {"a", "b", "c"};
  EXPECT_THROW(ImportPoses(dir.File("t.csv"), o), InputError);  // no unit
  o.rotation_unit = AngleUnit::kDeg;
  auto poses = ImportPoses(dir.File("t.csv"), o);
  ASSERT_TRUE(poses[0].orientation);
  EXPECT_FALSE(poses[0].orientation->sigma_rad);
  EXPECT_LT((poses[0].orientation->world_from_target - RxRyRz(M_PI / 2, 0, 0)).norm(), 1e-15);
  o.rotation_sigma_columns = {"sa", "sb", "sc"};
  poses = ImportPoses(dir.File("t.csv"), o);
  ASSERT_TRUE(poses[0].orientation->sigma_rad);
  EXPECT_NEAR((*poses[0].orientation->sigma_rad)(2), 0.01 * M_PI / 180, 1e-18);
  o.rotation_columns = {"a", "b"};
  EXPECT_THROW(ImportPoses(dir.File("t.csv"), o), InputError);
  o.rotation_columns = {"a", "b", "x"};  // a column that is also a coordinate
  EXPECT_THROW(ImportPoses(dir.File("t.csv"), o), InputError);
}

}  // namespace armsig::io
